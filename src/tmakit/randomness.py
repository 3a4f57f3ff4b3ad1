"""Sources of randomness, one convention: ``rng=`` takes a ``numpy.random.Generator`` or a seed.

A study that spawns one stream per run (the Monte Carlo, the planner's closed loop) needs an
integer seed it can record; :func:`study_seed` gives it from ``rng`` and keeps the older
``seed=`` keyword working for one release, with a ``DeprecationWarning``.
"""

from __future__ import annotations

import enum
import warnings

import numpy as np

__all__ = ["NOT_GIVEN", "NotGiven", "RngLike", "as_generator", "study_seed"]

#: A random source: a Generator, a seed (int >= 0), or None for fresh entropy.
RngLike = np.random.Generator | int | None


def as_generator(rng: RngLike) -> np.random.Generator:
    """Give a Generator for a Generator (as is), a seed, or None (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


class NotGiven(enum.Enum):
    """The default of a deprecated keyword, told apart from an explicit None."""

    NOT_GIVEN = "not given"


NOT_GIVEN = NotGiven.NOT_GIVEN


def study_seed(rng: RngLike, seed: int | NotGiven | None, where: str) -> int | None:
    """Give the integer seed of a study from ``rng`` (or the deprecated ``seed``).

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        A Generator (one integer is drawn from it), a seed, or None (fresh entropy, which the
        study records).
    seed : int, None or NOT_GIVEN
        The deprecated keyword; when given it stands for ``rng`` (which must be left at its
        default, 0) and warns.
    where : str
        The function's name, for the messages.

    Returns
    -------
    int or None
        The seed (>= 0), or None.

    Raises
    ------
    TypeError
        If both ``rng`` and ``seed`` are given.
    ValueError
        If the seed is not a whole number >= 0.
    """
    if seed is not NOT_GIVEN:
        warnings.warn(f"{where}(seed=...) is deprecated; use rng= (a seed or a "
                      f"numpy.random.Generator)", DeprecationWarning, stacklevel=3)
        if isinstance(rng, np.random.Generator) or rng != 0:  # 0 is rng's default
            raise TypeError(f"{where}() got both rng and seed; give rng only")
        rng = seed
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, 2**63))
    if rng is not None and (isinstance(rng, bool) or not isinstance(rng, int | np.integer)
                            or rng < 0):
        raise ValueError(f"rng must be a numpy.random.Generator, a whole number >= 0 or None, "
                         f"got {rng!r}")
    return None if rng is None else int(rng)
