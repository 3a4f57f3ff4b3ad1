"""No traceback reaches a user of ``tma``: the guard around every command, and its exit statuses.

Nothing numerical is imported here.
"""

from __future__ import annotations

import errno
import functools
import os
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import typer
from rich.markup import escape

from .common import err, fail, note_arguments

__all__ = ["EXIT_BAD_INPUT", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "EXIT_NO_ANSWER", "EXIT_STATUS",
           "EXIT_TERMINATED", "WRITE_ERRORS", "guarded", "install_sigterm", "set_debug",
           "write_failed"]

EXIT_STATUS = 1
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 3
EXIT_NO_ANSWER = 4
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

_state = {"debug": bool(os.environ.get("TMA_DEBUG"))}

WRITE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO, errno.EFBIG})
"""Errors of writing output that are the machine's, not tmakit's (full disk, read-only ...)."""


def write_failed(exc: OSError, command: str) -> int:
    """Say in one line that output could not be written; give the exit status (1)."""
    where = f" {exc.filename}" if exc.filename else " its output"
    name = f"tma {command}".strip()
    try:
        sys.stderr.write(f"error: `{name}` could not write{where}: {exc.strerror or exc}\n")
        sys.stderr.flush()
    except OSError:
        pass  # (stderr itself unwritable: the status says it)
    return EXIT_STATUS


class Terminated(BaseException):
    """Raised in the main thread by SIGTERM so that ``finally`` blocks (temp files) run."""


def set_debug(on: bool) -> None:
    """Show tracebacks and RuntimeWarnings on the terminal (``tma --debug``)."""
    _state["debug"] = bool(on) or bool(os.environ.get("TMA_DEBUG"))


def install_sigterm() -> None:
    """Turn SIGTERM into :class:`Terminated` so that temporary files are removed."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return

    def _raise(signum: int, frame: Any) -> None:
        raise Terminated

    signal.signal(signal.SIGTERM, _raise)


def _where(exc: BaseException) -> str:
    """Name the innermost tmakit function on the traceback: what was being computed."""
    where = ""
    for frame, _ in traceback.walk_tb(exc.__traceback__):
        module = frame.f_globals.get("__name__", "")
        if module.startswith("tmakit.") and not module.startswith("tmakit.cli"):
            where = f"{module}.{frame.f_code.co_name}"
    return where


def _report(exc: BaseException, command: str, caught: list[warnings.WarningMessage]) -> int:
    text = "".join(traceback.format_exception(exc))
    if caught:
        text += f"\n{len(caught)} RuntimeWarning(s) during the command:\n" + "".join(
            f"  {w.filename}:{w.lineno}: {w.message}\n" for w in caught[:50])
    where = _where(exc)
    what = f" while computing {where}" if where else ""
    message = f"{type(exc).__name__}: {exc}".strip().rstrip(":")
    if len(message) > 400:
        message = message[:400] + " ..."
    if _state["debug"]:
        sys.stderr.write(text)
        hint = "please report, with the traceback above"
    else:
        try:
            log = (Path(os.environ.get("TMA_LOG_DIR") or tempfile.gettempdir())
                   / f"tma-error-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log")
            log.write_text(f"tma {command}\n{text}")
            hint = f"please report; traceback in {log}"
        except OSError:
            hint = "please report; rerun with tma --debug for the traceback"
    err.print(f"[bold red]error:[/] internal error in `tma {command}`{what}: "
              f"{escape(f'{message} ({hint})')}", markup=True, soft_wrap=True)
    return EXIT_INTERNAL


def _interrupted(code: int, why: str) -> int:
    err.print(f"[bold red]{why}[/]", markup=True)
    return code


def _refuse_non_finite(options: dict[str, Any]) -> None:
    """Refuse NaN or infinite numeric options (``--at nan``, ``--ref-time inf``): exit 2."""
    import math

    for name, value in options.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise fail(f"--{name.replace('_', '-')} {value}: expected a finite number")


def guarded(command: Callable[..., Any]) -> Callable[..., Any]:
    """Wrap a ``tma`` command: unexpected exceptions become ``error: ...`` (exit 3)."""

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        _refuse_non_finite(kwargs)
        note_arguments(kwargs)  # the files they name are inputs: never written over
        caught: list[warnings.WarningMessage] = []
        others: list[warnings.WarningMessage] = []  # meant for the user: shown after recording
        try:
            with warnings.catch_warnings(record=not _state["debug"]) as record:
                if not _state["debug"]:
                    warnings.simplefilter("always", RuntimeWarning)
                try:
                    return command(*args, **kwargs)
                finally:
                    # Only sorted here: showing one while recording would record it again.
                    for w in record or []:
                        (caught if issubclass(w.category, RuntimeWarning) else others).append(w)
        except (typer.Exit, click.exceptions.ClickException, click.exceptions.Exit,
                click.exceptions.Abort):
            raise
        except KeyboardInterrupt:
            raise typer.Exit(_interrupted(EXIT_INTERRUPTED, "interrupted")) from None
        except Terminated:
            raise typer.Exit(_interrupted(EXIT_TERMINATED, "terminated")) from None
        except OSError as exc:
            if exc.errno not in WRITE_ERRORS or _state["debug"]:
                if _state["debug"]:
                    raise
                raise typer.Exit(_report(exc, command.__name__, caught)) from None
            raise typer.Exit(write_failed(exc, command.__name__)) from None
        except MemoryError:
            err.print(f"[bold red]error:[/] `tma {command.__name__}` ran out of memory; ask "
                      "for less work (fewer runs, rows or particles)", markup=True, soft_wrap=True)
            raise typer.Exit(EXIT_BAD_INPUT) from None
        except Exception as exc:  # the point: nothing escapes as a traceback
            if _state["debug"]:  # tma --debug: the exception itself, traceback and all
                raise
            raise typer.Exit(_report(exc, command.__name__, caught)) from None
        finally:
            for w in others:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)

    return run
