"""The result of a posterior Cramér–Rao bound: :class:`PosteriorBound`.

Computed by :mod:`tmakit.bounds.pcrb`; this module holds the result type, its look-ups and its
JSON and table forms.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Array

__all__ = ["PosteriorBound"]


@dataclass
class PosteriorBound:
    """The posterior CRB after each update (``K`` updates, ``n`` state components, SI units).

    Attributes
    ----------
    state_names : tuple of str
        ``x, y[, z], vx, vy[, vz]``.
    times : ndarray, shape (K,)
        s.
    information, covariance : ndarray, shape (K, n, n)
        ``J_k`` and its inverse, the MSE bound (m², m²/s, m²/s²).
    std : ndarray, shape (K, n)
        m, m/s.
    position_rms : ndarray, shape (K,)
        The RMS position error bound, m.
    prior_time : float
        Time of ``J_0 = P_0^{-1}``, s.
    q : tuple of float
        Acceleration noise std per axis, m/s² (Chen & Sun, §2.1).
    trajectories : int
        Trajectories sampled (Monte Carlo mode).
    mode : str
        ``"monte-carlo"`` or ``"deterministic"`` (along the prior mean).
    n_measurements : int
    notes : list of str
        Warnings, e.g. single trajectories dominating.
    position_rms_se : ndarray, shape (K,), or None
        Monte Carlo standard error of ``position_rms`` (10 batch means), m.
    max_share : ndarray, shape (K,), or None
        Largest share of one trajectory in ``Gamma_k``.

    References
    ----------
    Tichavský, Muravchik & Nehorai (1998) (the recursion); Hurtado & Nehorai (2008),
    eqs. 10-11.
    """

    state_names: tuple[str, ...]
    times: Array
    information: Array
    covariance: Array
    std: Array
    position_rms: Array
    prior_time: float
    q: tuple[float, ...]
    trajectories: int
    mode: str
    n_measurements: int
    notes: list[str] = field(default_factory=list)
    position_rms_se: Array | None = None
    max_share: Array | None = None

    def __len__(self) -> int:
        """Return the number of updates ``K``."""
        return int(self.times.shape[0])

    @property
    def dim(self) -> int:
        """The state's dimension, 2 or 3."""
        return len(self.state_names) // 2

    def index_at(self, time: float) -> int:
        """Return the index of the last update at or before ``time`` (s).

        Parameters
        ----------
        time : float

        Returns
        -------
        int

        Raises
        ------
        ValueError
            When ``time`` is before the first update.
        """
        k = int(np.searchsorted(self.times, float(time) + 1e-9, side="right")) - 1
        if k < 0:
            raise ValueError(f"no update at or before t={time} s (the first is at "
                             f"t={self.times[0]} s)")
        return k

    def at(self, time: float) -> dict[str, object]:
        """Return the bound after the last update at or before ``time`` (s).

        Parameters
        ----------
        time : float

        Returns
        -------
        dict
            ``time``, ``std`` per component, ``position_rms`` (and ``position_rms_se``).

        Raises
        ------
        ValueError
            When ``time`` is before the first update.
        """
        k = self.index_at(time)
        out: dict[str, object] = {
            "time": float(self.times[k]),
            "std": dict(zip(self.state_names, self.std[k].tolist(), strict=True)),
            "position_rms": float(self.position_rms[k])}
        if self.position_rms_se is not None:
            out["position_rms_se"] = float(self.position_rms_se[k])
        return out

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form.

        Returns
        -------
        dict
            Every attribute as plain lists and numbers (SI units), NaN as None.
        """
        return {
            "bound": "posterior CRB (Tichavsky recursion)",
            "mode": self.mode,
            "trajectories": self.trajectories,
            "state": list(self.state_names),
            "prior_time": self.prior_time,
            "q": list(self.q),
            "n_measurements": self.n_measurements,
            "time": self.times.tolist(),
            "std": self.std.tolist(),
            "position_rms": self.position_rms.tolist(),
            "position_rms_se": _nan_to_none(self.position_rms_se),
            "max_share": _nan_to_none(self.max_share),
            "covariance": self.covariance.tolist(),
            "information": self.information.tolist(),
            "notes": list(self.notes),
        }

    def to_json(self, indent: int | None = 2) -> str:
        """Return :meth:`as_dict` as JSON text.

        Parameters
        ----------
        indent : int or None, optional
            None: one line.

        Returns
        -------
        str
        """
        return json.dumps(self.as_dict(), indent=indent)

    def summary(self, times: ArrayLike | None = None) -> str:
        """Return a table of the std and position RMS (m, m/s) at some times, and the notes.

        Parameters
        ----------
        times : array_like, optional
            s; default five spread over the track.

        Returns
        -------
        str
        """
        if times is None:
            idx = np.unique(np.linspace(0, len(self) - 1, min(5, len(self))).round().astype(int))
        else:
            idx = np.array([self.index_at(t) for t in np.atleast_1d(times)], dtype=int)
        what = (f"{self.trajectories} sampled trajectories" if self.mode == "monte-carlo"
                else "the prior-mean trajectory")
        se = self.position_rms_se
        lines = [f"Posterior CRB, q = {', '.join(f'{v:g}' for v in self.q)} m/s^2, "
                 f"{self.n_measurements} measurements, expectation over {what}",
                 f"  {'time (s)':>10}" + "".join(f"{'std ' + s:>12}" for s in self.state_names)
                 + f"{'pos. RMS':>12}" + ("" if se is None else f"{'+-':>10}")]
        for k in idx:
            lines.append(f"  {self.times[k]:10.6g}" + "".join(f"{v:12.5g}" for v in self.std[k])
                         + f"{self.position_rms[k]:12.5g}"
                         + ("" if se is None else f"{se[k]:10.2g}"))
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)


def _nan_to_none(values: Array | None) -> list[float | None] | None:
    if values is None:
        return None
    return [float(v) if np.isfinite(v) else None for v in values]
