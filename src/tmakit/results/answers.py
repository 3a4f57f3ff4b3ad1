"""Answers in the user's terms: position, course, speed, range and bearing, and the ellipse.

Std are linearised (the delta method); an unobservable quantity is ``None``, never a number.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import chi2 as chi2_dist
from ..core.frames import wrap_angle
from ..core.geodesy import enu_to_geodetic
from ..data import MeasurementSet
from .context import altitude_reference, clock_time, origin_of, sensor_position

KNOT = 1852.0 / 3600.0
"""One knot in m/s (one nautical mile, 1852 m, per hour)."""

ELLIPSE_LEVEL = 0.95
"""Default probability inside the reported position ellipse."""

#: A quantity is unobservable when its gradient's cosine with a null direction exceeds this.
NULL_COSINE = 0.05

#: An angle (course, bearing) whose linearised 1-sigma exceeds this (deg) is not determined.
UNDETERMINED_ANGLE_DEG = 60.0
#: A speed or range whose 1-sigma exceeds this multiple of its value is not determined.
UNDETERMINED_RATIO = 3.0


def _std(grad: NDArray[np.float64], cov: NDArray[np.float64],
         null: NDArray[np.float64] | None = None) -> float | None:
    """Return the linearised std ``sqrt(g^T P g)``; None when unobservable."""
    used = grad != 0
    if not np.any(used):
        return 0.0
    if null is not None and null.size:
        # Within the components used (a velocity moves by 1e-3 of a position along a range
        # scaling), but round-off (1e-16 of the whole null direction) is no motion.
        whole = np.linalg.norm(null, axis=0)
        part = np.linalg.norm(null[used], axis=0)
        moving = part > 1e-9 * whole
        if np.any(np.abs(grad @ null[:, moving])
                  > NULL_COSINE * part[moving] * np.linalg.norm(grad)):
            return None
    sub = cov[np.ix_(used, used)]
    if not np.all(np.isfinite(sub)):
        return None
    var = float(grad[used] @ sub @ grad[used])
    return float(np.sqrt(max(var, 0.0))) if np.isfinite(var) else None


def finite(x: float) -> float | None:
    """Give ``x`` as JSON has it: a float, or None where it is not finite."""
    return float(x) if np.isfinite(x) else None


@dataclass(frozen=True)
class Ellipse:
    """The horizontal position's confidence ellipse.

    Parameters
    ----------
    semi_major, semi_minor, orientation_deg, level : float
        Semi-axes, m; the major axis, degrees true (0 to 180); the probability inside.
    """

    semi_major: float
    semi_minor: float
    orientation_deg: float
    level: float


def position_ellipse(cov2: NDArray[np.float64], level: float = ELLIPSE_LEVEL
                     ) -> Ellipse | None:
    """Return the confidence ellipse of an East/North position covariance."""
    if not np.all(np.isfinite(cov2)):
        return None
    k = float(np.sqrt(chi2_dist.ppf(level, 2)))
    evals, evecs = np.linalg.eigh(0.5 * (cov2 + cov2.T))
    major = evecs[:, 1]
    return Ellipse(k * float(np.sqrt(max(evals[1], 0.0))), k * float(np.sqrt(max(evals[0], 0.0))),
                   float(np.degrees(np.arctan2(major[0], major[1])) % 180.0), level)


@dataclass(frozen=True)
class Answer:
    """The emitter at one time in the user's terms; ``None`` marks what is unobservable.

    Parameters
    ----------
    time, clock : float, str or None
        s since the set's time origin; the same time in UTC, when the origin is known.
    dim, stationary : int, bool
    enu, enu_std, velocity, velocity_std : tuple of (float or None)
        East, North, Up, m and m/s.
    geodetic : tuple of (float or None) or None
        Latitude, longitude (deg), altitude (m); None without an origin.
    course_deg, course_std_deg, bearing_deg, bearing_std_deg : float or None
        Degrees true.
    speed, speed_std, range_m, range_std : float or None
        m/s; slant range from ``sensor``, m.
    sensor : str or None
    ellipse : Ellipse or None
    covariance : ndarray, shape (6, 6)
        ENU state covariance; infinite where unobservable.
    altitude_reference : str
    undetermined : tuple of str
        Quantities left out because their 1-sigma is too large, in words.
    """

    time: float
    clock: str | None
    dim: int
    stationary: bool
    enu: tuple[float | None, ...]
    enu_std: tuple[float | None, ...]
    geodetic: tuple[float | None, ...] | None
    velocity: tuple[float | None, ...]
    velocity_std: tuple[float | None, ...]
    course_deg: float | None
    course_std_deg: float | None
    speed: float | None
    speed_std: float | None
    sensor: str | None
    range_m: float | None
    range_std: float | None
    bearing_deg: float | None
    bearing_std_deg: float | None
    ellipse: Ellipse | None
    covariance: NDArray[np.float64] = field(repr=False)
    altitude_reference: str = "WGS-84 ellipsoid"
    undetermined: tuple[str, ...] = ()

    @property
    def position_determined(self) -> bool:
        """Whether the position is given and its range from the sensor is determined."""
        return (self.enu[0] is not None and self.enu[1] is not None
                and not any(w.startswith("range") for w in self.undetermined))

    @property
    def speed_knots(self) -> float | None:
        """Speed in knots (None when unobservable or stationary)."""
        return None if self.speed is None else self.speed / KNOT

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form (SI units and degrees; ``None`` where unobservable).

        Returns
        -------
        dict
        """
        def pair(v: float | None, s: float | None) -> dict[str, float | None]:
            return {"value": v, "std": s}

        pos: dict[str, object] = {n: pair(v, s) for n, v, s in
                                  zip(("east_m", "north_m", "up_m"), self.enu, self.enu_std,
                                      strict=True)}
        if self.geodetic is not None:
            pos.update(lat_deg=self.geodetic[0], lon_deg=self.geodetic[1],
                       alt_m=self.geodetic[2], altitude_reference=self.altitude_reference)
        cov = [[finite(c) for c in row] for row in self.covariance]
        kn = None if self.speed_std is None else self.speed_std / KNOT
        return {
            "time_s": self.time, "clock": self.clock, "stationary": self.stationary,
            "position": pos,
            "velocity": {n: pair(v, s) for n, v, s in zip(
                ("east_mps", "north_mps", "up_mps"), self.velocity, self.velocity_std,
                strict=True)},
            "course_deg": pair(self.course_deg, self.course_std_deg),
            "speed_mps": pair(self.speed, self.speed_std),
            "speed_kn": pair(self.speed_knots, kn),
            "from_sensor": {"sensor": self.sensor, "range_m": pair(self.range_m, self.range_std),
                            "bearing_deg": pair(self.bearing_deg, self.bearing_std_deg)},
            "ellipse": (None if self.ellipse is None else {
                "semi_major_m": self.ellipse.semi_major, "semi_minor_m": self.ellipse.semi_minor,
                "orientation_deg_true": self.ellipse.orientation_deg,
                "level": self.ellipse.level}),
            "state": ["east", "north", "up", "v_east", "v_north", "v_up"],
            "state_covariance": cov,
            "std_method": "linearised (delta method) from the covariance",
        }


