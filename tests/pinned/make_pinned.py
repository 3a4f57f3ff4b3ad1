"""Rewrite ``expected.json`` from the current code (see ``commands.py``)."""

import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from commands import PINNED
from runner import run_pinned


def main() -> None:
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, setup, command in PINNED:
            out[name] = run_pinned(Path(tmp), setup, command)
            print(name, "ok")
    Path(__file__).with_name("expected.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
