"""Typed records of how a track started.

An initiator (:mod:`.initiators`) returns one of :class:`PriorStart` and :class:`BatchStart`: the
Gaussian the filter began from (time, mean, covariance, nuisance values) and why.  Their
:meth:`as_dict` is the JSON-ready ``start`` of ``tma track --json`` and of ``Track.extra["start"]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

from ..core.arrays import Array

if TYPE_CHECKING:  # pragma: no cover
    from ..filters import BearingPrior, FirstBearing
    from ..results.estimate import EstimateResult

__all__ = ["BatchStart", "BearingStart", "Confirmation", "PriorStart", "Rejection",
           "StartRecord"]



@dataclass(frozen=True)
class Confirmation:
    """The innovation test of a batch start.

    The normalised innovation squared (NIS) summed over the first ``updates`` updates after it,
    against chi-square with ``dof`` degrees of freedom.

    Parameters
    ----------
    updates : int
        Updates tested.
    nis : float
        Their summed NIS.
    dof : int
        Their summed degrees of freedom.
    p_value : float
        Chi-square survival probability of ``nis`` (1 when there are no degrees of freedom).
    """

    updates: int
    nis: float
    dof: int
    p_value: float

    def as_dict(self) -> dict[str, float | int]:
        """Return the JSON form: ``updates``, ``nis``, ``dof``, ``p_value``.

        Returns
        -------
        dict
            The test's figures by key (NIS and p-value dimensionless).
        """
        return {"updates": self.updates, "nis": self.nis, "dof": self.dof,
                "p_value": self.p_value}


@dataclass(frozen=True)
class Rejection:
    """A batch start that its innovation test rejected.

    Parameters
    ----------
    window : int
        Its initial window (distinct measurement times).
    time : float
        The window's last time (s).
    confirmation : Confirmation
        The failed test.
    """

    window: int
    time: float
    confirmation: Confirmation

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form: ``window``, ``time`` and the test's keys.

        Returns
        -------
        dict
            The window (distinct times), its last time (s) and the test's figures.
        """
        return {"window": self.window, "time": self.time, **self.confirmation.as_dict()}

    def describe(self) -> str:
        """Describe the rejection in one sentence: the window and its test.

        Returns
        -------
        str
            The sentence (time in s).
        """
        c = self.confirmation
        return (f"window of {self.window} times (t <= {float(self.time):g} s): NIS "
                f"{float(c.nis):.4g} on {c.dof} degrees of freedom over the next "
                f"{c.updates} updates (p = {float(c.p_value):.2g})")