def _finite(v: float, s: float | None) -> tuple[float | None, float | None]:
    """Return a value and its std, both None when the std says the value is unobservable."""
    if s is None or not np.isfinite(v):
        return None, None
    return float(v), s


def _size_and_direction(vector: NDArray[np.float64], at: int, cov: NDArray[np.float64],
                        null: NDArray[np.float64] | None = None
                        ) -> tuple[float | None, float | None, float | None, float | None]:
    """Length and direction (deg true) of a 3-vector of the state at ``at``, with their std."""
    h2 = float(vector[0] ** 2 + vector[1] ** 2)
    if h2 == 0.0:
        return None, None, None, None
    length = float(np.linalg.norm(vector))
    g = np.zeros(6)
    g[at:at + 3] = vector / length
    size, size_sd = _finite(length, _std(g, cov, null))
    g = np.zeros(6)
    g[at], g[at + 1] = vector[1] / h2, -vector[0] / h2
    a_sd = _std(g, cov, null)
    angle, angle_sd = _finite(float(np.degrees(np.arctan2(vector[0], vector[1])) % 360.0),
                              None if a_sd is None else float(np.degrees(a_sd)))
    return size, size_sd, angle, angle_sd


def answer_from_state(state: NDArray[np.float64], cov: NDArray[np.float64], t: float,
                      meas: MeasurementSet | None = None, sensor: str | None = None,
                      dim: int = 3, stationary: bool = False,
                      level: float = ELLIPSE_LEVEL,
                      null: NDArray[np.float64] | None = None) -> Answer:
    """Return the answer for a state and covariance (inf/NaN: unobservable; ``null``: its nulls)."""
    state = np.asarray(state, dtype=float)
    cov = np.where(np.isnan(cov), np.inf, np.asarray(cov, dtype=float))
    parts = [_finite(state[i], _std(np.eye(6)[i], cov, null))
             if i % 3 < dim and (i < 3 or not stationary) else (None, None) for i in range(6)]
    enu, enu_sd = zip(*parts[:3], strict=True)
    vel, vel_sd = zip(*parts[3:], strict=True)
    speed, speed_sd, course, course_sd = (None, None, None, None) if stationary else (
        _size_and_direction(state[3:6], 3, cov, null))
    origin = origin_of(meas)
    geo: tuple[float | None, float | None, float | None] | None = None
    if origin is not None:
        geo = (None, None, None)
        if enu[0] is not None and enu[1] is not None:
            # An unobservable height (a 3-D bearings-only fit) must not move lat/lon.
            up = state[2] if dim == 3 and enu[2] is not None else 0.0
            lat, lon, alt = enu_to_geodetic(state[0], state[1], up, origin)
            geo = (float(lat), float(lon), float(alt) if enu[2] is not None or dim == 2 else None)
    if meas is not None and len(meas) and sensor is None:
        sensor = meas.sensor_names[int(meas.sensor_code[int(np.argmax(meas.time))])]
    rng = rng_sd = brg = brg_sd = None
    if meas is not None and sensor is not None and np.all(np.isfinite(state[:2])):
        where = sensor_position(meas, sensor, t)
        if dim == 2:
            where = np.array([where[0], where[1], state[2]])
        rng, rng_sd, brg, brg_sd = _size_and_direction(state[:3] - where, 0, cov, null)
    weak: list[str] = []
    course, course_sd = _determined("course", course, course_sd, weak)
    speed, speed_sd = _determined("speed", speed, speed_sd, weak, "m/s")
    rng, rng_sd = _determined("range", rng, rng_sd, weak, "m")
    brg, brg_sd = _determined("bearing", brg, brg_sd, weak)
    return Answer(float(t), clock_time(meas, t), dim, stationary, tuple(enu), tuple(enu_sd), geo,
                  tuple(vel), tuple(vel_sd), course, course_sd, speed, speed_sd, sensor, rng,
                  rng_sd, brg, brg_sd,
                  position_ellipse(cov[:2, :2], level) if None not in enu[:2] else None, cov,
                  altitude_reference(meas), tuple(weak))


