"""What any file tmakit reads must be before it is read: a regular file, and text if text.

FIFOs, terminals and devices are refused, and a NUL byte in the first :data:`SNIFF_BYTES` of a
text file, naming the file.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path
from typing import Any

__all__ = ["SNIFF_BYTES", "binary_problem", "not_regular_problem", "read_toml"]

#: Bytes read from the start of a text file to tell it from a binary one.
SNIFF_BYTES = 1 << 16


def not_regular_problem(path: str | os.PathLike[str]) -> str | None:
    """Say why an existing path cannot be read as a file, or None."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    what = ("a folder" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
            else "a socket" if stat.S_ISSOCK(mode) else "a device")
    return (f"is {what}, not a regular file: tmakit reads files (write the data to a file "
            "first)")


def binary_problem(path: str | os.PathLike[str]) -> str | None:
    """Say why a regular file is not text (a NUL byte near its start), or None."""
    with open(Path(path), "rb") as f:
        head = f.read(SNIFF_BYTES)
    at = head.find(b"\x00")
    if at < 0:
        return None
    return (f"is not a text file (a NUL byte at byte {at}): a binary file where text (CSV, "
            "TOML, NMEA, GPX, Debrief) was expected")


def read_toml(path: Path, what: str, error: type[ValueError] = ValueError) -> dict[str, Any]:
    """Read a TOML file; raise ``error`` naming ``path`` (the ``what`` file) and its problem."""
    problem = not_regular_problem(path) or (path.is_file() and binary_problem(path))
    if problem:
        raise error(f"{path}: {problem}")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{path}: no such {what} file") from None
    except UnicodeDecodeError as e:
        raise error(f"{path}: not a UTF-8 text (TOML) file ({e.reason} at byte "
                    f"{e.start})") from None
    except OSError as e:  # a folder, no permission
        raise error(f"{path}: cannot be read ({e.strerror or e})") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path}: not valid TOML: {e}") from None
