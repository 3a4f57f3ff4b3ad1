"""Output paths checked before any work starts, and pictures written atomically.

:func:`check_output` resolves each output to the exact file (a picture without a suffix gets
``.png``) and refuses it, naming the option, when it exists without ``--force``, is a folder, or
cannot be written.  Nothing numerical is imported here.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from .common import fail, refuse_existing

__all__ = ["PAGE_SUFFIXES", "PICTURE_SUFFIXES", "SOLUTION_SUFFIXES", "TABLE_SUFFIXES",
           "check_output", "check_outputs",
           "claim_outputs", "write_picture"]

#: Suffixes of pictures (matplotlib's formats that tmakit promises).
PICTURE_SUFFIXES = (".png", ".pdf", ".svg")
#: Suffixes of tables and measurement files (CSV, Parquet).
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
#: Suffixes of the solution page (``--html``).
PAGE_SUFFIXES = (".html", ".htm")
#: Suffixes of an exported solution (``--export``: Debrief lines, GeoJSON, KML).
SOLUTION_SUFFIXES = (".rep", ".geojson", ".kml")

_FORMATS = {"picture": PICTURE_SUFFIXES, "table": TABLE_SUFFIXES, "json": None,
            "measurements": None, "page": PAGE_SUFFIXES, "solution": SOLUTION_SUFFIXES}


def check_output(path: Path | None, option: str, force: bool, kind: str = "table",
                 inputs: Iterable[Path] = ()) -> Path | None:
    """Resolve and check one output path before any computation."""
    if path is None:
        return None
    given, path = path, Path(path)
    suffixes = _FORMATS[kind]
    if kind == "picture" and path.suffix == "" and not path.is_dir():
        path = path.with_name(path.name + ".png")  # what matplotlib would write
    if path.is_dir():
        raise fail(f"{option} {path}: is a folder, not a file")
    if kind == "measurements":
        from ..io import find_format  # the registry: a new writable format is known here too
        from ..io.formats import registered_formats

        if find_format(path, reading=False) is None:
            known = sorted({x for f in registered_formats(False) for x in f.suffixes})
            raise fail(f"{option} {path}: unknown format {path.suffix or '(no suffix)'!r}; "
                       f"expected {', '.join(known)}")
    elif suffixes is not None and path.suffix.lower() not in suffixes:
        said = {"table": ".csv or .parquet", "picture": ".png, .pdf or .svg",
                "page": ".html", "solution": ".rep, .geojson or .kml"}[kind]
        raise fail(f"{option} {path}: unknown format {path.suffix or '(no suffix)'!r}; "
                   f"written as {said}")
    parent = path.parent
    if not parent.exists():
        raise fail(f"{option} {path}: the folder {parent} does not exist")
    if not parent.is_dir():
        raise fail(f"{option} {path}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise fail(f"{option} {path}: the folder {parent} cannot be written")
    if path.exists():
        for source in [*inputs, *_command_inputs(given)]:
            if Path(source).is_file() and _same_file(Path(source), path):
                raise fail(f"{option} {path}: is the input file {source} of this command; it "
                           "is never written over, --force or not: write to another file")
        refuse_existing(path, force)
    return path


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


#: The arguments of the running command, by name (set by :func:`tmakit.cli.guard.guarded`).
_ARGUMENTS: dict[str, Any] = {}


def note_arguments(arguments: dict[str, Any]) -> None:
    """Remember the running command's arguments: the files they name are its inputs."""
    _ARGUMENTS.clear()
    _ARGUMENTS.update(arguments)


def _command_inputs(given: object) -> list[Path]:
    """Every file named by the running command's arguments other than the output ``given``."""
    named: list[Path] = []
    for values in _ARGUMENTS.values():
        for value in values if isinstance(values, list | tuple) else [values]:
            if value is given or not isinstance(value, str | Path) or not str(value):
                continue
            try:
                if Path(value).is_file():
                    named.append(Path(value))
            except (OSError, ValueError):
                continue
    return named


def check_outputs(outputs: Iterable[tuple[str, Path | None, str]], force: bool,
                  inputs: Iterable[Path] = ()) -> list[Path | None]:
    """Check several outputs (:func:`check_output`) and refuse two options naming one file."""
    resolved: list[Path | None] = []
    seen: dict[Path, str] = {}
    inputs = list(inputs)
    for option, path, kind in outputs:
        p = check_output(path, option, force, kind, inputs)
        if p is not None:
            key = p.resolve()
            if key in seen:
                raise fail(f"{option} {p}: the same file as {seen[key]}")
            seen[key] = option
        resolved.append(p)
    return resolved


def _lock_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.tma-lock")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


@contextlib.contextmanager
def claim_outputs(paths: Iterable[Path | None]) -> Iterator[None]:
    """Hold the outputs of a long command for it alone while it runs (a lock file beside each).

    The lock is ``.NAME.tma-lock`` (the process id; a dead process's lock is taken over).
    """
    held: list[Path] = []
    try:
        for path in (p for p in paths if p is not None):
            lock = _lock_path(path)
            for _ in range(2):
                try:
                    fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
                except FileExistsError:
                    try:
                        pid = int(lock.read_text().strip() or "0")
                    except (OSError, ValueError):
                        pid = 0
                    if pid and _alive(pid):
                        raise fail(f"{path}: another tma run (process {pid}) is writing it; "
                                   f"write to another file, or wait (its lock: {lock})") from None
                    lock.unlink(missing_ok=True)  # the run that held it has ended
                    continue
                with os.fdopen(fd, "w") as f:
                    f.write(f"{os.getpid()}\n")
                held.append(lock)
                break
        yield
    finally:
        for lock in held:
            lock.unlink(missing_ok=True)


def write_picture(path: Path, force: bool, draw: Callable[[Path], Any]) -> None:
    """Draw a picture into a temporary file and move it into place (never a partial file)."""
    from ..io import atomic_write

    try:
        with atomic_write(path, force=force, keep_suffix=True) as tmp:
            draw(tmp)
    except FileExistsError:
        raise fail(f"{path} already exists; use --force to overwrite it") from None


def memory_limit() -> int:
    """Give the memory a command may plan to use (bytes): ``TMA_MAX_MEMORY_GB``, default 2."""
    try:
        gb = float(os.environ.get("TMA_MAX_MEMORY_GB", "2"))
    except ValueError:
        gb = 2.0
    return int(max(gb, 0.001) * 2**30)


def check_particles(particles: int | None, option: str = "--particles",
                    bytes_per_particle: int = 8 * 8 * 8) -> None:
    """Refuse a particle count whose working arrays would not fit the memory limit."""
    if particles is None:
        return
    need = particles * bytes_per_particle
    if need > memory_limit():
        raise fail(f"{option} {particles:,}: about {need / 2**30:.1f} GiB of working memory, "
                   f"more than the limit of {memory_limit() / 2**30:.1f} GiB; raise it with "
                   "TMA_MAX_MEMORY_GB=N")
