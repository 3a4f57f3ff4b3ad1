"""The emitter's height, chosen by the data: a 2-D fit against its 3-D counterpart.

The 3-D fit is kept when the sensors fly or the likelihood-ratio test (Wilks 1938) rejects the
2-D model; docs/estimation.md explains why.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core import chi2 as chi2_dist
from ..data import MeasurementSet
from ..measurements import KINDS
from ..motion import MotionModel, motion_from_name
from ..results.estimate import EstimateResult
from ..results.status import CONVERGED
from .estimator import Options
from .methods import estimate

HEIGHT_LEVEL = 0.001
"""The 3-D fit is kept when the likelihood-ratio test's p-value is below this."""

AIRBORNE_ALTITUDE = 25.0
"""Sensors whose plane lies more than this (m) above mean sea level fly."""

GEOID_REACH = 85.0
"""The geoid's greatest height above the WGS-84 ellipsoid (m)."""

SOUND_LIMIT = 1.0e4
"""Frequencies carried slower than this (m/s) travel as sound, in the sensors' medium."""

RAISED = {"static2d": "static3d", "cv2d": "cv3d"}
"""The 3-D counterpart of each 2-D motion model."""

_START_FRACTIONS = (0.25, 0.5, 1.0)


@dataclass
class HeightChoice:
    """The outcome of :func:`choose_height`.

    Parameters
    ----------
    result, flat, raised : EstimateResult
        The fit chosen, the 2-D fit, the best 3-D fit (None when the test does not apply).
    delta_chi2, p_value : float or None
        ``chi2_2D - chi2_3D`` and the likelihood-ratio test's p-value.
    dim : int
        2 or 3: the dimension of ``result``.
    note : str
        What was tested and chosen, with the numbers (empty when the test does not apply).
    """

    result: EstimateResult
    flat: EstimateResult
    raised: EstimateResult | None
    delta_chi2: float | None
    p_value: float | None
    dim: int
    note: str

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``dim``, ``chi2_2d``, ``chi2_3d``, ``delta_chi2``, ``p_value``, ``note``.
        """
        def num(x: float | None) -> float | None:
            return float(x) if x is not None and np.isfinite(x) else None

        return {"dim": self.dim, "chi2_2d": num(self.flat.chi2),
                "chi2_3d": num(self.raised.chi2) if self.raised is not None else None,
                "delta_chi2": num(self.delta_chi2), "p_value": num(self.p_value),
                "note": self.note}


def height_matters(meas: MeasurementSet, result: EstimateResult) -> bool:
    """Tell whether a 2-D fit could be wrong for want of the emitter's height."""
    return (result.motion.name in RAISED and bool(np.all(np.isfinite(result.estimate)))
            and not all(KINDS[k].height_blind for k in meas.kinds) and meas.dim == 2)


def choose_height(meas: MeasurementSet, flat: EstimateResult, options: Options = None, *,
                  level: float = HEIGHT_LEVEL, force: bool = False) -> HeightChoice:
    """Fit the 3-D counterpart of a 2-D fit and keep it when the data need the height.

    Parameters
    ----------
    meas : MeasurementSet
    flat : EstimateResult
        The 2-D maximum-likelihood fit of ``meas`` (``static2d`` or ``cv2d``).
    options : Mapping, optional
        The measurement-model options of the fit.
    level : float, optional
        The likelihood-ratio test's level (default :data:`HEIGHT_LEVEL`).
    force : bool, optional
        Keep the 3-D fit whatever the test says (``tma estimate --dim 3``).

    Returns
    -------
    HeightChoice
    """
    if not height_matters(meas, flat):
        return HeightChoice(flat, flat, None, None, None, 2, "")
    sound = _sound_speed(meas, options)
    if sound is not None and not force:
        return HeightChoice(flat, flat, None, None, None, 2, (
            f"height: the frequencies travel at {sound:g} m/s, as sound: the emitter is in the "
            "sensors' medium, whose depth is small beside the ranges; the 2-D fit is kept "
            "(--dim 3 fits in 3-D)"))
    raised = _best_raised(meas, flat, options)
    if raised is None:
        return HeightChoice(flat, flat, None, None, None, 2,
                            "height: no 3-D fit converged; the 2-D fit is kept")
    added = raised.motion.n_params - flat.motion.n_params
    delta = float(flat.chi2 - raised.chi2)
    p = float(chi2_dist.sf(max(delta, 0.0), added))
    test = (f"chi2 {flat.chi2:.1f} in 2-D, {raised.chi2:.1f} in 3-D: a drop of {delta:.1f} "
            f"for {added} more parameter{'s' if added > 1 else ''}, p = {p:.2g}")
    flying = airborne(meas)
    if p >= level and not force and not flying:
        return HeightChoice(flat, flat, raised, delta, p, 2,
                            f"height: a 3-D fit does not explain the data better ({test} >= "
                            f"{level:g}); the 2-D fit is kept (--dim 3 fits in 3-D)")
    z, sz = float(raised.estimate[2]), float(raised.std[2])
    side = "below" if z < 0 else "above"
    why = (f"the data need the height ({test} < {level:g})" if p < level else
           "the 3-D fit is asked for (--dim 3)" if force else
           f"the sensors fly, above any emitter on the ground ({test})")
    note = (f"height: the emitter is {abs(z):.0f} ± {sz:.2g} m {side} the sensors' plane: "
            f"{why}, so the answer is the 3-D fit; the sensors fly in one plane, so above "
            f"and below it fit alike and {side} is assumed ({_side_reason(meas)}); "
            "--dim 2 keeps the 2-D fit")
    message = f"{raised.message}; {note}" if raised.message else note
    return HeightChoice(dataclasses.replace(raised, message=message), flat, raised, delta, p,
                        3, note)


