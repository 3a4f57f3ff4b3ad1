"""Tracking a measurement file with a recursive filter: choosing the start, running the filter,
writing the track.

:func:`track` needs no initial guess.  By default it starts the filter from a batch
maximum-likelihood estimate (:func:`tmakit.batch.estimate`, constant velocity referenced at
the window's last time) over the shortest initial window of the data that is good enough to
linearise around: the estimate converged, the data of the window make every state component
observable, and the position's largest 1-sigma semi-axis is below ``max_relative_std`` times
the estimated range to the nearest sensor.  The last condition matters: a bearings-only EKF
started from an estimate that is merely observable (range known to 70 %) diverges; one
started below 25 % stays consistent (``docs/tracking.md`` gives the numbers).  The window
doubles from :data:`MIN_WINDOW` measurement times until it qualifies, then bisection finds
the shortest one that does (the quality improves with the window length, if not strictly).
The filter then runs over the rows after the window, and the track's first row is the batch
estimate at the window's end.

Alternatively an explicit Gaussian prior (``prior`` and ``prior_std``, by state name) starts
the filter at the first measurement time, and the filter updates with every row.

The nuisance parameters (carrier, power constant, ...) a filter must know come from the batch
estimate, or are given (``nuisance=``) with a prior.  Everything is SI (m, m/s, s).
"""

from __future__ import annotations

import inspect
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .data import MeasurementSet
from .filters import FILTERS, Track, TrackingFilter, group_times, state_names

if TYPE_CHECKING:  # pragma: no cover
    from .results.estimate import EstimateResult

__all__ = [
    "DEFAULT_MAX_RELATIVE_STD",
    "batch_start",
    "filter_dim",
    "parse_q",
    "random_filters",
    "track",
    "track_dict",
    "track_pcrb",
    "truth_states",
    "write_track",
]

Array = NDArray[np.float64]

#: Default start quality: the position's largest 1-sigma semi-axis over the range.
DEFAULT_MAX_RELATIVE_STD = 0.25
#: The smallest initial window tried (distinct measurement times).
MIN_WINDOW = 8
#: A batch start is rejected (and a longer window tried) when the innovations of the updates
#: that follow it are this improbable (chi-square test of their summed NIS).
CONFIRM_P_VALUE = 1e-3
#: Table suffixes :func:`write_track` understands.
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")

_THREE_D_MOTIONS = ("cv3d", "static3d")


def filter_dim(meas: MeasurementSet, dim: int | None = None) -> int:
    """The filter's spatial dimension: ``dim`` if given (2 or 3), else 3 when the data need
    it (:attr:`MeasurementSet.dim`: elevation, or a sensor off the plane z = 0) or the
    file's metadata names a 3-D motion model (``cv3d``, ``static3d``), else 2."""
    if dim is not None:
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        return int(dim)
    if meas.dim == 3:
        return 3
    return 3 if meas.metadata.get("motion", "").strip().lower() in _THREE_D_MOTIONS else 2


def parse_q(q: float | str | ArrayLike, dim: int) -> tuple[float, ...]:
    """Process noise as ``dim`` per-axis acceleration standard deviations (m/s^2).

    ``q``: one number for every axis, ``dim`` numbers, or text ``"0.01"`` / ``"qx,qy[,qz]"``.
    """
    if isinstance(q, str):
        parts = [p.strip() for p in q.split(",")]
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise ValueError(f"q {q!r}: expected one number or {dim} numbers separated by "
                             "commas (m/s^2 per axis, e.g. 0.01 or "
                             f"{','.join(['0.01'] * dim)})") from None
    else:
        values = np.atleast_1d(np.asarray(q, dtype=float)).tolist()
    if len(values) == 1:
        values = values * dim
    if len(values) != dim:
        axes = "qx,qy" if dim == 2 else "qx,qy,qz"
        raise ValueError(f"q: expected one value or {dim} per-axis values ({axes}) for a "
                         f"{dim}-D track, got {len(values)}")
    if not all(np.isfinite(v) and v >= 0 for v in values):
        raise ValueError(f"q: process noise must be finite and >= 0 m/s^2, got {values}")
    return tuple(float(v) for v in values)


