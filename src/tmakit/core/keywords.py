"""The conventions of public keywords: random sources, and renamed keywords kept for a release.

``rng=`` takes a Generator or a seed (:func:`study_seed`); a renamed keyword warns for one
release (:func:`renamed_keyword`).
"""

from __future__ import annotations

import enum
import warnings
from typing import TypeVar

import numpy as np

__all__ = ["NOT_GIVEN", "NotGiven", "RngLike", "as_generator", "renamed_keyword", "study_seed"]

#: A random source: a Generator, a seed (int >= 0), or None for fresh entropy.
RngLike = np.random.Generator | int | None

T = TypeVar("T")


def as_generator(rng: RngLike) -> np.random.Generator:
    """Give a Generator for a Generator (as is), a seed, or None (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


class NotGiven(enum.Enum):
    """The default of a deprecated keyword, told apart from an explicit None."""

    NOT_GIVEN = "not given"


NOT_GIVEN = NotGiven.NOT_GIVEN


def renamed_keyword(where: str, old: str, old_value: T | NotGiven, new: str, new_value: T,
                    default: T) -> T:
    """Give the value of a renamed keyword: the new one's, or the old one's with a warning."""
    if isinstance(old_value, NotGiven):
        return new_value
    warnings.warn(f"{where}({old}=...) is deprecated; use {new}=", DeprecationWarning,
                  stacklevel=3)
    if new_value is not default and not (type(new_value) is type(default)
                                         and new_value == default):
        raise TypeError(f"{where}() got both {new} and {old}; give {new} only")
    return old_value


def study_seed(rng: RngLike) -> int | None:
    """Give the integer seed of a study from ``rng``."""
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, 2**63))
    if rng is not None and (isinstance(rng, bool) or not isinstance(rng, int | np.integer)
                            or rng < 0):
        raise ValueError(f"rng must be a numpy.random.Generator, a whole number >= 0 or None, "
                         f"got {rng!r}")
    return None if rng is None else int(rng)
