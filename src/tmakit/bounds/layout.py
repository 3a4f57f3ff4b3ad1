"""The bound of a sensor layout over many emitter positions: TDOA and FDOA of a fixed emitter.

The Fisher information of :func:`tmakit.bounds.crlb` for a stationary emitter, written for a
grid of positions (``tma gdop``): shared-reference noise is whitened in closed form,
``F = 2 sum_i y_i y_i' - 2 sum_g s_g s_g' / (1 + m_g)``.  The CEP (50 %, 90 %) comes from the
horizontal covariance by a tabulated integral, not the ``0.59 (s1 + s2)`` rule of thumb.
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from ..core.arrays import Array, BoolArray, IntArray
from ..core.units import SPEED_OF_LIGHT
from ..data import MeasurementSet
from ..measurements import options_with_metadata
from ..measurements.range import range_row
from ..measurements.range_rate import range_rate_row

__all__ = ["LayoutRows", "cep", "layout_information"]


class LayoutRows:
    """The ``tdoa`` and ``fdoa`` rows of a layout (values unused) as the bound needs them.

    ``carrier``: the FDOA carrier (Hz) when the set's options do not state it.
    """

    def __init__(self, meas: MeasurementSet, carrier: float | None = None) -> None:
        other = sorted(set(meas.kinds) - {"tdoa", "fdoa"})
        if other:
            raise ValueError(f"the layout bound takes tdoa and fdoa rows, not {', '.join(other)}")
        opts = options_with_metadata(meas.kinds, None, meas.metadata)
        fdoa = meas.kind_mask("fdoa")
        given = opts.get("fdoa", {}).get("carrier", carrier)
        if fdoa.any() and given is None:
            raise ValueError("fdoa rows: the bound of a layout needs the carrier (Hz)")
        f0 = float(given) if given is not None else 0.0  # type: ignore[arg-type]
        # d value / d range (rate) difference: 1 / c (s/m) for tdoa, -f0 / c (Hz s/m) fdoa
        scale = np.where(fdoa, -f0 / SPEED_OF_LIGHT, 1.0 / SPEED_OF_LIGHT)
        self.inv_sigma = np.abs(scale) / meas.sigma_si  # in range (rate) units
        self.fdoa = fdoa
        self.sensor, self.ref = meas.sensor_state, meas.ref_sensor_state
        shared = {k: opts.get(k, {}).get("noise", "shared") == "shared" for k in meas.kinds}
        alone = np.full(len(meas), -1, dtype=np.int64)  # independent rows: a group each
        for kind, on in shared.items():
            if not on:
                rows = np.flatnonzero(meas.kind_mask(kind))
                alone[rows] = rows
        ref = meas.ref_sensor_state
        keys = (alone, ref[:, 2], ref[:, 1], ref[:, 0], meas.time, meas.kind_code)
        order = np.lexsort(keys)
        change = np.zeros(len(meas), dtype=bool)
        for key in keys:
            col = key[order]
            change[1:] |= col[1:] != col[:-1]
        # the rows in group order, held so (contiguous): the bound reads them in one pass
        self.sensor, self.ref = self.sensor[order], self.ref[order]
        self.inv_sigma, self.fdoa = self.inv_sigma[order], self.fdoa[order]
        #: the first row of each group (of one kind, time and reference), in group order
        self.starts = np.concatenate([[0], np.flatnonzero(change[1:]) + 1])
        self.n = len(meas)


def layout_information(rows: LayoutRows, emitters: Array, dim: int = 2) -> Array:
    """Give the Fisher information of a stationary emitter's position at many points."""
    emitters = np.ascontiguousarray(np.atleast_2d(np.asarray(emitters, dtype=float)))
    return _information(emitters, rows.sensor, rows.ref, rows.fdoa, rows.inv_sigma,
                        rows.starts, dim)


