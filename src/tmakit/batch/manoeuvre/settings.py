"""The manoeuvre estimator's settings and what it keeps of every order it fits.

What the estimator is told is :class:`ManoeuvreSettings`; each order's fit is an
:class:`OrderFit`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...core.arrays import Array

CRITERIA = ("bic", "lrt")
"""Criteria for the number of manoeuvres and the accelerations held (see
:mod:`tmakit.batch.manoeuvre`)."""
ACCELERATIONS = ("select", "all")
"""How the accelerations are fitted (see :class:`ManoeuvreSettings`)."""


@dataclass(frozen=True)
class ManoeuvreSettings:
    """How the manoeuvre estimator searches (times in seconds).

    Parameters
    ----------
    max_manoeuvres : int
        The largest order tried.
    exact : bool
        Fit only ``max_manoeuvres``.
    criterion : {"bic", "lrt"}
        How the order and the held accelerations are chosen.
    alpha : float
        Level of the likelihood-ratio tests, in (0, 1).
    grid_step : float
        Spacing of the profile grid, s.
    min_segment : float
        Shortest segment, and the grid's distance from the data's ends, s.
    refine : int
        Profile minima refined per order.
    profile_iter : int
        Iterations of each held fit.
    max_tuples : int
        Beyond this many grid tuples only those extending the order below's best minima are fitted.
    prune : float
        Held fits stop once they cannot come within this (half chi2) of the best.
    polish_step, polish_rounds : float, int
        The finer profile after refinement (s; 0 rounds: none).
    max_iter : int
        Iterations of a refinement with every parameter free.
    accelerations : {"select", "all"}
        Hold unneeded accelerations at zero (default), or fit all.

    Raises
    ------
    ValueError
        For a setting out of its range, named.
    """

    max_manoeuvres: int = 2
    exact: bool = False
    criterion: str = "bic"
    alpha: float = 0.01
    grid_step: float = 40.0
    min_segment: float = 20.0
    refine: int = 3
    profile_iter: int = 12
    max_tuples: int = 400
    prune: float = 25.0
    polish_step: float = 4.0
    polish_rounds: int = 2
    max_iter: int = 100
    accelerations: str = "select"

    def __post_init__(self) -> None:
        """Refuse settings out of range."""
        if self.max_manoeuvres < 0 or int(self.max_manoeuvres) != self.max_manoeuvres:
            raise ValueError(f"max_manoeuvres must be a whole number >= 0, got "
                             f"{self.max_manoeuvres!r}")
        if self.criterion not in CRITERIA:
            raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got "
                             f"{self.criterion!r}")
        if not 0.0 < self.alpha < 1.0:
            raise ValueError(f"alpha must lie in (0, 1), got {self.alpha!r}")
        if not self.grid_step > 0 or not self.min_segment > 0:
            raise ValueError("grid_step and min_segment must be positive (seconds)")
        if self.refine < 1 or self.profile_iter < 1 or self.max_iter < 1:
            raise ValueError("refine, profile_iter and max_iter must be at least 1")
        if self.polish_rounds < 0 or not self.polish_step > 0:
            raise ValueError("polish_rounds must be >= 0 and polish_step positive (seconds)")
        if self.max_tuples < 1:
            raise ValueError("max_tuples must be at least 1")
        if self.accelerations not in ACCELERATIONS:
            raise ValueError(f"accelerations must be one of {', '.join(ACCELERATIONS)}, got "
                             f"{self.accelerations!r}")


@dataclass
class OrderFit:
    """The best fit with ``manoeuvres`` manoeuvres.

    Parameters
    ----------
    manoeuvres : int
    theta : ndarray
        Internal parameters (at the first measurement time), SI.
    nuisance : ndarray
    chi2 : float
    unknowns : int
        Motion and nuisance parameters fitted.
    converged : bool
    iterations : int
    starts : int
        Starts of the final refinement.
    note : str
        How the fit was settled, when it matters.
    profile_times, profile_chi2 : ndarray
        The profile grid's change-over times ``(G, M)``, s, and chi2 ``(G,)``.
    free : ndarray of bool, optional
        The internal parameters fitted; None: all.
    alternatives : list of OrderFit
        Other local minima of this order.
    """

    manoeuvres: int
    theta: Array
    nuisance: Array
    chi2: float
    unknowns: int
    converged: bool
    iterations: int
    starts: int
    note: str = ""
    profile_times: Array = field(default_factory=lambda: np.zeros((0, 0)))
    profile_chi2: Array = field(default_factory=lambda: np.zeros(0))
    free: NDArray[np.bool_] | None = None  # internal parameters fitted; None: all
    alternatives: list[OrderFit] = field(default_factory=list)

    def free_mask(self) -> NDArray[np.bool_]:
        """Which internal parameters are fitted (the others are accelerations held at 0).

        Returns
        -------
        ndarray of bool
            ``(p,)``, True where fitted.
        """
        return np.ones(self.theta.shape[0], dtype=bool) if self.free is None else self.free