def _vector(values: Mapping[str, float] | ArrayLike, names: tuple[str, ...], what: str
            ) -> Array:
    if isinstance(values, Mapping):
        unknown = sorted(set(values) - set(names))
        missing = [n for n in names if n not in values]
        if unknown or missing:
            raise ValueError(
                f"{what}: expected the state components {', '.join(names)}"
                + (f"; missing {', '.join(missing)}" if missing else "")
                + (f"; unknown {', '.join(unknown)}" if unknown else ""))
        out = np.array([float(values[n]) for n in names])
    else:
        out = np.asarray(values, dtype=float).reshape(-1)
        if out.shape != (len(names),):
            raise ValueError(f"{what}: expected {len(names)} values ({', '.join(names)}), "
                             f"got {out.size}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{what}: values must be finite, got {out.tolist()}")
    return out


def _filter_class(name: str) -> type[TrackingFilter]:
    cls = FILTERS.get(name)
    if cls is None:
        raise ValueError(f"filter {name!r}: expected one of {', '.join(sorted(FILTERS))}")
    return cls


def _filter_kwargs(cls: type[TrackingFilter], particles: int | None,
                   rng: np.random.Generator | int | None) -> dict[str, Any]:
    """The particle count and random generator, for the filters that take them."""
    params = inspect.signature(cls.__init__).parameters
    kwargs: dict[str, Any] = {}
    if particles is not None:
        key = next((k for k in ("particles", "n_particles") if k in params), None)
        if key is None:
            raise ValueError(f"particles: the {cls.name} filter has no particles; the number "
                             "of particles applies only to particle filters "
                             f"({', '.join(random_filters()) or 'none registered'})")
        if isinstance(particles, bool) or int(particles) != particles:
            raise ValueError(f"particles: expected a whole number, got {particles!r}")
        kwargs[key] = int(particles)
    key = next((k for k in ("rng", "seed") if k in params), None)
    if key is not None:
        kwargs[key] = np.random.default_rng(rng)
    return kwargs


def random_filters() -> list[str]:
    """Names of the registered filters that draw random numbers (take ``rng``/``seed``)."""
    return [n for n, c in sorted(FILTERS.items())
            if {"rng", "seed"} & set(inspect.signature(c.__init__).parameters)]


def _window_check(result: EstimateResult, rows: MeasurementSet, time: float, dim: int
                  ) -> tuple[bool, float]:
    """Whether a window's estimate is a good start, and its relative position std."""
    if result.status != "converged":
        return False, np.inf
    theta = result.estimate
    motion = result.motion
    keep = list(range(dim))
    state = motion.states(theta, np.array([time]))[0]
    jac = motion.jacobian(theta, np.array([time]))[0][keep]
    cov = jac @ result.covariance @ jac.T
    if not np.all(np.isfinite(cov)):
        return False, np.inf
    last = np.abs(rows.time - rows.time.max()) < 1e-9
    ranges = np.linalg.norm(state[None, :dim] - rows.sensor_state[last][:, :dim], axis=1)
    rng = float(np.min(ranges))
    major = float(np.sqrt(max(np.max(np.linalg.eigvalsh(cov)), 0.0)))
    rel = major / rng if rng > 0 else np.inf
    return True, rel