def cep(covariance: Array, probability: float) -> Array:
    """Give the circular error probable of horizontal position covariances."""
    finite = np.all(np.isfinite(covariance), axis=(-2, -1))
    lam = np.linalg.eigvalsh(np.where(finite[..., None, None], covariance, np.eye(2)))
    major = np.maximum(lam[..., 1], 0.0)
    ratio = np.clip(lam[..., 0] / np.where(major > 0, major, 1.0), _RATIO_LOW, 1.0)
    grid, radius = _cep_table(float(probability))
    return np.where(finite, np.sqrt(major) * np.interp(np.log10(ratio), grid, radius), np.inf)


#: The smallest minor/major variance ratio tabled (below it: the 1-D limit, to 1e-6).
_RATIO_LOW = 1e-12


@functools.cache
def _cep_table(probability: float) -> tuple[Array, Array]:
    """Tabulate the CEP over the major axis's std against log10(minor / major variance)."""
    from scipy.special import erf

    log_k = np.linspace(np.log10(_RATIO_LOW), 0.0, 241)
    k = 10.0 ** log_k[:, None]
    nodes, weights = np.polynomial.legendre.leggauss(400)
    phi = 0.5 * np.pi * nodes
    w = 0.5 * np.pi * weights
    low, high = np.zeros(k.shape[0]), np.full(k.shape[0], 4.0)
    for _ in range(60):
        rho = 0.5 * (low + high)[:, None]
        p = np.sum(w * np.exp(-0.5 * (rho * np.sin(phi)) ** 2) / np.sqrt(2 * np.pi)
                   * erf(rho * np.cos(phi) / np.sqrt(2.0 * k)) * rho * np.cos(phi), axis=1)
        below = p < probability
        low, high = np.where(below, rho[:, 0], low), np.where(below, high, rho[:, 0])
    return log_k, 0.5 * (low + high)


_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_range_row, _range_rate_row = _jit(range_row), _jit(range_rate_row)


@_jit
def _gradient(e: Array, st: Array, fdoa: bool, out: Array) -> None:
    """Write the range (fdoa: range-rate) gradient by the emitter position into ``out``."""
    # the kinds' own rows; a stationary emitter: relative velocity = - sensor velocity
    rel = (e[0] - st[0], e[1] - st[1], e[2] - st[2], -st[3], -st[4], -st[5])
    row = _range_rate_row(rel) if fdoa else _range_row(rel)
    out[0], out[1], out[2] = row[1], row[2], row[3]


@_jit
def _information(emitters: Array, sensor: Array, ref: Array, fdoa: BoolArray,
                 inv_sigma: Array, starts: IntArray, dim: int) -> Array:
    """Give the Fisher information ``(E, dim, dim)`` at each emitter (rows in group order)."""
    n, groups = sensor.shape[0], starts.shape[0]
    info = np.zeros((emitters.shape[0], dim, dim))
    at_ref, g, y, s = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    acc = np.empty((dim, dim))
    for k in range(emitters.shape[0]):
        e = emitters[k]
        acc[:] = 0.0
        for grp in range(groups):
            lo = starts[grp]
            hi = starts[grp + 1] if grp + 1 < groups else n
            _gradient(e, ref[lo], fdoa[lo], at_ref)
            s[:] = 0.0
            for i in range(lo, hi):
                _gradient(e, sensor[i], fdoa[i], g)
                for a in range(dim):
                    y[a] = (g[a] - at_ref[a]) * inv_sigma[i]
                    s[a] += y[a]
                for a in range(dim):
                    for b in range(a, dim):
                        acc[a, b] += 2.0 * y[a] * y[b]
            c = 2.0 / (1.0 + (hi - lo))
            for a in range(dim):
                for b in range(a, dim):
                    acc[a, b] -= c * s[a] * s[b]
        for a in range(dim):
            for b in range(a, dim):
                info[k, a, b] = acc[a, b]
                info[k, b, a] = acc[a, b]
    return info
