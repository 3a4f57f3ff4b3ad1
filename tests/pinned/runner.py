"""Run one pinned ``tma`` command in-process and return its parsed JSON output."""

import contextlib
import io
import json
import os
from pathlib import Path


def tma(folder: Path, args: list[str]) -> str:
    """Run ``tma ARGS`` in ``folder`` and return its standard output (exit 0 or 1 accepted)."""
    import sys

    from tmakit.cli import main

    out, err = io.StringIO(), io.StringIO()
    old_cwd, old_argv = Path.cwd(), sys.argv
    code = 0
    try:
        os.chdir(folder)
        sys.argv = ["tma", *args]
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main()
            except SystemExit as stop:
                code = stop.code or 0
    finally:
        os.chdir(old_cwd)
        sys.argv = old_argv
    if code not in (0, 1):
        raise RuntimeError(f"tma {' '.join(args)} exited {code}:\n{err.getvalue()}{out.getvalue()}")
    return out.getvalue()


def run_pinned(folder: Path, setup: list[list[str]], command: list[str]) -> object:
    """Run the set-up commands whose outputs are missing, then ``command``; parse its JSON."""
    folder.mkdir(parents=True, exist_ok=True)
    for step in setup:
        if not (folder / step[step.index("-o") + 1]).exists():
            tma(folder, step)
    return json.loads(tma(folder, command))