def batch_start(meas: MeasurementSet, dim: int,
                options: Mapping[str, Mapping[str, object]] | None = None,
                init_window: int | None = None,
                max_relative_std: float = DEFAULT_MAX_RELATIVE_STD, *,
                min_window: int = MIN_WINDOW
                ) -> tuple[EstimateResult, float, int, dict[str, object]]:
    """The batch estimate the filter starts from, over an initial window of ``meas``.

    ``init_window``: the number of distinct measurement times to use (the estimate must then
    converge and be observable); by default the shortest window of at least ``min_window``
    times that passes the start quality test (see the module docstring) is searched for.
    Returns the estimate (constant velocity referenced at the window's last time), that time
    (s), the number of distinct times used, and a description of the start.  Raises
    ``ValueError`` when no window qualifies.
    """
    from .batch import estimate
    from .motion import ConstantVelocity

    groups = group_times(meas)
    n = len(groups)
    if n == 0:
        raise ValueError("the measurement set is empty: nothing to track")
    if init_window is not None:
        if int(init_window) != init_window or not 1 <= init_window <= n:
            raise ValueError(f"init_window: expected a whole number of measurement times "
                             f"from 1 to {n}, got {init_window}")
    elif not max_relative_std > 0:
        raise ValueError(f"max_relative_std must be > 0, got {max_relative_std}")

    tried: dict[int, tuple[EstimateResult | None, float, int, float, str]] = {}

    def evaluate(k: int) -> tuple[EstimateResult | None, float, int, float, str]:
        """(estimate, window end time, rows, relative position std or inf, problem)."""
        if k not in tried:
            rows = meas.take(np.concatenate(groups[:k]))
            time = float(rows.time.max())
            try:
                result = estimate(rows, ConstantVelocity(dim, time), options=options)
            except ValueError as e:  # e.g. no finite starting point on a tiny window
                tried[k] = (None, time, len(rows), np.inf, f"failed: {e}")
            else:
                ok, rel = _window_check(result, rows, time, dim)
                problem = "" if ok else result.status + (
                    f": {result.message}" if result.message else "")
                tried[k] = (result, time, len(rows), rel, problem)
        return tried[k]

    def start(k: int) -> tuple[EstimateResult, float, int, dict[str, object]]:
        result, time, n_rows, rel, _ = evaluate(k)
        assert result is not None
        info = {
            "method": "batch",
            "window": k,
            "rows": n_rows,
            "time": time,
            "status": result.status,
            "chi2": float(result.chi2),
            "dof": int(result.dof),
            "relative_position_std": float(rel),
            "max_relative_std": None if init_window is not None else max_relative_std,
            "windows_tried": len(tried),
            "nuisance": {name: {"value": v, "std": sd}
                         for name, (v, sd) in result.nuisance.items()},
        }
        return result, time, k, info

    if init_window is not None:
        k = int(init_window)
        _, time, _, _, problem = evaluate(k)
        if problem:
            raise ValueError(f"the batch estimate over the first {k} measurement times "
                             f"(t <= {time:g} s) {'' if problem.startswith('failed') else 'is '}"
                             f"{problem}; use a longer window or give a prior")
        return start(k)

    def good(k: int) -> bool:
        return evaluate(k)[3] < max_relative_std

    # Double the window until it qualifies, then bisect down to the shortest that does.
    k = min(max(int(min_window), 1), n)
    bad = k - 1
    while not good(k):
        if k == n:
            usable = [(v[3], kk) for kk, v in tried.items() if np.isfinite(v[3])]
            if usable:
                rel, kk = min(usable)
                detail = (f"the best converged, observable window ({kk} measurement times) "
                          f"has a position std of {rel:.0%} of the range")
            else:
                detail = "no window gave a converged, observable estimate"
            raise ValueError(
                f"cannot start the filter from the data: {detail}, and the start needs less "
                f"than {max_relative_std:.0%} ({len(tried)} windows of up to {n} measurement "
                "times tried); give a prior (--prior/--prior-std) or relax the start quality "
                "(--start-std)")
        bad = k
        k = min(2 * k, n)
    while k - bad > 1:
        mid = (k + bad) // 2
        if good(mid):
            k = mid
        else:
            bad = mid
    return start(k)


