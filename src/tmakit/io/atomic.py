"""One way to write a file safely: a temporary file in the same folder, moved into place.

A failure never leaves a partial file nor damages an existing one.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
from collections.abc import Iterator
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no advisory locks, stale files stay
    fcntl = None  # type: ignore[assignment]

__all__ = ["TEMP_PATTERN", "atomic_write", "clean_stale_temporaries", "exists_error",
           "fsync_file"]

#: The names of tmakit's temporary files: ``.NAME.<12 hex digits>.tmp[.suffix]``.
TEMP_PATTERN = re.compile(r"^\..+\.[0-9a-f]{12}\.tmp(\.[A-Za-z0-9]{1,8})?$")


def exists_error(path: str | os.PathLike[str]) -> FileExistsError:
    """Build the error for refusing to overwrite ``path``.

    It names the parameter ``force=True``; the command line says ``--force`` in its own message.

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


def clean_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove tmakit's temporary files in ``folder`` that no live writer holds."""
    removed: list[Path] = []
    if fcntl is None:
        return removed
    try:
        names = [e.name for e in os.scandir(folder) if TEMP_PATTERN.match(e.name)]
    except OSError:
        return removed
    for name in names:
        tmp = Path(folder) / name
        try:
            fd = os.open(tmp, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # a live writer holds it
            os.close(fd)
            continue
        try:
            tmp.unlink()
            removed.append(tmp)
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


def _create_locked(path: Path, keep_suffix: bool) -> tuple[Path, int]:
    """Create and lock a new temporary file beside ``path``; return it and its descriptor."""
    suffix = path.suffix if keep_suffix else ""
    while True:
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp{suffix}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        if fcntl is None:
            return tmp, fd
        fcntl.flock(fd, fcntl.LOCK_EX)
        try:  # a cleaner may have removed it between creation and locking: start again
            if os.stat(tmp).st_ino == os.fstat(fd).st_ino:
                return tmp, fd
        except FileNotFoundError:
            pass
        os.close(fd)


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], force: bool = False,
                 keep_suffix: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: yield a new empty temporary file, then move it into place.

    Use as ``with atomic_write(path, force) as tmp: write(tmp)``.  Without ``force`` the move is
    a hard link, so a file created meanwhile is never overwritten; on any failure the temporary
    file is removed and ``path`` left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.
    force : bool, optional
        Overwrite an existing file (default: refuse).
    keep_suffix : bool, optional
        End the temporary file's name with the suffix of ``path`` (for writers, such as matplotlib,
        that choose the format by the suffix).

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
    clean_stale_temporaries(path.parent)
    tmp, fd = _create_locked(path, keep_suffix)
    try:
        yield tmp
        _move_into_place(tmp, path, force)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    finally:
        os.close(fd)


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
    """Flush a written file to disk (before it is moved into place)."""
    with open(path, "rb+") as f:
        os.fsync(f.fileno())
