"""Fisher information and the Cramér–Rao lower bound for any mix of measurement kinds,
sensors and motion models.

For Gaussian noise with covariance R the information about the unknowns ``u`` is
``F = J^T R^-1 J`` with ``J = d predictions / d u`` (000_bc54bd8c50e47249.txt eqs. 17-18
are the special cases for power and Doppler; 002_e7269ad11b825346.txt eq. 9 for azimuth and
azimuth rate).  The unknowns are the motion parameters and, unless they are declared known,
the nuisance parameters (carrier and drift, power constant, path-loss exponent).
**Default: nuisance parameters unknown** — the bound that matches an estimator that does not
know them.

Where the information is singular nothing is inverted blindly: the unobservable directions are
named (:mod:`tmakit.bounds.observability`) and every parameter or derived quantity that depends
on them has an infinite standard deviation.
"""

from __future__ import annotations

import json
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..results.bound import Bound, bound_from_information


def whitened_jacobian(obs: ObservationModel, noise: NoiseModel, theta: ArrayLike,
                      nuisance: ArrayLike, known_nuisance: bool) -> NDArray[np.float64]:
    """``R^{-1/2} J`` with respect to the unknowns (motion parameters, then nuisance)."""
    j_theta, j_nu = obs.jacobian(theta, nuisance)
    jac = j_theta if known_nuisance else np.concatenate([j_theta, j_nu], axis=-1)
    return noise.whiten(jac, axis=-2)


def fisher_information(obs: ObservationModel, theta: ArrayLike, nuisance: ArrayLike,
                       known_nuisance: bool = False, noise: NoiseModel | None = None
                       ) -> NDArray[np.float64]:
    """The Fisher information about the motion parameters (and the nuisance parameters
    unless known) at ``theta``, ``nuisance``."""
    noise = noise or NoiseModel(obs.meas)
    w = whitened_jacobian(obs, noise, theta, nuisance, known_nuisance)
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
    values.setdefault("power_constant_db", 0.0)  # the bound does not depend on it
    values.setdefault("carrier_drift", 0.0)
    values.setdefault("path_loss_exponent", 2.0)
    return values


def bound_source(source, motion: MotionModel | None,
                 truth: Mapping[str, float] | ArrayLike | None,
                 nuisance: Mapping[str, float] | None,
                 options: Mapping[str, Mapping[str, object]] | None, caller: str):
    """What a bound is evaluated on, ``(meas, motion, truth, nuisance, options)``, from its
    ``source``: a :class:`~tmakit.scenario.Scenario` (its noise-free simulation; its motion,
    truth and measurement options unless given; its nuisance values updated by ``nuisance``)
    or a :class:`~tmakit.data.MeasurementSet` (then ``motion`` and ``truth`` are required).
    ``caller`` names the function in the error for any other type."""
    from ..scenario import Scenario

    if isinstance(source, Scenario):
        meas = source.simulate(noise=False)
        motion = motion or source.motion
        truth = source.truth if truth is None else truth
        nuisance = {**source.nuisance, **dict(nuisance or {})}
        options = source.measurement_options if options is None else options
    elif isinstance(source, MeasurementSet):
        meas = source
        if motion is None or truth is None:
            raise ValueError("the bound of a measurement set needs the motion model and the "
                             "truth at which to evaluate it")
    else:
        raise TypeError(f"{caller} takes a Scenario or a MeasurementSet; "
                        f"got {type(source).__name__}")
    return meas, motion, truth, nuisance, options


def truth_vector(motion: MotionModel, truth: Mapping[str, float] | ArrayLike
                 ) -> NDArray[np.float64]:
    """``truth`` (a mapping by parameter name, or a vector) as the parameter vector of
    ``motion``; ``ValueError`` naming the expected parameters when its length is wrong."""
    theta = (motion.theta(truth) if isinstance(truth, Mapping)
             else np.asarray(truth, dtype=float))
    if theta.shape != (motion.n_params,):
        raise ValueError(f"truth must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)}); got shape {theta.shape}")
    return theta


def crlb(source, motion: MotionModel | None = None,
         truth: Mapping[str, float] | ArrayLike | None = None,
         nuisance: Mapping[str, float] | None = None, known_nuisance: bool = False,
         options: Mapping[str, Mapping[str, object]] | None = None) -> Bound:
    """The Cramér–Rao bound of a scenario (at its truth) or of a measurement set (at the
    given ``truth``; the measured values are not used, only times, sensors, kinds and sigmas).

    ``known_nuisance=False`` (default) treats carrier, drift, power constant and path-loss
    exponent as unknown; ``options`` selects them per kind (``{"frequency": {"drift": True}}``).
    """
    meas, motion, truth, nuisance, options = bound_source(source, motion, truth, nuisance,
                                                          options, "crlb()")
    theta = truth_vector(motion, truth)
    obs = ObservationModel(meas, motion, options)
    values = _nuisance_values(meas, nuisance)
    nu = obs.nuisance_vector(values)
    info = fisher_information(obs, theta, nu, known_nuisance)
    names = motion.param_names + (() if known_nuisance else obs.nuisance_names)
    vals = theta if known_nuisance else np.concatenate([theta, nu])
    used = {n: float(v) for n, v in zip(obs.nuisance_names, nu, strict=True)}
    return bound_from_information(info, names, vals, meas, motion, known_nuisance, used)