def track(meas: MeasurementSet, filter: str = "ekf", q: float | str | ArrayLike = 0.0,
          particles: int | None = None,
          prior: Mapping[str, float] | ArrayLike | None = None,
          prior_std: Mapping[str, float] | ArrayLike | None = None,
          prior_time: float | None = None,
          init_window: int | None = None,
          max_relative_std: float = DEFAULT_MAX_RELATIVE_STD,
          confirm: bool = True,
          rng: np.random.Generator | int | None = None,
          dim: int | None = None,
          options: Mapping[str, Mapping[str, object]] | None = None,
          nuisance: Mapping[str, float] | None = None) -> Track:
    """Track the emitter through ``meas`` with a recursive filter; returns the
    :class:`~tmakit.filters.Track` (one row per update, SI).

    ``filter``: a name of :data:`tmakit.filters.FILTERS` (``ekf``, ...).  ``q``:
    nearly-constant-velocity process noise, one acceleration standard deviation (m/s^2) for
    every axis or one per axis (:func:`parse_q`).  ``particles`` and ``rng`` (a Generator or
    seed): for particle filters only (``particles`` for another filter is an error).

    Start: from ``prior`` and ``prior_std`` (by state name ``x, y, (z), vx, vy, (vz)`` or
    as vectors; independent components) at ``prior_time`` (default: the first measurement
    time), with known ``nuisance`` values if the kinds need them; otherwise from a batch
    estimate over an initial window (:func:`batch_start`: ``init_window``,
    ``max_relative_std``), confirmed by the innovations of the updates that follow it
    (``confirm``; a rejected start is replaced by one from a window at least twice as long,
    see :data:`CONFIRM_P_VALUE`).  ``dim``: 2 or 3 (default :func:`filter_dim`); ``options``:
    per-kind model options as for :func:`tmakit.batch.estimate`.

    ``track.extra["start"]`` says which start was used; ``track.extra["q"]`` the per-axis q.
    After a batch start the first row is the batch estimate at the window's last time (NIS
    NaN, no degrees of freedom) and the log-likelihood counts the rows after it.
    """
    if not isinstance(meas, MeasurementSet):
        raise TypeError(f"meas must be a MeasurementSet, got {type(meas).__name__}")
    cls = _filter_class(filter)
    d = filter_dim(meas, dim)
    q_axes = parse_q(q, d)
    kwargs = _filter_kwargs(cls, particles, rng)
    if options:
        kwargs["options"] = options
    if len(meas) == 0:
        raise ValueError("the measurement set is empty: nothing to track")
    names = state_names(d)
    if prior is not None or prior_std is not None:
        if prior is None or prior_std is None:
            raise ValueError("a prior needs both its mean (prior) and its standard deviations "
                             "(prior_std)")
        mean = _vector(prior, names, "prior")
        std = _vector(prior_std, names, "prior_std")
        if np.any(std <= 0):
            raise ValueError(f"prior_std: standard deviations must be > 0, got {std.tolist()}")
        _check_nuisance(meas, options, nuisance)
        t0 = float(np.min(meas.time)) if prior_time is None else float(prior_time)
        filt = cls(mean, np.diag(std**2), t0, q=q_axes, nuisance=nuisance, **kwargs)
        start_state = (t0, mean, np.diag(std**2), dict(nuisance or {}))
        result = filt.run(meas)
        start: dict[str, object] = {"method": "prior", "time": t0,
                                    "mean": dict(zip(names, mean.tolist(), strict=True)),
                                    "std": dict(zip(names, std.tolist(), strict=True))}
    else:
        if nuisance:
            raise ValueError("nuisance values are taken from the batch estimate; give them "
                             "only with a prior")
        rejected: list[dict[str, Any]] = []
        first = MIN_WINDOW
        while True:
            try:
                est, t0, k, start = batch_start(meas, d, options, init_window,
                                                max_relative_std, min_window=first)
            except ValueError as e:
                if not rejected:
                    raise
                raise ValueError(f"{e}; earlier starts were rejected by the innovations that "
                                 "followed them: " + "; ".join(
                                     _rejection_text(r) for r in rejected)) from None
            filt = cls.from_estimate(est, t0, q=q_axes, **kwargs)
            start_state = (t0, filt.state, filt.covariance, dict(filt.nuisance))
            rest = meas.take(meas.time > t0 + 1e-9)
            after = filt.run(rest)
            check = _confirmation(after, k)
            start["confirmation"] = check
            if (not confirm or init_window is not None
                    or check["p_value"] >= CONFIRM_P_VALUE):
                break
            # (the whole data as window leaves no updates to test: p = 1, accepted)
            rejected.append({"window": k, "time": t0, **check})
            first = 2 * k
        start["rejected"] = rejected
        result = _prepend(after, *start_state[:3], names)
    result.extra["start"] = start
    result.extra["q"] = list(q_axes)
    result.extra["dim"] = d
    result.extra["prior"] = start_state  # (time, mean, covariance, nuisance) the filter began
    result.extra["options"] = dict(options or {})
    return result


