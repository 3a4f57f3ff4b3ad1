"""One way to write a file safely: a temporary file in the same folder, moved into place.

A failure never leaves a partial file nor damages an existing one.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_write", "exists_error", "fsync_file"]


def exists_error(path: str | os.PathLike[str]) -> FileExistsError:
    """Build the error for refusing to overwrite ``path``.

    It names the parameter ``force=True``; the command line says ``--force`` in its own
    message.

    Parameters
    ----------
    path : str or os.PathLike
        The existing file.

    Returns
    -------
    FileExistsError
        Not raised: the caller raises it.
    """
    return FileExistsError(f"{path} already exists; pass force=True to overwrite it")


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], force: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: yield a new empty temporary file, then move it into place.

    Use as ``with atomic_write(path, force) as tmp: write(tmp)``.  The temporary file lies in
    the folder of ``path`` (so the final move is one :func:`os.replace`, or a hard link when
    ``force`` is false so that a file created meanwhile is never overwritten).  On any failure
    inside the block the temporary file is removed and ``path`` is left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    force : bool, optional
        Overwrite an existing file (default: refuse).

    Yields
    ------
    pathlib.Path
        The temporary file (created empty) for the caller to write.

    Raises
    ------
    FileExistsError
        If ``path`` exists (checked before and, atomically, after writing) and not ``force``.
    IsADirectoryError
        If ``path`` is a folder.
    """
    path = Path(path)
    if path.exists() and not force:
        raise exists_error(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a folder, not a file")
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    try:
        yield tmp
        _move_into_place(tmp, path, force)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def _move_into_place(tmp: Path, path: Path, force: bool) -> None:
    if force:
        os.replace(tmp, path)
        return
    try:  # atomic "create only if absent": a hard link fails if the name exists
        os.link(tmp, path)
    except FileExistsError:
        raise exists_error(path) from None
    except OSError:  # no hard links on this file system
        if path.exists():
            raise exists_error(path) from None
        os.replace(tmp, path)
        return
    tmp.unlink()


def fsync_file(path: str | os.PathLike[str]) -> None:
    """Flush a written file to disk (before it is moved into place).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    """
    with open(path, "rb+") as f:
        os.fsync(f.fileno())
