"""The error a measurement file raises when it breaks the file contract."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

__all__ = ["MAX_LISTED_PROBLEMS", "NOTES_SEPARATOR", "READER_NOTES_KEY", "MeasurementFileError",
           "add_reader_notes", "reader_notes"]

#: At most this many problems are listed in a :class:`MeasurementFileError` message.
MAX_LISTED_PROBLEMS = 25


class MeasurementFileError(ValueError):
    """A measurement file that breaks the contract of ``docs/file-format.md``.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    problems : iterable of str
        One line per problem, in the order to show them
        (``row R (line L), column 'C': expected ..., found ...``).
    """

    def __init__(self, path: str | os.PathLike[str], problems: Iterable[str]) -> None:
        self.path = Path(path)
        self.problems = [str(p) for p in problems]
        super().__init__(self._message())

    def _message(self) -> str:
        n = len(self.problems)
        if n == 0:
            return f"{self.path}: not a valid measurement file"
        head = f"{self.path}: {n} problem{'s' if n != 1 else ''} in the measurement file:"
        lines = [head, *(f"  - {p}" for p in self.problems[:MAX_LISTED_PROBLEMS])]
        if n > MAX_LISTED_PROBLEMS:
            rest = n - MAX_LISTED_PROBLEMS
            lines.append(f"  ... and {rest} more problem{'s' if rest != 1 else ''}")
        return "\n".join(lines)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle by path and problems (the message is rebuilt from them)."""
        return (type(self), (self.path, self.problems))


#: Metadata key of a reader's notes and warnings (``note: ...`` / ``warning: ...``), joined by
#: :data:`NOTES_SEPARATOR`: what was read in another way than written, or left out, and why.
READER_NOTES_KEY = "reader_notes"
NOTES_SEPARATOR = " || "


def reader_notes(metadata: dict[str, str], pop: bool = False) -> list[str]:
    """Return a set's reader notes (``note: ...`` or ``warning: ...``), optionally removing them."""
    text = metadata.pop(READER_NOTES_KEY, "") if pop else metadata.get(READER_NOTES_KEY, "")
    return [n for n in text.split(NOTES_SEPARATOR) if n]


def add_reader_notes(metadata: dict[str, str], *notes: str) -> None:
    """Add notes to a set's reader notes (kept in the metadata under :data:`READER_NOTES_KEY`)."""
    if every := [*reader_notes(metadata), *notes]:
        metadata[READER_NOTES_KEY] = NOTES_SEPARATOR.join(every)


def refuse_unreadable(path: Path, binary: bool = False) -> None:
    """Refuse, before reading, a path that is no regular file, or binary where text is due."""
    from ..core.input_files import binary_problem, not_regular_problem

    problem = not_regular_problem(path) or (None if binary else binary_problem(path))
    if problem is not None:
        raise MeasurementFileError(path, [problem])