def _check_nuisance(meas: MeasurementSet, options: Mapping[str, Mapping[str, object]] | None,
                    nuisance: Mapping[str, float] | None) -> None:
    """With a prior, the nuisance parameters of the kinds present must be given."""
    from .measurements import model_for

    given = set(nuisance or {})
    missing: dict[str, list[str]] = {}
    for kind in meas.kinds:
        model = model_for(kind, **dict((options or {}).get(kind, {})))
        names = [n for n in model.nuisance_names if n not in given]
        if names:
            missing[kind] = names
    if missing:
        flat = [n for names in missing.values() for n in names]
        raise ValueError(
            "with a prior the nuisance values must be given: "
            + "; ".join(f"the {k} measurements need {', '.join(v)}" for k, v in missing.items())
            + f" (nuisance={{...}}; --nuisance {','.join(f'{n}=...' for n in flat)}); a batch "
            "start estimates them itself")


def _confirmation(after: Track, window: int) -> dict[str, float | int]:
    """The innovation test of a start: the NIS summed over the next ``max(window,
    MIN_WINDOW)`` updates against chi-square with their degrees of freedom."""
    from scipy.stats import chi2

    m = min(len(after), max(window, MIN_WINDOW))
    nis = float(np.sum(after.nis[:m]))
    dof = int(np.sum(after.dof[:m]))
    p = float(chi2.sf(nis, dof)) if dof > 0 and np.isfinite(nis) else (1.0 if dof == 0
                                                                          else 0.0)
    return {"updates": m, "nis": nis, "dof": dof, "p_value": p}


def _rejection_text(r: Mapping[str, Any]) -> str:
    return (f"window of {r['window']} times (t <= {float(r['time']):g} s): NIS "
            f"{float(r['nis']):.4g} on {r['dof']} degrees of freedom over the next "
            f"{r['updates']} updates (p = {float(r['p_value']):.2g})")


def _prepend(tr: Track, time: float, state: Array, cov: Array, names: tuple[str, ...]
             ) -> Track:
    """The track with a first row for the start (NIS NaN, 0 degrees of freedom)."""
    return Track(tr.filter_name or "", names,
                 np.concatenate([[time], tr.times]),
                 np.concatenate([state[None], tr.states]),
                 np.concatenate([cov[None], tr.covariances]),
                 np.concatenate([[np.nan], tr.nis]),
                 np.concatenate([np.zeros(1, dtype=np.int64), tr.dof]),
                 np.concatenate([[0.0], tr.log_likelihood]), dict(tr.extra))


def track_dict(tr: Track) -> dict[str, object]:
    """The track as JSON-ready data: :meth:`Track.as_dict` with ``start`` and ``q``, NaN as
    ``None``."""
    data = tr.as_dict()
    data["start"] = tr.extra.get("start")
    data["q"] = tr.extra.get("q")

    def clean(v: object) -> object:
        if isinstance(v, float):
            return v if np.isfinite(v) else None
        if isinstance(v, list):
            return [clean(x) for x in v]
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        return v

    return clean(data)  # type: ignore[return-value]


