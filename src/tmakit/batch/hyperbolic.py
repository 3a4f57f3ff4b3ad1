"""Closed-form geolocation from differences between sensors: Chan & Ho (1994), Ho & Xu (2004).

Two-stage weighted least squares on one snapshot against one reference sensor: squared TDOAs
(and FDOAs) linear in ``[u, r_1]`` (``[u, r_1, u_dot, r_1_dot]``), then ``r_1 = |u - s_1|``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array, row_labels
from ..core.geodesy import enu_to_geodetic, geodetic_to_enu
from ..core.units import SPEED_OF_LIGHT
from ..data import MeasurementSet
from ..measurements import Altitude, model_for, options_with_metadata
from ..motion import ConstantVelocity, MotionModel, Stationary
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..observation.rows import correlated_blocks
from ..results.estimate import EstimateResult, assemble_result
from .estimator import BatchEstimator, Init, Options

__all__ = ["ChanHo", "HoXu", "Snapshot", "closed_form_many", "snapshot_rows",
           "two_stage_wls"]

MAX_SNAPSHOT_ROWS = 400  # most rows one solve takes (its weights: a dense square of this size)


def _t(a: Array) -> Array:
    return np.swapaxes(a, -1, -2)


def _inverse(a: Array) -> Array:
    """Invert symmetric matrices ``(..., M, M)``; pseudo-inverses when one is singular."""
    try:  # (LU: a tenth of the pseudo-inverse's fixed cost on these small matrices)
        return np.asarray(np.linalg.inv(a), dtype=np.float64)
    except np.linalg.LinAlgError:
        return np.asarray(np.linalg.pinv(a, hermitian=True), dtype=np.float64)


def _solve_weighted(g: Array, h: Array, cov: Array) -> tuple[Array, Array]:
    """Give ``(G' W G)^-1 G' W h`` and ``(G' W G)^-1`` with ``W = cov^-1``."""
    gtw = _t(g) @ _inverse(cov)
    inv = _inverse(gtw @ g)
    solution: Array = (inv @ (gtw @ h[..., None]))[..., 0]
    return solution, inv


def two_stage_wls(sensors: Array, ref: Array, rd: Array, cov: Array,
                  sensor_vel: Array | None = None, ref_vel: Array | None = None,
                  rrd: Array | None = None, height: float | None = None
                  ) -> tuple[Array, Array | None]:
    """Locate a source from range (and range-rate) differences against one reference."""
    rd = np.asarray(rd, dtype=float)
    moving = rrd is not None
    free = [0, 1] if height is not None else [0, 1, 2]
    n = len(free)
    m = rd.shape[-1]
    if m < n + 1:
        raise ValueError(f"{m} differences for {n + 1} unknowns of stage 1 (the source's "
                         f"{n} coordinates and its range from the reference): at least "
                         f"{n + 1} are needed, from {n + 2} sensors")
    known = np.zeros(3)
    if height is not None:
        known[2] = height
    g, h = _stage_one(sensors, ref, rd, free, known, sensor_vel, ref_vel, rrd)
    batch = rd.shape[:-1]
    diag = np.arange(m)
    phi, cov1 = _solve_weighted(g, h, cov)
    for _ in range(2):  # the weights from the estimate (Chan & Ho (1994): B = 2 diag(r_i))
        pos = np.broadcast_to(known, (*batch, 3)).copy()
        pos[..., free] = phi[..., :n]
        rel = pos[..., None, :] - sensors
        r = np.linalg.norm(rel, axis=-1)
        b = np.zeros((*batch, g.shape[-2], g.shape[-2]))
        b[..., diag, diag] = 2.0 * r
        if moving:
            assert sensor_vel is not None
            vel = np.zeros((*batch, 3))
            vel[..., free] = phi[..., n + 1:2 * n + 1]
            rdot = np.sum(rel * (vel[..., None, :] - sensor_vel), axis=-1) / r
            b[..., m + diag, diag] = 2.0 * rdot
            b[..., m + diag, m + diag] = 2.0 * r
        phi, cov1 = _solve_weighted(g, h, b @ cov @ _t(b))
    return _stage_two(phi, cov1, ref, ref_vel, known, free, moving)


def _stage_one(sensors: Array, ref: Array, rd: Array, free: list[int], known: Array,
               sensor_vel: Array | None, ref_vel: Array | None, rrd: Array | None
               ) -> tuple[Array, Array]:
    """Give stage 1's ``G`` and ``h`` (the squared TDOA equations and their time derivative)."""
    n, moving = len(free), rrd is not None
    ds = sensors - ref
    g_t = np.zeros((*rd.shape, 2 * (n + 1) if moving else n + 1))
    g_t[..., :n] = -2.0 * ds[:, free]
    g_t[..., n] = -2.0 * rd
    h_t = rd**2 - np.sum(sensors**2, axis=1) + ref @ ref + 2.0 * ds[:, 2] * known[2] * (n == 2)
    if not moving:
        return g_t, h_t
    assert sensor_vel is not None and ref_vel is not None and rrd is not None
    dv = sensor_vel - ref_vel
    g_f = np.zeros_like(g_t)
    g_f[..., :n] = -2.0 * dv[:, free]
    g_f[..., n] = -2.0 * rrd
    g_f[..., n + 1:2 * n + 1] = -2.0 * ds[:, free]
    g_f[..., 2 * n + 1] = -2.0 * rd
    h_f = (2.0 * rd * rrd - 2.0 * np.sum(sensors * sensor_vel, axis=1) + 2.0 * ref @ ref_vel
           + 2.0 * dv[:, 2] * known[2] * (n == 2))
    return np.concatenate([g_t, g_f], axis=-2), np.concatenate([h_t, h_f], axis=-1)


def _stage_two(phi: Array, cov1: Array, ref: Array, ref_vel: Array | None, known: Array,
               free: list[int], moving: bool) -> tuple[Array, Array | None]:
    """Impose ``r_1 = |u - s_1|`` (and its rate) on stage 1 in the squared coordinates."""
    n = len(free)
    batch = phi.shape[:-1]
    fixed = [k for k in range(3) if k not in free]
    d = phi[..., :n] - ref[free]
    r1 = phi[..., n]
    off = known[fixed] - ref[fixed]
    size = 2 * (n + 1) if moving else n + 1
    g2 = np.zeros((size, 2 * n if moving else n))
    g2[:n, :n] = np.eye(n)
    g2[n, :n] = 1.0
    h2 = np.concatenate([d**2, (r1**2 - off @ off)[..., None]], axis=-1)
    b2 = np.zeros((*batch, size, size))
    diag = np.arange(n)
    b2[..., diag, diag] = 2.0 * d
    b2[..., n, n] = 2.0 * r1
    if moving:
        assert ref_vel is not None
        dd = phi[..., n + 1:2 * n + 1] - ref_vel[free]
        r1dot = phi[..., 2 * n + 1]
        off_dot = -ref_vel[fixed]
        g2[n + 1:2 * n + 1, n:] = np.eye(n)
        g2[2 * n + 1, n:] = 1.0
        h2 = np.concatenate([h2, d * dd, (r1 * r1dot - off @ off_dot)[..., None]], axis=-1)
        b2[..., n + 1 + diag, diag] = dd
        b2[..., n + 1 + diag, n + 1 + diag] = d
        b2[..., 2 * n + 1, n] = r1dot
        b2[..., 2 * n + 1, 2 * n + 1] = r1
    phi2, _ = _solve_weighted(g2, h2, b2 @ cov1 @ _t(b2))
    sign = np.where(d < 0, -1.0, 1.0)
    root = sign * np.sqrt(np.abs(phi2[..., :n]))
    pos = np.broadcast_to(known, (*batch, 3)).copy()
    pos[..., free] = ref[free] + root
    if not moving:
        return pos, None
    assert ref_vel is not None
    vel = np.zeros((*batch, 3))
    # (u - s_1)(u_dot - s_dot_1) over (u - s_1); stage 1's velocity where that is near 0
    scale = np.maximum(1.0, np.max(np.abs(root), axis=-1, keepdims=True))
    tiny = np.abs(root) < 1e-9 * scale
    vel[..., free] = np.where(tiny, phi[..., n + 1:2 * n + 1],
                              ref_vel[free] + phi2[..., n:] / np.where(tiny, 1.0, root))
    return pos, vel


@dataclass(frozen=True)
class Snapshot:
    """The rows one closed-form solve takes: TDOAs against one reference, FDOAs beside them."""

    tdoa: NDArray[np.intp]
    fdoa: NDArray[np.intp] | None  # one per TDOA row (None: TDOA only)
    time: float  # s


def snapshot_rows(meas: MeasurementSet, moving: bool, with_fdoa: bool) -> Snapshot | None:
    """Choose the largest snapshot of a set: TDOAs against one reference position."""
    tdoa = np.flatnonzero(meas.kind_mask("tdoa"))
    if tdoa.size == 0:
        return None
    ref = meas.ref_sensor_state[:, :3]
    key = np.column_stack([ref[tdoa], meas.time[tdoa] if moving else np.zeros(tdoa.size)])
    fdoa = None
    if with_fdoa:
        f_rows = np.flatnonzero(meas.kind_mask("fdoa"))
        lookup = {(meas.time[i], meas.sensor_code[i], *ref[i].tolist()): i
                  for i in f_rows.tolist()}
        match = np.array([lookup.get((meas.time[i], meas.sensor_code[i], *ref[i].tolist()), -1)
                          for i in tdoa.tolist()], dtype=np.intp)
        keep = match >= 0
        tdoa, key, fdoa = tdoa[keep], key[keep], match[keep]
        if tdoa.size == 0:
            return None
    label, counts = row_labels(key)
    chosen = np.flatnonzero(label == int(np.argmax(counts)))
    if chosen.size > MAX_SNAPSHOT_ROWS:  # spread over the snapshot's times
        chosen = chosen[np.linspace(0, chosen.size - 1, MAX_SNAPSHOT_ROWS).astype(int)]
    rows = tdoa[chosen]
    return Snapshot(rows, None if fdoa is None else fdoa[chosen], float(meas.time[rows[0]]))


def _covariance(meas: MeasurementSet, rows: NDArray[np.intp], kind: str) -> Array:
    """Give the noise covariance of some rows of one kind (SI units squared)."""
    model = model_for(kind, options_with_metadata([kind], None, meas.metadata).get(kind))
    sigma = meas.sigma_si[rows]
    cov = np.diag(sigma**2)
    local = np.arange(rows.size)
    for block, c in correlated_blocks({kind: model}, {kind: local}, meas.time[rows],
                                      meas.time_ref[rows], sigma, meas.sensor_code[rows],
                                      False, meas.ref_sensor_state[rows]):
        cov[np.ix_(block, block)] = c
    return cov


def closed_form_state(meas: MeasurementSet, values: Array, snap: Snapshot,
                      carrier: float | None, height: float | None
                      ) -> tuple[Array, Array | None]:
    """Solve one snapshot: the source position (and velocity, with FDOAs) at its time."""
    t = snap.tdoa
    rd = SPEED_OF_LIGHT * values[..., t]
    cov = SPEED_OF_LIGHT**2 * _covariance(meas, t, "tdoa")
    ref = meas.ref_sensor_state[t[0]]
    if snap.fdoa is None or carrier is None:
        return two_stage_wls(meas.sensor_state[t, :3], ref[:3], rd, cov, height=height)
    f = snap.fdoa
    scale = -SPEED_OF_LIGHT / carrier
    m = t.size
    full = np.zeros((2 * m, 2 * m))
    full[:m, :m] = cov
    full[m:, m:] = scale**2 * _covariance(meas, f, "fdoa")
    return two_stage_wls(meas.sensor_state[t, :3], ref[:3], rd, full,
                         meas.sensor_state[t, 3:], ref[3:], scale * values[..., f], height)


def _known_carrier(meas: MeasurementSet, options: Options) -> float | None:
    """Give the FDOA carrier the options or the set's metadata state (Hz), or None."""
    opts = options_with_metadata(["fdoa"], options, meas.metadata).get("fdoa", {})
    value = opts.get("carrier")
    return None if value is None else float(value)  # type: ignore[arg-type]


def solve_snapshot(meas: MeasurementSet, values: Array, snap: Snapshot, carrier: float | None,
                   motion: MotionModel) -> Array:
    """Solve a snapshot for the motion parameters, at the height known (plane or ellipsoid)."""
    flat = motion.dim == 2
    rows = np.flatnonzero(meas.kind_mask("altitude"))
    stated = None if flat else Altitude.options_from_metadata(meas.metadata).get("origin")
    if values.ndim == 2 and not (flat or rows.size == 0 or stated is None):
        return np.stack([solve_snapshot(meas, v, snap, carrier, motion) for v in values])
    if flat or rows.size == 0 or stated is None:
        pos, vel = closed_form_state(meas, values, snap, carrier, 0.0 if flat else None)
    else:
        origin = np.asarray(stated, dtype=float)
        height = float(np.average(values[rows], weights=meas.sigma_si[rows] ** -2.0))
        up = height - float(origin[2])
        for _ in range(4):
            pos, vel = closed_form_state(meas, values, snap, carrier, up)
            lat, lon, _ = enu_to_geodetic(pos[0], pos[1], pos[2], origin)
            up = float(geodetic_to_enu(lat, lon, height, origin)[2])
    return motion.from_state(np.concatenate([pos, np.zeros_like(pos) if vel is None else vel],
                                            axis=-1), snap.time)


def closed_form_many(meas: MeasurementSet, ys: Array, motion: MotionModel,
                     options: Options = None) -> Array | None:
    """Solve the set's best closed form for each of several data sets of the same rows."""
    moving = not isinstance(motion, Stationary)
    carrier = _known_carrier(meas, options)
    snap = None
    if moving and carrier is not None:
        snap = snapshot_rows(meas, True, True)
    if snap is None:
        snap = snapshot_rows(meas, moving, False)
    if snap is None:
        return None
    failed = (ValueError, NotImplementedError, np.linalg.LinAlgError)
    try:
        with np.errstate(invalid="ignore", divide="ignore"):
            theta = np.asarray(solve_snapshot(meas, ys, snap, carrier, motion), dtype=float)
    except failed:
        if ys.shape[0] == 1:
            return np.full((1, motion.n_params), np.nan)
        theta = np.concatenate([closed_form_many(meas, y[None], motion, options)
                                for y in ys])
    theta[~np.all(np.isfinite(theta), axis=1)] = np.nan
    return theta


@dataclass(frozen=True, eq=False)
class _ClosedForm(BatchEstimator):
    """A closed form on the set's largest snapshot, its covariance the bound at the estimate."""

    init: Init = None
    options: Options = None
    moving: ClassVar[bool] = False

    def __post_init__(self) -> None:
        """Refuse a start: the closed form needs none."""
        if self.init is not None:
            raise ValueError(f"{self.name}: a closed form takes no starting point (--init)")

    def _check(self, meas: MeasurementSet, motion: MotionModel) -> float | None:
        """Refuse what the paper does not solve; give the carrier (Hz) it uses, if any."""
        raise NotImplementedError

    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Solve the largest snapshot in closed form."""
        carrier = self._check(meas, motion)
        snap = snapshot_rows(meas, self.moving, self.moving)
        if snap is None:
            raise ValueError(f"{self.name}: no TDOA rows"
                             + (" with FDOA rows of the same sensors, times and reference"
                                if self.moving else ""))
        theta = solve_snapshot(meas, meas.value_si, snap, carrier, motion)
        rows = snap.tdoa if snap.fdoa is None else np.concatenate([snap.tdoa, snap.fdoa])
        if motion.dim == 3:  # the stated altitude took part (solve_snapshot)
            rows = np.concatenate([rows, np.flatnonzero(meas.kind_mask("altitude"))])
        used = meas.take(np.sort(rows))
        opts = ({"fdoa": {"carrier": carrier}} if carrier is not None
                else {k: dict(v) for k, v in dict(self.options or {}).items()})
        obs = ObservationModel(used, motion, opts)
        noise = NoiseModel(obs.grouped, obs.models)
        nu = np.zeros(0)
        cost = 0.5 * float(np.sum(noise.whiten(obs.values_grouped
                                                - obs.predict_grouped(theta, nu)) ** 2))
        note = (f"closed form on {rows.size} of {len(meas)} rows (one reference"
                + (f", t = {snap.time:g} s" if self.moving else "") + ")")
        return assemble_result(obs, noise, theta, nu, cost, 0, True, self.name, 1, None, note)


@dataclass(frozen=True, eq=False)
class ChanHo(_ClosedForm):
    """Chan & Ho (1994): a stationary source from TDOAs, two-stage weighted least squares."""

    name: ClassVar[str] = "chan-ho"

    def _check(self, meas: MeasurementSet, motion: MotionModel) -> float | None:
        """Refuse a moving source; no carrier is used."""
        if not isinstance(motion, Stationary):
            raise ValueError("chan-ho: Chan & Ho (1994) locate a stationary source (motion "
                             f"static2d or static3d), got {motion.name}; use ho-xu with FDOA "
                             "or ml for a moving one")
        return None


@dataclass(frozen=True, eq=False)
class HoXu(_ClosedForm):
    """Ho & Xu (2004): a moving source from TDOAs and FDOAs (``options``: the FDOA carrier)."""

    name: ClassVar[str] = "ho-xu"
    moving: ClassVar[bool] = True

    def _check(self, meas: MeasurementSet, motion: MotionModel) -> float | None:
        """Refuse a model other than constant velocity, or an unknown carrier."""
        if not isinstance(motion, ConstantVelocity):
            raise ValueError("ho-xu: Ho & Xu (2004) locate a source at constant velocity "
                             f"(motion cv2d or cv3d), got {motion.name}")
        carrier = _known_carrier(meas, self.options)
        if carrier is None:
            raise ValueError("ho-xu: the FDOA carrier must be known (the file's "
                             "'# fdoa_carrier: HZ', or options {'fdoa': {'carrier': HZ}}); "
                             "use ml to estimate it")
        return carrier


def closed_form_starts(obs: ObservationModel, ys: Array) -> dict[int, Array]:
    """Give the closed-form start of each data set ``ys (B, n)`` (the set's row order)."""
    if "tdoa" not in obs.models:
        return {}
    theta = closed_form_many(obs.meas, ys, obs.motion, obs.options)
    if theta is None:
        return {}
    return {r: theta[r][None, :] for r in range(ys.shape[0]) if np.isfinite(theta[r, 0])}