def _determined(name: str, v: float | None, s: float | None, weak: list[str],
                unit: str | None = None) -> tuple[float | None, float | None]:
    """Give ``v, s``, or None (said in ``weak``) where the 1-sigma is too large (no unit: deg)."""
    if v is None or s is None or s <= (UNDETERMINED_ANGLE_DEG if unit is None
                                       else UNDETERMINED_RATIO * v):
        return v, s
    weak.append(f"{name} (1-sigma {s:.0f} deg)" if unit is None
                else f"{name} (1-sigma {s:.3g} {unit} against {v:.3g} {unit})")
    return None, None


def bearing_interval(answer: Answer, meas: MeasurementSet | None,
                     level: float = ELLIPSE_LEVEL) -> tuple[float, float] | None:
    """Give the hull (centre, half-width; deg) of the answer's and measured bearings' intervals."""
    z = float(np.sqrt(chi2_dist.ppf(level, 1)))
    spans = []  # (centre, half-width), rad
    if answer.bearing_deg is not None and answer.bearing_std_deg is not None:
        spans.append((np.radians(answer.bearing_deg), z * np.radians(answer.bearing_std_deg)))
    if meas is not None and answer.sensor in meas.sensors:
        rows = np.flatnonzero(meas.kind_mask("bearing") & meas.sensor_mask(answer.sensor)
                              & (meas.time == answer.time))
        for i in rows:
            seen = np.array([meas.value_si[i]] if meas.ambiguous_si is None or not spans
                            else [meas.value_si[i], meas.ambiguous_si[i]])
            near = np.nanargmin(np.abs(wrap_angle(seen - spans[0][0]))) if spans else 0
            spans.append((float(seen[near]), z * float(meas.sigma_si[i])))
    if not spans:
        return None
    offs = wrap_angle([c - spans[0][0] for c, _ in spans])
    lo = min(o - h for o, (_, h) in zip(offs, spans, strict=True))
    hi = max(o + h for o, (_, h) in zip(offs, spans, strict=True))
    return (float(np.degrees(spans[0][0] + (lo + hi) / 2.0) % 360.0),
            float(np.degrees(hi - lo) / 2.0))