def track_pcrb(meas: MeasurementSet, tr: Track, truth: ArrayLike | None = None, *,
               trajectories: int = 200, rng: np.random.Generator | int | None = 0
               ) -> tuple[Any | None, str]:
    """The posterior CRB (:mod:`tmakit.bounds.pcrb`, 004_590a452506c86051.txt eqs. 10-11)
    of a tracker that starts where ``tr`` (from :func:`track`) started, with the same prior
    covariance, q, options and nuisance values, over the same updates.

    With ``truth`` (true states (K, n) at the track's times, as from :func:`truth_states`)
    the measurement information is evaluated along the true trajectory
    (:func:`~tmakit.bounds.pcrb.deterministic_pcrb` from the true state at the start): the
    bound for this run's geometry, which with q = 0 equals the batch CRLB of the same data
    plus the start's information.  Without it, :func:`~tmakit.bounds.pcrb.posterior_crb`
    averages over ``trajectories`` drawn from the start prior (``rng``).  The average is
    dominated by the draws that pass closest to the sensors when the prior is wide (bearing
    information grows as 1/range^2), which is why the picture of a known-truth run uses the
    former.  Returns ``(bound, note)``: ``bound`` is ``None`` (and ``note`` says why) when it
    cannot be computed."""
    try:
        from .bounds.pcrb import deterministic_pcrb, posterior_crb
    except ImportError as e:  # pragma: no cover - the module ships with tmakit
        return None, f"PCRB not available ({e})"
    prior = tr.extra.get("prior")
    if prior is None:
        return None, "PCRB not available (the track does not say how it started)"
    t0, mean, cov, nuisance = prior
    start = tr.extra.get("start") or {}
    rows = meas.take(meas.time > t0 + 1e-9) if start.get("method") == "batch" else meas
    if len(rows) == 0:
        return None, "PCRB not available (no measurements after the start)"
    q = tr.extra.get("q", 0.0)
    options = tr.extra.get("options") or None
    try:
        if truth is not None:
            truth = np.asarray(truth, dtype=float)
            at_start = truth[int(np.argmin(np.abs(tr.times - t0)))]
            bound = deterministic_pcrb(rows, at_start, cov, t0, q=q, options=options,
                                       nuisance=nuisance)
        else:
            bound = posterior_crb(rows, mean, cov, t0, q=q, trajectories=trajectories,
                                  rng=rng, options=options, nuisance=nuisance)
    except (ValueError, TypeError) as e:
        return None, f"PCRB not available ({e})"
    return bound, ""


def truth_states(meas: MeasurementSet, times: ArrayLike, dim: int) -> Array | None:
    """True filter states ``(K, 2 dim)`` at ``times`` from the file's metadata (``motion``,
    ``truth``, ``ref_time``, as simulated files carry them), or ``None`` if unknown."""
    meta = meas.metadata
    if "motion" not in meta or "truth" not in meta:
        return None
    from .motion import motion_from_name

    try:
        motion = motion_from_name(meta["motion"], float(meta.get("ref_time", 0.0)))
        theta = motion.theta(json.loads(meta["truth"]))
        s6 = motion.states(theta, np.asarray(times, dtype=float))
    except (ValueError, KeyError, TypeError, json.JSONDecodeError):
        return None
    keep = [0, 1, 2, 3, 4, 5] if dim == 3 else [0, 1, 3, 4]
    return np.asarray(s6, dtype=float)[:, keep]


def write_track(tr: Track, path: str | os.PathLike[str], force: bool = False) -> Path:
    """Write the track table (:meth:`Track.table_columns`) as CSV or Parquet, by suffix.

    Refuses to overwrite an existing file (``FileExistsError``) unless ``force``; writes a
    temporary file in the same folder and moves it into place, so a failure leaves nothing
    half-written.  Parquet files carry the filter, start and q as schema metadata.
    """
    import pandas as pd

    from .io.measurement_files import _written_in_place

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise ValueError(f"{path}: a track is written as .csv or .parquet, not "
                         f"{path.suffix or 'a file without suffix'}")
    with _written_in_place(path, force) as tmp:
        frame = pd.DataFrame(tr.table_columns())
        if suffix == ".csv":
            frame.to_csv(tmp, index=False)
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            table = pa.Table.from_pandas(frame, preserve_index=False)
            meta = dict(table.schema.metadata or {})
            for key, value in (("filter", tr.filter_name),
                               ("start", json.dumps(track_dict(tr)["start"])),
                               ("q", json.dumps(tr.extra.get("q")))):
                meta[f"tmakit:{key}".encode()] = str(value).encode()
            pq.write_table(table.replace_schema_metadata(meta), tmp)
    return path