@dataclass(frozen=True)
class PriorStart:
    """A start from a given Gaussian prior; the filter updates with every row.

    Parameters
    ----------
    time : float
        Prior time (s).
    mean : ndarray, shape (n,)
        Prior mean (m, m/s).
    std : ndarray, shape (n,)
        Its standard deviations as given (m, m/s).
    covariance : ndarray, shape (n, n)
        ``diag(std**2)`` (m^2, m^2/s^2).
    nuisance : dict of str to float
        The known nuisance values given with it (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    """

    method: ClassVar[str] = "prior"

    time: float
    mean: Array
    std: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form: ``method`` (``"prior"``), ``time``, ``mean``, ``std`` by name.

        Returns
        -------
        dict
            The start; time in s, mean and std in SI state units (m, m/s).
        """
        return {"method": self.method, "time": self.time,
                "mean": dict(zip(self.state_names, self.mean.tolist(), strict=True)),
                "std": dict(zip(self.state_names, self.std.tolist(), strict=True))}


@dataclass(frozen=True)
class BatchStart:
    """A start from a batch estimate over the first ``window`` measurement times.

    The filter begins at the window's last time with the estimate's state and covariance
    (as the filter holds them) and its nuisance values, and updates with the later rows.

    Parameters
    ----------
    time : float
        The window's last time (s).
    mean : ndarray, shape (n,)
        The filter's state at ``time`` (m, m/s).
    covariance : ndarray, shape (n, n)
        Its covariance (SI).
    nuisance : dict of str to float
        The nuisance values the filter holds, from the estimate (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    estimate : EstimateResult
        The batch estimate (constant velocity referenced at ``time``).
    window : int
        Distinct measurement times in the window.
    rows : int
        Rows in the window.
    relative_position_std : float
        The position's largest 1-sigma semi-axis over the range to the nearest sensor.
    max_relative_std : float or None
        The start quality required (``None`` when the window was chosen).
    windows_tried : int
        Windows estimated by the search that found this one.
    confirmation : Confirmation or None
        The innovation test of this start.
    rejected : tuple of Rejection
        Earlier starts that their innovation tests rejected.
    """

    method: ClassVar[str] = "batch"

    time: float
    mean: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]
    estimate: EstimateResult
    window: int
    rows: int
    relative_position_std: float
    max_relative_std: float | None
    windows_tried: int
    confirmation: Confirmation | None = None
    rejected: tuple[Rejection, ...] = field(default_factory=tuple)

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form.

        Keys ``method`` (``"batch"``), ``window``, ``rows``, ``time``, ``status``, ``chi2``,
        ``dof``, ``relative_position_std``, ``max_relative_std``, ``windows_tried``, ``nuisance``
        (value and std by name), ``confirmation`` and ``rejected``.

        Returns
        -------
        dict
            The start; times in s, nuisance values in their SI units (Hz, dBW, ...).
        """
        est = self.estimate
        out: dict[str, Any] = {
            "method": self.method,
            "window": self.window,
            "rows": self.rows,
            "time": self.time,
            "status": est.status,
            "chi2": float(est.chi2),
            "dof": int(est.dof),
            "relative_position_std": float(self.relative_position_std),
            "max_relative_std": self.max_relative_std,
            "windows_tried": self.windows_tried,
            "nuisance": {name: {"value": v, "std": sd}
                         for name, (v, sd) in est.nuisance.items()},
        }
        if self.confirmation is not None:
            out["confirmation"] = self.confirmation.as_dict()
        out["rejected"] = [r.as_dict() for r in self.rejected]
        return out


@dataclass(frozen=True)
class BearingStart:
    """A start at the first bearing from a prior in the user's terms (range, speed, height).

    The filter begins at the first bearing's time from :class:`~tmakit.filters.BearingPrior`
    centred on that bearing (which it has then used) and updates with every other row.

    Parameters
    ----------
    time : float
        The first bearing's time (s).
    mean : ndarray, shape (n,)
        The filter's state there: the prior's mean (m, m/s).
    covariance : ndarray, shape (n, n)
        Its covariance (SI).
    nuisance : dict of str to float
        Known nuisance values given with it (Hz, dBW, ...).
    state_names : tuple of str
        The state components.
    prior : BearingPrior
        The intervals.
    first : FirstBearing
        The bearing the prior is centred on (its row is not used again).
    confirmation : Confirmation, optional
        The innovation test of the start.
    rejected : tuple of Rejection
        Earlier bearings whose starts the test rejected (window 1: one bearing).
    """

    method: ClassVar[str] = "first-bearing"

    time: float
    mean: Array
    covariance: Array
    nuisance: dict[str, float]
    state_names: tuple[str, ...]
    prior: BearingPrior
    first: FirstBearing
    confirmation: Confirmation | None = None
    rejected: tuple[Rejection, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON form: ``method`` (``"first-bearing"``), ``time``, ``prior``, ...

        Returns
        -------
        dict
            ``time`` (s), ``bearing_deg``, ``sensor_row``, ``prior`` (m, m/s, with the
            intervals the user gave), ``mean`` and ``std`` by name (m, m/s).
        """
        import math

        std = [math.sqrt(max(float(v), 0.0)) for v in self.covariance.diagonal()]
        return {"method": self.method, "time": self.time,
                "bearing_deg": math.degrees(self.first.bearing) % 360.0,
                "row": self.first.row, "prior": self.prior.as_dict(),
                "mean": dict(zip(self.state_names, self.mean.tolist(), strict=True)),
                "std": dict(zip(self.state_names, std, strict=True)),
                "confirmation": None if self.confirmation is None
                else self.confirmation.as_dict(),
                "rejected": [r.as_dict() for r in self.rejected]}


#: What an initiator returns.
StartRecord = PriorStart | BatchStart | BearingStart