def in_bearing_interval(position: ArrayLike, answer: Answer,
                        meas: MeasurementSet | None, level: float = ELLIPSE_LEVEL) -> bool:
    """Whether a horizontal position (East, North, m) lies in :func:`bearing_interval`."""
    span = bearing_interval(answer, meas, level)
    if span is None:
        return False
    where = (sensor_position(meas, answer.sensor, answer.time)
             if meas is not None and answer.sensor is not None else np.zeros(3))
    d = np.asarray(position, dtype=float)[:2] - where[:2]
    return bool(np.degrees(abs(wrap_angle(np.arctan2(d[0], d[1]) - np.radians(span[0]))))
                <= span[1])


def estimate_answer(result: object, meas: MeasurementSet | None = None,
                    time: float | None = None, sensor: str | None = None,
                    level: float = ELLIPSE_LEVEL) -> Answer:
    """Return a batch estimate in the user's terms at ``time`` (default the last measurement's)."""
    from ..rules import time_problem

    motion = result.motion  # type: ignore[attr-defined]
    if time is None:
        time = (float(np.max(meas.time)) if meas is not None and len(meas)
                else float(getattr(motion, "ref_time", 0.0)))
    problem = time_problem(float(time), None if meas is None else meas.time, "time")
    if problem is not None:
        raise ValueError(problem)
    state, cov, jac, null = fit_state(result, float(time))
    stationary = not np.any(jac[3:6]) and not np.any(state[3:6])  # nothing moves it
    return answer_from_state(state, cov, float(time), meas, sensor, motion.dim,
                             bool(stationary), level, null)


def covering_scale(state: NDArray[np.float64], cov: NDArray[np.float64],
                   others: list[tuple[NDArray[np.float64], NDArray[np.float64]]]) -> float:
    """Give the factor on ``cov`` whose 95 % position ellipse contains the others'."""
    q = float(chi2_dist.ppf(ELLIPSE_LEVEL, 2))
    scale = 1.0
    try:
        low = np.linalg.cholesky(cov[:2, :2])
    except np.linalg.LinAlgError:
        return 1.0
    for st, c in others:
        if not (np.all(np.isfinite(c[:2, :2])) and np.all(np.isfinite(st[:2]))):
            continue
        try:
            lj = np.linalg.cholesky(c[:2, :2])
        except np.linalg.LinAlgError:
            continue
        d = np.linalg.solve(low, st[:2] - state[:2])
        spread = float(np.linalg.svd(np.linalg.solve(low, lj), compute_uv=False)[0])
        scale = max(scale, (float(np.linalg.norm(d)) / np.sqrt(q) + spread) ** 2)
    return scale


