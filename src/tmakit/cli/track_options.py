"""The options of ``tma track``: parsed and checked before the file is read.

Its library errors are translated here into the flags that would fix them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import typer

from .common import fail, parse_assignments

__all__ = ["TRACK_FLAGS", "check_track_options", "parse_prior", "parse_q", "tracking_failure"]


def parse_q(text: str, dim: int) -> list[float]:
    """Parse ``--q``: one number or per-axis numbers ``qx,qy[,qz]`` (m/s^2).

    Parameters
    ----------
    text : str
        The option's text.
    dim : int
        Spatial dimension (for the error message).

    Returns
    -------
    list of float
        The acceleration standard deviations (m/s^2).

    Raises
    ------
    typer.Exit
        Status 2 when a part is not a number.
    """
    try:
        return [float(p.strip()) for p in text.split(",")]
    except ValueError:
        raise fail(f"--q {text!r}: expected one number or {dim} numbers separated by commas "
                   "(m/s^2 per axis, e.g. 0.01 or "
                   f"{','.join(['0.01'] * dim)})") from None


#: The flags of `tma track` for the library parameters its errors name.
#: Fewest particles ``tma track`` takes: one more than a 3-D state's six values, the fewest
#: whose cloud can have a non-singular covariance.
MIN_PARTICLES = 7

TRACK_FLAGS = {"q": "--q", "dim": "--dim", "prior": "--prior", "prior_std": "--prior-std",
               "max_relative_std": "--start-std", "tracker": "--filter"}


def tracking_failure(e: Any) -> typer.Exit:
    """Translate a :class:`tmakit.tracking.TrackingError` into `tma track`'s words (its flags).

    Parameters
    ----------
    e : tmakit.tracking.TrackingError
        The library's error.

    Returns
    -------
    typer.Exit
        The exit (status 2) after printing the message with the flags named.
    """
    from ..tracking import MissingNuisanceError

    names = dict(TRACK_FLAGS)
    if isinstance(e, MissingNuisanceError):
        names["nuisance"] = ("nuisance={...}; --nuisance "
                             + ",".join(f"{n}=..." for n in e.names))
    return fail(e.render(names))


def check_track_options(output: Path | None, plot: Path | None, force: bool,
                        filter_name: str, particles: int | None, seed: int | None,
                        ellipses: int, rows: int, inputs: Sequence[object] = ()
                        ) -> tuple[Path | None, Path | None]:
    """Refuse bad ``tma track`` options before reading the file.

    Parameters
    ----------
    output, plot : Path or None
        ``-o`` and ``--plot``: not overwritten without ``force``; ``-o`` .csv or .parquet.
    force : bool
        ``--force``.
    filter_name : str
        ``--filter``: a name of :data:`tmakit.filters.FILTERS`.
    particles, seed : int or None
        ``--particles`` and ``--seed``: for the random (particle) filters only.
    ellipses, rows : int
        ``--ellipses`` (0 or more) and ``--rows`` (1 or more).
    inputs : sequence of Path or None, optional
        The files read (None: not given): never written over, even with ``force``.

    Returns
    -------
    tuple of (Path or None)
        The exact files ``-o`` and ``--plot`` will write.

    Raises
    ------
    typer.Exit
        Status 2 for the first bad option.
    """
    from .. import tracking
    from ..filters import FILTERS
    from .outputs import check_outputs, check_particles

    check_particles(particles)
    if particles is not None and particles < MIN_PARTICLES:
        raise fail(f"--particles {particles}: a cloud of fewer than {MIN_PARTICLES} particles "
                   "cannot span the target's state (4 or 6 values), so its covariance is "
                   "singular; use hundreds or more")
    output, plot = check_outputs([("-o", output, "table"), ("--plot", plot, "picture")], force,
                                 [p for p in inputs if isinstance(p, Path)])
    if filter_name not in FILTERS:
        raise fail(f"--filter {filter_name!r}: expected one of {', '.join(sorted(FILTERS))}")
    random_filters = tracking.random_filters()
    for option, value in (("--particles", particles), ("--seed", seed)):
        if value is not None and filter_name not in random_filters:
            raise fail(f"{option} applies only to the particle filter"
                       f"{'s' if len(random_filters) > 1 else ''} "
                       f"({', '.join(random_filters) or 'none registered'}), not to "
                       f"{filter_name}")
    if ellipses < 0 or rows < 1:
        raise fail("--ellipses must be 0 or more and --rows 1 or more")
    return output, plot


def parse_prior(prior: str | None, prior_std: str | None, nuisance: str | None,
                init_window: int | None) -> tuple[dict[str, float] | None, ...]:
    """``--prior``, ``--prior-std`` and ``--nuisance`` by name, checked to go together.

    Parameters
    ----------
    prior, prior_std, nuisance : str or None
        The options' ``name=value`` texts (m, m/s; Hz, dBW).
    init_window : int or None
        ``--init-window``, which cannot be combined with ``--prior``.

    Returns
    -------
    tuple of (dict or None)
        ``(prior_mean, prior_std, known_nuisance)``.

    Raises
    ------
    typer.Exit
        Status 2 when the options do not go together.
    """
    prior_mean = parse_assignments(prior, "--prior") or None
    prior_sd = parse_assignments(prior_std, "--prior-std") or None
    known = parse_assignments(nuisance, "--nuisance") or None
    if (prior_mean is None) != (prior_sd is None):
        raise fail("--prior and --prior-std go together (the state and its standard "
                   "deviations, by name)")
    if known is not None and prior_mean is None:
        raise fail("--nuisance goes with --prior; a batch start estimates the nuisance "
                   "values itself")
    if prior_mean is not None and init_window is not None:
        raise fail("--init-window chooses the batch start; it cannot be used with --prior")
    return prior_mean, prior_sd, known
