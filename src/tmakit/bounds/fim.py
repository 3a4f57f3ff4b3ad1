"""Fisher information and the Cramér–Rao lower bound for any measurements and motion.

``F = J^T R^-1 J`` over the motion parameters and, unless known
(:class:`~tmakit.results.nuisance.KnownNuisance`), the nuisance parameters (Gu et al. (2007),
eqs. 17-18; Hörst & Oispuu (2010), eq. 9).  A singular information is never inverted blindly:
unobservable directions are named and their std are infinite.  With sensor position errors
(:func:`crlb_with_sensor_errors`, Ho, Lu & Kovavisaruch (2007)) the rows' noise is
``R + H_b Q_b H_b'`` (:func:`tmakit.observation.noise.effective_noise`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..motion.base import WITHIN_REACH
from ..observation import ObservationModel
from ..observation.noise import NoiseModel, effective_noise
from ..observation.planar import Linearisation
from ..results.bound import Bound, bound_from_information
from ..results.nuisance import KnownNuisanceLike, as_known_nuisance

if TYPE_CHECKING:  # pragma: no cover
    from ..scenario.model import Scenario


def fisher_information(obs: ObservationModel, theta: ArrayLike, nuisance: ArrayLike,
                       known_nuisance: KnownNuisanceLike = None) -> NDArray[np.float64]:
    """Return the Fisher information ``J^T R^-1 J`` about the motion (and unknown nuisance), SI."""
    return _grouped_information(obs, obs.linearisation(theta), nuisance, known_nuisance)


def _grouped_information(obs: ObservationModel, lin: Linearisation, nuisance: ArrayLike,
                         known_nuisance: KnownNuisanceLike, noise: NoiseModel | None = None
                         ) -> NDArray[np.float64]:
    """``J^T R^-1 J`` from a linearisation, rows in grouped order (F does not depend on it)."""
    w = lin.jacobian(np.asarray(nuisance, dtype=float))
    if lin.whitened:  # (the planar path: no nuisance)
        return w.T @ w
    if as_known_nuisance(known_nuisance) is None and obs.n_nuisance:
        w = np.concatenate([w, obs.const_design + lin.a_var], axis=-1)
    noise = NoiseModel.from_rows(obs.row_model) if noise is None else noise
    w = noise.whiten(w, axis=-2, overwrite=True)
    return w.T @ w


def _nuisance_values(meas: MeasurementSet, given: Mapping[str, float] | None
                     ) -> dict[str, float]:
    values: dict[str, float] = {}
    if "nuisance" in meas.metadata:
        values.update(json.loads(meas.metadata["nuisance"]))
    values.update(dict(given or {}))
    if "frequency" in meas.kinds and "carrier" not in values:
        # The bound depends on the carrier only through its scale; the median received
        # frequency gives it to ~1e-6, far below anything that matters here.
        values["carrier"] = float(np.median(meas.value_si[meas.kind == "frequency"]))
        for label in [] if meas.tonal is None else np.unique(meas.tonal[meas.tonal != ""]):
            values.setdefault(f"carrier[{label}]",
                              float(np.median(meas.value_si[meas.tonal == label])))
    values.setdefault("power_constant_db", 0.0)  # the bound does not depend on it
    values.setdefault("carrier_drift", 0.0)
    values.setdefault("path_loss_exponent", 2.0)
    return values


def bound_source(source: Scenario | MeasurementSet, motion: MotionModel | None,
                 truth: Mapping[str, float] | ArrayLike | None,
                 nuisance: Mapping[str, float] | None,
                 options: Mapping[str, Mapping[str, object]] | None, caller: str
                 ) -> tuple[MeasurementSet, MotionModel, Mapping[str, float] | ArrayLike,
                            Mapping[str, float] | None,
                            Mapping[str, Mapping[str, object]] | None]:
    """Return what a bound is evaluated on, from its ``source``."""
    if isinstance(source, MeasurementSet):
        if motion is None or truth is None:
            raise ValueError("the bound of a measurement set needs the motion model and the "
                             "truth at which to evaluate it")
        return source, motion, truth, nuisance, options
    from ..scenario.model import Scenario  # (a set's bound needs no scenario code)

    if not isinstance(source, Scenario):
        raise TypeError(f"{caller} takes a Scenario or a MeasurementSet; "
                        f"got {type(source).__name__}")
    meas = source.simulate(noise=False)
    motion = motion or source.motion
    truth = source.truth if truth is None else truth
    nuisance = {**source.nuisance, **dict(nuisance or {})}
    options = source.measurement_options if options is None else options
    return meas, motion, truth, nuisance, options


def truth_vector(motion: MotionModel, truth: Mapping[str, float] | ArrayLike
                 ) -> NDArray[np.float64]:
    """Convert ``truth`` to the parameter vector of ``motion``."""
    theta = (motion.theta(truth) if isinstance(truth, Mapping)
             else np.asarray(truth, dtype=float))
    if theta.shape != (motion.n_params,):
        raise ValueError(f"truth must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)}); got shape {theta.shape}")
    if far := motion.beyond_reach(theta):
        raise ValueError(f"truth {', '.join(far)}: {WITHIN_REACH}")
    return theta


def crlb(source: Scenario | MeasurementSet, motion: MotionModel | None = None,
         truth: Mapping[str, float] | ArrayLike | None = None,
         nuisance: Mapping[str, float] | None = None,
         known_nuisance: KnownNuisanceLike = None,
         options: Mapping[str, Mapping[str, object]] | None = None) -> Bound:
    """Return the Cramér–Rao bound of a scenario (at its truth) or of a measurement set.

    A set's measured values are not used, only times, sensors, kinds and sigmas.

    Parameters
    ----------
    source : Scenario or MeasurementSet
    motion : MotionModel, optional
        Default the scenario's; required for a set.
    truth : Mapping[str, float] or array_like, optional
        Where evaluated, SI; default the scenario's; required for a set.
    nuisance : Mapping[str, float], optional
        Nuisance values at the evaluation point.
    known_nuisance : KnownNuisance, Mapping, bool or None, optional
        Default: the nuisance parameters are unknowns.
    options : Mapping, optional
        The nuisance model per kind; default the scenario's.

    Returns
    -------
    Bound

    Raises
    ------
    TypeError
        When ``source`` is neither a scenario nor a measurement set.
    ValueError
        When a set comes without ``motion`` or ``truth``, ``truth`` has the wrong length, or
        it puts the target on a sensor.

    References
    ----------
    Gu et al. (2007), eqs. 17-18; Hörst & Oispuu (2010), eq. 9.
    """
    meas, motion, truth, nuisance, options = bound_source(source, motion, truth, nuisance,
                                                          options, "crlb()")
    known = as_known_nuisance(known_nuisance)
    theta = truth_vector(motion, truth)
    obs = ObservationModel(meas, motion, options)
    noise = NoiseModel.from_rows(obs.row_model)
    with np.errstate(divide="ignore", invalid="ignore"):  # on a sensor: refused just below
        # independent rows: the planar path makes the Jacobian whitened
        lin = obs.linearisation(theta, weights=None if noise.correlated else noise.inv_sigma)
    check_off_sensors(obs, theta, lin)
    if not obs.n_nuisance:  # (no values to gather)
        info = _grouped_information(obs, lin, np.zeros(0), known, noise)
        return bound_from_information(info, motion.param_names, theta.copy(), meas, motion,
                                      known, {})
    values = _nuisance_values(meas, nuisance)
    nu = obs.nuisance_vector(values if known is None else known.over(values))
    info = _grouped_information(obs, lin, nu, known, noise)
    names = motion.param_names + (() if known else obs.nuisance_names)
    vals = theta if known else np.concatenate([theta, nu])
    used = {n: float(v) for n, v in zip(obs.nuisance_names, nu, strict=True)}
    return bound_from_information(info, names, vals, meas, motion, known, used)


#: Closer than this (m) to a sensor at a measurement time, the target is "on the sensor".
ON_SENSOR_M = 1e-3


def check_off_sensors(obs: ObservationModel, theta: NDArray[np.float64],
                      lin: Linearisation) -> None:
    """Refuse a truth that puts the target on a sensor at one of the measurement times."""
    planar = lin.planar_squared  # the planar path's own squared distances
    if planar is None:
        rel = lin.relative
        assert rel is not None  # (made with derivatives)
        planar = rel[..., 0] * rel[..., 0]  # the linearisation's own relative positions
        planar += rel[..., 1] * rel[..., 1]
    if not planar.size or planar.min() >= ON_SENSOR_M**2:  # away from each in the plane alone
        return
    dist2 = obs.squared_ranges(theta)  # with the height, in grouped order
    j = int(np.argmin(dist2))
    k = int(obs.order[j])
    if not dist2[j] >= ON_SENSOR_M**2:  # also NaN
        meas = obs.meas
        raise ValueError(
            f"truth puts the target on sensor {str(meas.sensor[k])!r} at t = {meas.time[k]:g} s "
            f"(distance {np.sqrt(dist2[j]):.3g} m < {ON_SENSOR_M:g} m): the bound is undefined "
            "there (no bearing, no range derivative); choose a truth away from every sensor")


def crlb_with_sensor_errors(meas: MeasurementSet, motion: MotionModel,
                            truth: Mapping[str, float] | ArrayLike, position_sigma: float,
                            velocity_sigma: float = 0.0,
                            nuisance: Mapping[str, float] | None = None,
                            options: Mapping[str, Mapping[str, object]] | None = None
                            ) -> tuple[Bound, Bound]:
    """Give the CRLB with sensor position errors (Ho, Lu & Kovavisaruch (2007)), and without."""
    known = crlb(meas, motion, truth, nuisance, None, options)
    theta = truth_vector(motion, truth)
    obs = ObservationModel(meas, motion, options)
    nu = np.asarray(known.values[motion.n_params:], dtype=float)
    noise = effective_noise(obs, theta, nu, position_sigma, velocity_sigma)  # grouped order
    w = noise.whiten(np.concatenate(obs.jacobian_grouped(theta, nu), axis=-1), axis=-2)
    info = w.T @ w
    names = motion.param_names + obs.nuisance_names
    with_errors = bound_from_information(info, names, np.asarray(known.values, dtype=float),
                                         meas, motion, None, known.nuisance_values)
    return with_errors, known
