"""A Cramér–Rao bound as a result (at the truth, or an estimate's covariance at the fit)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from .answers import finite, parameter_display, position_ellipse
from .nuisance import KnownNuisance, as_known_nuisance
from .observability import Decomposition, Observability, analyse


def pseudo_covariance(obsv: Observability) -> NDArray[np.float64]:
    """Invert the information on its observable subspace (Moore–Penrose)."""
    assert obsv.decomposition is not None  # (made by analyse)
    evals, evecs, scale = obsv.decomposition  # eigenvalues ascending: the rank's are the last
    lo = obsv.size - obsv.rank
    if lo:
        evals, evecs = evals[lo:], evecs[:, lo:]
    seen = evecs * scale[:, None]  # in the parameters' units
    cov: NDArray[np.float64] = (seen / evals).dot(seen.T)  # (the BLAS call of @, faster)
    return cov


@dataclass
class Bound:
    """A Cramér–Rao bound evaluated at ``values`` (the truth).

    Parameters
    ----------
    parameters : tuple of str
        The unknowns, motion parameters first.
    values, std : ndarray, shape (q,)
        SI; std infinite where unobservable.
    information, covariance : ndarray, shape (q, q)
        Fisher information, SI, and its inverse on the observable subspace.
    observability : Observability
    known_nuisance : KnownNuisance or None
        None when the nuisance parameters are unknowns.
    nuisance_values : dict of str to float
        At the evaluation point (Hz, Hz/s, dB).
    motion, n_measurements : MotionModel, int

    References
    ----------
    Gu et al. (2007), eqs. 17-18; Hörst & Oispuu (2010), eq. 9.
    """

    parameters: tuple[str, ...]
    values: NDArray[np.float64]
    information: NDArray[np.float64]
    covariance: NDArray[np.float64]
    std: NDArray[np.float64]
    observability: Observability
    known_nuisance: KnownNuisance | None
    nuisance_values: dict[str, float]
    motion: MotionModel
    n_measurements: int

    @property
    def rank(self) -> int:
        """The rank of the information (the number of observable directions)."""
        return self.observability.rank

    def std_of(self, name: str) -> float:
        """Return the std of the parameter ``name`` (SI; inf if unobservable).

        Parameters
        ----------
        name : str

        Returns
        -------
        float

        Raises
        ------
        ValueError
            If ``name`` is not a parameter.
        """
        return float(self.std[self.parameters.index(name)])

    def _gradient_variance(self, grad: NDArray[np.float64]) -> float:
        """Delta-method variance of a scalar with gradient ``grad``; inf if not estimable."""
        full = np.zeros(len(self.parameters))
        full[: grad.size] = grad
        null = self.observability.null_basis
        dec = self.observability.decomposition
        if null.size:
            # A function is estimable only if its gradient is orthogonal to the null space,
            # compared in the normalised coordinates of the rank test (units cancel: a
            # position moves by metres where a speed moves by millimetres per second).
            scale = dec[2] if dec is not None else np.ones(full.size)
            g, n = full * scale, null / scale[:, None]
            n = n / np.linalg.norm(n, axis=0, keepdims=True)
            if np.max(np.abs(g @ n)) > 1e-3 * max(float(np.linalg.norm(g)), 1e-300):
                return float("inf")
        return float(full @ self.covariance @ full)

    def state_covariance(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Return the ENU target state at ``t`` and its covariance (delta method).

        Parameters
        ----------
        t : float
            s.

        Returns
        -------
        state, cov : ndarray, shapes (6,) and (6, 6)
            m and m/s; the covariance infinite where unobservable.
        """
        theta = self.values[: self.motion.n_params]
        state = self.motion.states(theta, np.array([float(t)]))[0]
        jac = self.motion.jacobian(theta, np.array([float(t)]))[0]  # (6, p)
        full = np.zeros((6, len(self.parameters)))
        full[:, : jac.shape[1]] = jac
        cov = full @ self.covariance @ full.T
        for i in range(6):
            if np.any(jac[i]) and not np.isfinite(self._gradient_variance(jac[i])):
                cov[i, :] = cov[:, i] = np.inf
        return state, cov

    def ellipse(self, t: float, level: float = 0.9) -> dict[str, float]:
        """Return the horizontal position confidence ellipse at time ``t``.

        Parameters
        ----------
        t : float
            s.
        level : float
            Probability inside (0 to 1).

        Returns
        -------
        dict of str to float
            ``east``, ``north``, ``major``, ``minor`` (m), ``bearing_deg`` and ``level``.
        """
        state, cov = self.state_covariance(t)
        e = position_ellipse(cov[:2, :2], level)
        return {"east": float(state[0]), "north": float(state[1]),
                "major": np.inf if e is None else e.semi_major,
                "minor": np.inf if e is None else e.semi_minor,
                "bearing_deg": float("nan") if e is None else e.orientation_deg,
                "level": level}

    def derived(self, t: float, sensor_position: ArrayLike | None = None
                ) -> dict[str, tuple[float, float]]:
        """Return derived quantities at time ``t`` with their std.

        Parameters
        ----------
        t : float
            s.
        sensor_position : array_like, shape (3,), optional
            ENU, m; adds ``range``.

        Returns
        -------
        dict of str to (float, float)
            Position (m), velocity (m/s), ``speed``, ``course`` (rad) and ``range`` (m).
        """
        state, cov = self.state_covariance(t)
        out: dict[str, tuple[float, float]] = {}
        axes = ("x", "y", "z")[: self.motion.dim]
        for i, a in enumerate(axes):
            out[a] = (float(state[i]), float(np.sqrt(cov[i, i])))
            out[f"v{a}"] = (float(state[3 + i]), float(np.sqrt(cov[3 + i, 3 + i])))
        v = state[3:6]
        speed = float(np.linalg.norm(v))

        def std_of(grad6: NDArray[np.float64]) -> float:
            on = grad6 != 0  # an unobservable state off the gradient's support does not count
            sub = cov[np.ix_(on, on)]
            if not np.all(np.isfinite(sub)):
                return float("inf")
            var = float(grad6[on] @ sub @ grad6[on])  # below 0 only by rounding: not a number
            return float(np.sqrt(var)) if var >= 0.0 else float("nan")

        if speed > 0:
            g = np.zeros(6)
            g[3:6] = v / speed
            out["speed"] = (speed, std_of(g))
            h2 = v[0] ** 2 + v[1] ** 2
            g = np.zeros(6)
            g[3], g[4] = v[1] / h2, -v[0] / h2
            out["course"] = (float(np.arctan2(v[0], v[1])), std_of(g))
        if sensor_position is not None:
            d = state[:3] - np.asarray(sensor_position, dtype=float)
            r = float(np.linalg.norm(d))
            g = np.zeros(6)
            g[:3] = d / r
            out["range"] = (r, std_of(g))
        return out

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form (SI; non-finite numbers as ``None``).

        Returns
        -------
        dict of str to object
        """
        cov = self.covariance.copy()
        bad = ~np.isfinite(self.std)
        cov[bad, :] = np.nan
        cov[:, bad] = np.nan
        return {
            "parameters": list(self.parameters),
            "values": [float(v) for v in self.values],
            "std": [finite(s) for s in self.std],
            "covariance": [[finite(c) for c in row] for row in cov],
            "rank": self.rank,
            "size": len(self.parameters),
            "unobservable": [d.as_dict() for d in self.observability.directions],
            "nuisance": "known" if self.known_nuisance else "unknown",
            "nuisance_values": self.nuisance_values,
            "motion": self.motion.name,
            "n_measurements": self.n_measurements,
        }

    def to_json(self, indent: int | None = 2) -> str:
        """Return :meth:`as_dict` as JSON text.

        Parameters
        ----------
        indent : int or None

        Returns
        -------
        str
        """
        return json.dumps(self.as_dict(), indent=indent)

    def summary(self) -> str:
        """Return a readable table of the bound and what is unseen.

        Returns
        -------
        str
        """
        lines = [f"Cramér–Rao bound, motion {self.motion.name}, {self.n_measurements} "
                 f"measurements, nuisance parameters "
                 f"{'known' if self.known_nuisance else 'unknown (estimated jointly)'}",
                 f"rank {self.rank} of {len(self.parameters)}"
                 + ("" if self.observability.full_rank else " — NOT fully observable")]
        width = max(len(p) for p in self.parameters)
        lines.append(f"  {'parameter':<{width}}  {'value':>16}  {'std (CRLB)':>14}  unit")
        for name, val, sd in zip(self.parameters, self.values, self.std, strict=True):
            val, sd, unit = parameter_display(name, val, sd)
            sd_text = f"{sd:14.6g}" if np.isfinite(sd) else f"{'unobservable':>14}"
            lines.append(f"  {name:<{width}}  {val:16.8g}  {sd_text}  {unit}")
        for d in self.observability.directions:
            lines.append(f"  unobservable: {d.sentence}")
            lines.append("      parameter change: " + ", ".join(
                f"{k} {v:+.4g}" for k, v in d.weights.items()))
        return "\n".join(lines)


def bound_from_information(info: NDArray[np.float64], names: tuple[str, ...],
                           values: NDArray[np.float64], meas: MeasurementSet,
                           motion: MotionModel, known_nuisance: KnownNuisance | None,
                           nuisance_values: Mapping[str, float],
                           decomposition: Decomposition | None = None) -> Bound:
    """Build the bound (or an estimate's covariance) from an information matrix.

    Parameters
    ----------
    info : ndarray, shape (q, q)
        Fisher information about ``names``, SI.
    names : tuple of str
        Motion parameters first, then the nuisance unless known.
    values : ndarray, shape (q,)
        Where it was evaluated (truth or fit).
    meas, motion, known_nuisance, nuisance_values
        As for :class:`Bound`.
    decomposition : tuple of ndarray, optional
        ``info``'s (:func:`~tmakit.results.observability.analyse`), if made already.

    Returns
    -------
    Bound
    """
    known = as_known_nuisance(known_nuisance)
    if known is not None:
        known = KnownNuisance(nuisance_values)
    theta = values[: motion.n_params]
    obsv = analyse(info, names, meas, motion, theta, decomposition)
    cov = pseudo_covariance(obsv)
    std = np.sqrt(np.maximum(cov.diagonal(), 0.0))
    if not obsv.full_rank:
        std = np.where(obsv.observable, std, np.inf)
    return Bound(names, values, info, cov, std, obsv, known,
                 dict(nuisance_values), motion, len(meas))