def airborne(meas: MeasurementSet) -> bool:
    """Tell whether a set's sensors fly: their plane is well above mean sea level."""
    if "origin_alt" not in meas.metadata:
        return False
    margin = 0.0 if meas.metadata.get("altitude_reference") == "msl" else GEOID_REACH
    return float(meas.metadata["origin_alt"]) > AIRBORNE_ALTITUDE + margin


def _sound_speed(meas: MeasurementSet, options: Options) -> float | None:
    """Give the frequencies' propagation speed (m/s) when it is sound's, else None."""
    if "frequency" not in meas.kinds:
        return None
    speed = dict((options or {}).get("frequency", {})).get("propagation_speed")
    if speed is None:
        speed = KINDS["frequency"].options_from_metadata(meas.metadata).get("propagation_speed")
    return None if speed is None or not float(speed) < SOUND_LIMIT else float(speed)  # type: ignore[arg-type]


def _side_reason(meas: MeasurementSet) -> str:
    alt = float(meas.metadata.get("origin_alt", 0.0))
    ref = meas.metadata.get("altitude_reference", "ellipsoid")
    where = "mean sea level" if ref == "msl" else "the WGS-84 ellipsoid"
    return (f"the sensors' plane is {alt:.0f} m above {where}, "
            + ("airborne: the emitter on the ground below" if airborne(meas)
               else "at the surface: the emitter above it"))


def _best_raised(meas: MeasurementSet, flat: EstimateResult, options: Options
                 ) -> EstimateResult | None:
    """Give the best converged 3-D fit started from the 2-D one at several heights, or None."""
    motion = flat.motion
    ref = getattr(motion, "ref_time", None)
    raised = motion_from_name(RAISED[motion.name],
                              *(() if ref is None or not np.isfinite(ref) else (ref,)))
    states = motion.states(flat.estimate, meas.time)
    reach = float(np.median(np.hypot(*(states[:, :2] - meas.sensor_state[:, :2]).T)))
    sign = -1.0 if airborne(meas) else 1.0
    named = dict(zip(motion.param_names, flat.estimate, strict=True))
    best = None
    for f in _START_FRACTIONS:
        start = {n: named.get(n, 0.0) for n in raised.param_names}
        start["z"] = sign * max(f * reach, 1.0)
        fit = _fit(meas, raised, start, options)
        if fit is not None and (best is None or fit.chi2 < best.chi2):
            best = fit
    if best is not None and best.estimate[2] * sign < 0:  # the mirror, on the side assumed
        mirror = dict(zip(raised.param_names, best.estimate, strict=True))
        mirror["z"] = -mirror["z"]
        if "vz" in mirror:
            mirror["vz"] = -mirror["vz"]
        best = _fit(meas, raised, mirror, options) or best
    return best


def _fit(meas: MeasurementSet, motion: MotionModel, start: dict[str, float],
         options: Options) -> EstimateResult | None:
    """Fit from one start; None unless converged."""
    try:
        fit = estimate(meas, motion, init=start, options=options)
    except ValueError:
        return None
    return fit if fit.status == CONVERGED and np.isfinite(fit.chi2) else None