def fit_state(result: object, time: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                         NDArray[np.float64] | None]:
    """Give :func:`_state_at` with the covariance widened to cover ``result.covers``."""
    state, cov, jac, null = _state_at(result, time)
    covers = getattr(result, "covers", ())
    if covers and null is None:
        cov = cov * covering_scale(state, cov, [_state_at(r, time)[:2] for r in covers])
    return state, cov, jac, null


def _state_at(result: object, time: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                         NDArray[np.float64] | None]:
    """State, covariance, d state / d theta and null motion of a fit at ``time``."""
    motion = result.motion  # type: ignore[attr-defined]
    theta = np.asarray(result.estimate, dtype=np.float64)  # type: ignore[attr-defined]
    t = np.array([float(time)])
    null = None
    if not np.all(np.isfinite(theta)):
        state, jac = np.full(6, np.nan), np.zeros((6, theta.size))
        cov = np.full((6, 6), np.inf)
    else:
        state = motion.states(theta, t)[0]
        jac = motion.jacobian(theta, t)[0]
        bound = result.bound  # type: ignore[attr-defined]
        if bound is not None:
            state, cov = bound.state_covariance(float(time))
            basis = bound.observability.null_basis
            if basis.size:  # (in the bound's parameters: a manoeuvre fit's held ones are not)
                seen = bound.motion.jacobian(bound.values[: bound.motion.n_params], t)[0]
                null = seen @ basis[: seen.shape[1]]
                # On the observable subspace: what does not move with ``null`` (the bearing
                # of a range-free fit) keeps its std.
                full = np.zeros((6, len(bound.parameters)))
                full[:, : seen.shape[1]] = seen
                pseudo = full @ bound.covariance @ full.T
                cov = np.where(np.isfinite(pseudo), pseudo, cov)
        else:
            cov = jac @ np.asarray(result.covariance) @ jac.T  # type: ignore[attr-defined]
    return state, cov, jac, null


def track_answer(track: object, meas: MeasurementSet | None = None, index: int = -1,
                 sensor: str | None = None, level: float = ELLIPSE_LEVEL) -> Answer:
    """Return a filter's state after one update in the user's terms.

    Parameters
    ----------
    track : tmakit.filters.Track
    index : int
        The update (default the last).
    meas, sensor, level : optional
        As for :meth:`EstimateResult.answer <tmakit.results.EstimateResult.answer>`.

    Returns
    -------
    Answer
    """
    names = tuple(track.state_names)  # type: ignore[attr-defined]
    dim = len(names) // 2
    idx = [*range(dim), *range(3, 3 + dim)]
    state = np.zeros(6)
    cov = np.zeros((6, 6))
    state[idx] = track.states[index]  # type: ignore[attr-defined]
    cov[np.ix_(idx, idx)] = track.covariances[index]  # type: ignore[attr-defined]
    t = float(track.times[index])  # type: ignore[attr-defined]
    return answer_from_state(state, cov, t, meas, sensor, dim, False, level)


#: Units of motion and nuisance parameters on screen, by name (angles shown in degrees).
_PARAM_UNITS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s",
                "speed": "m/s", "course": "deg", "carrier": "Hz", "drift": "Hz/s",
                "power_constant_db": "dBW", "exponent": "", "path_loss_exponent": ""}


def parameter_display(name: str, value: float, std: float) -> tuple[float, float, str]:
    """Return a parameter's value and std in the unit shown to the user, and that unit."""
    unit = _PARAM_UNITS.get(name.partition("[")[0])  # carrier[TONAL]: a tonal's carrier
    if unit is None:
        unit = ("m/s^2" if name.startswith(("at_", "an_"))
                else "s" if name.startswith("t_") else "")
    if unit == "deg":  # a course is shown in degrees true, 0 to 360
        shown = float(np.degrees(value))
        return (shown % 360.0 if name == "course" and np.isfinite(shown) else shown,
                float(np.degrees(std)), unit)
    return float(value), float(std), unit
