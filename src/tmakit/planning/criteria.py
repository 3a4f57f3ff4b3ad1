"""Planning criteria: scalar costs of a predicted Bayesian information matrix.

A criterion maps ``J`` (..., n, n) to a cost (...,) the planner minimises, vectorised over leading
axes: :class:`WeightedTrace` (``Tr{Pi J^{-1}}``, Hurtado & Nehorai (2008), eq. 12, m^2),
:class:`LogDet` (``log det`` of a block of ``J^{-1}``) or :class:`CustomCriterion`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..bounds.pcrb_recursion import information_inverse
from ..core.arrays import Array
from . import compiled

Block = Literal["position", "velocity", "state"]


def bound_covariance(information: Array) -> Array:
    """Return ``J^{-1}`` (..., n, n) of positive-definite information matrices."""
    info = np.asarray(information, dtype=float)
    inv = compiled.spd_inverse(info)
    return information_inverse(info) if inv is None else inv


class Criterion(Protocol):
    """A scalar cost of Bayesian information, smaller is better (vectorised)."""

    @property
    def name(self) -> str:
        """The criterion's name, for tables."""

    def __call__(self, information: Array) -> Array:
        """Return the cost (...,) of ``information`` (..., n, n), SI."""
        ...


def evaluate(criterion: Criterion, information: Array, covariance: Array | None = None) -> Array:
    """Return ``criterion(information)``, from ``covariance`` when the criterion can."""
    of_covariance = getattr(criterion, "of_covariance", None)
    if covariance is None or of_covariance is None:
        return criterion(information)
    return np.asarray(of_covariance(covariance), dtype=float)


def block_indices(block: Block, n: int) -> NDArray[np.intp]:
    """Return the state indices of ``block`` for an ``n``-component state."""
    dim = n // 2
    if block == "position":
        return np.arange(dim)
    if block == "velocity":
        return np.arange(dim, n)
    if block == "state":
        return np.arange(n)
    raise ValueError(f"block must be 'position', 'velocity' or 'state', got {block!r}")


@dataclass(frozen=True)
class WeightedTrace:
    """``Tr{Pi J^{-1}}``: the weighted trace of the posterior CRB (A-optimal).

    Parameters
    ----------
    weights : array_like, optional
        ``Pi`` (n, n), symmetric positive semi-definite, in units that make the terms comparable
        (e.g. ``diag(1, 1, tau^2, tau^2)`` weighs velocity errors as the position error they cause
        after ``tau`` seconds). Default: the position block (ones on the position diagonal, zeros
        elsewhere), so the cost is the bound on the mean-square position error, m^2.

    References
    ----------
    Hurtado & Nehorai (2008), eq. 12.
    """

    weights: ArrayLike | None = None
    name: str = field(default="weighted trace", init=False)

    def matrix(self, n: int) -> Array:
        """Return ``Pi`` for an ``n``-component state.

        Parameters
        ----------
        n : int
            State components (``2 dim``: position, then velocity).

        Returns
        -------
        ndarray, shape (n, n)
            The weighting (position block ones by default).

        Raises
        ------
        ValueError
            If the given weighting is not a finite, symmetric positive semi-definite
            ``(n, n)`` matrix.
        """
        if self.weights is None:
            pi = np.zeros((n, n))
            idx = block_indices("position", n)
            pi[idx, idx] = 1.0
            return pi
        pi = np.asarray(self.weights, dtype=float)
        if pi.shape != (n, n) or not np.all(np.isfinite(pi)):
            raise ValueError(f"the weighting matrix Pi must be a finite ({n}, {n}) matrix; "
                             f"got shape {pi.shape}")
        if not np.allclose(pi, pi.T) or np.linalg.eigvalsh(pi).min() < -1e-12 * max(
                1.0, np.abs(pi).max()):
            raise ValueError("the weighting matrix Pi must be symmetric positive semi-definite")
        return pi

    def __call__(self, information: Array) -> Array:
        """Return ``Tr{Pi J^{-1}}`` (...,) (m^2 with the default weights)."""
        return self.of_covariance(bound_covariance(np.asarray(information, dtype=float)))

    def of_covariance(self, covariance: Array) -> Array:
        """Return ``Tr{Pi C}`` of ``C = J^{-1}``.

        Parameters
        ----------
        covariance : ndarray, shape (..., n, n)
            ``J^{-1}``, SI.

        Returns
        -------
        ndarray, shape (...,)
            The weighted trace (m^2 for the default position weighting).
        """
        pi = self.matrix(covariance.shape[-1])
        return np.einsum("ij,...ji->...", pi, covariance)


@dataclass(frozen=True)
class LogDet:
    """``log det`` of a block of the posterior CRB ``J^{-1}`` (D-optimal).

    Parameters
    ----------
    block : {"position", "velocity", "state"}, optional
        Which block of ``J^{-1}`` (default the position block: ``log det`` of the position error
        covariance bound, log m^(2 dim)).

    Notes
    -----
    The log-volume of the error ellipsoid; unlike the trace it is indifferent to how the
    error is shared between axes (a long thin ellipse can score as well as a round one).
    """

    block: Block = "position"
    name: str = field(default="log det", init=False)

    def __call__(self, information: Array) -> Array:
        """Return ``log det`` of the chosen block of ``J^{-1}`` (...,)."""
        return self.of_covariance(bound_covariance(np.asarray(information, dtype=float)))

    def of_covariance(self, covariance: Array) -> Array:
        """Return ``log det`` of the chosen block of ``C = J^{-1}``.

        Parameters
        ----------
        covariance : ndarray, shape (..., n, n)
            ``J^{-1}``, SI.

        Returns
        -------
        ndarray, shape (...,)
            ``log det`` of the block (``inf`` where it is not positive definite).
        """
        idx = block_indices(self.block, covariance.shape[-1])
        sign, logdet = np.linalg.slogdet(covariance[..., idx[:, None], idx[None, :]])
        return np.where(sign > 0, logdet, np.inf)


@dataclass(frozen=True)
class CustomCriterion:
    """A user-supplied function of the Bayesian information.

    Parameters
    ----------
    function : callable
        ``function(J)`` with ``J`` (..., n, n) (SI) returning a cost (...,), smaller better. It must
        be vectorised over the leading axes.
    name : str, optional
        A label for reports.

    Raises
    ------
    ValueError
        When the function returns an array of the wrong shape (on call).
    """

    function: Callable[[Array], ArrayLike]
    name: str = "custom"

    def __call__(self, information: Array) -> Array:
        """Return ``function(information)``, checked to have the leading shape."""
        info = np.asarray(information, dtype=float)
        cost = np.asarray(self.function(info), dtype=float)
        if cost.shape != info.shape[:-2]:
            raise ValueError(f"the criterion {self.name!r} returned shape {cost.shape} for "
                             f"information of shape {info.shape}; expected "
                             f"{info.shape[:-2]} (one cost per matrix)")
        return cost


CRITERIA: dict[str, Callable[[], Criterion]] = {
    "trace": WeightedTrace,
    "logdet": LogDet,
}


def criterion_from_name(name: str) -> Criterion:
    """Return the criterion named ``"trace"`` (position) or ``"logdet"`` (position).

    Parameters
    ----------
    name : str
        A key of :data:`CRITERIA`.

    Returns
    -------
    Criterion

    Raises
    ------
    ValueError
        For an unknown name.
    """
    key = name.strip().lower()
    if key not in CRITERIA:
        raise ValueError(f"unknown planning criterion {name!r}; expected one of "
                         f"{', '.join(CRITERIA)}")
    return CRITERIA[key]()
