"""Every batch estimator by name, and one function to call them: :func:`estimate_with`.

* ``ml`` — tmakit's maximum likelihood (:func:`tmakit.batch.ml.estimate`): nuisance parameters
  eliminated exactly, no initial guess needed.
* ``gu-direct`` — 000_bc54bd8c50e47249.txt §3, iterative LS with C/C_0 and c/f_s in the
  parameter vector (:func:`tmakit.batch.gu_direct.gu_direct`).
* ``ratio-power``, ``ratio-doppler``, ``ratio`` — 000 §4, ratios of neighbouring power and/or
  Doppler measurements (:func:`tmakit.batch.ratios.ratio_method`).
* ``lecture-gn`` — 001_ba171c940b7f4701.txt, Gauss–Newton on [X_N Y_N Z_N Vx Vy Vz f_o]
  (:func:`tmakit.batch.lecture.lecture_gauss_newton`).

The papers' methods are local iterations and need a starting point.  When none is given,
:func:`estimate_with` gives them tmakit's own no-guess start: the best point of the likelihood
grid of :func:`tmakit.batch.init.best_starts` (the same grid ``ml`` starts from).  That start is
tmakit's, not the papers'; the result says so in its message and in ``extra["start"]``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..data import MeasurementSet
from ..motion import MotionModel
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..results.estimate import EstimateResult
from .gu_direct import gu_direct
from .init import best_starts
from .lecture import lecture_gauss_newton
from .ml import estimate
from .ratios import ratio_method
from .solver import VarProProblem


def ratio_power(meas: MeasurementSet, motion: MotionModel,
                init: Mapping[str, float] | ArrayLike | None, **kw: Any) -> EstimateResult:
    """The ratio method on power ratios only (000_bc54bd8c50e47249.txt eqs. 19-25)."""
    return ratio_method(meas, motion, init, kinds=("power",), **kw)


def ratio_doppler(meas: MeasurementSet, motion: MotionModel,
                  init: Mapping[str, float] | ArrayLike | None, **kw: Any) -> EstimateResult:
    """The ratio method on Doppler ratios only (000_bc54bd8c50e47249.txt eqs. 26-32)."""
    return ratio_method(meas, motion, init, kinds=("frequency",), **kw)


def ratio_both(meas: MeasurementSet, motion: MotionModel,
               init: Mapping[str, float] | ArrayLike | None, **kw: Any) -> EstimateResult:
    """The ratio method on power and Doppler ratios (000_bc54bd8c50e47249.txt eqs. 33-34)."""
    return ratio_method(meas, motion, init, kinds=("power", "frequency"), **kw)


METHODS: dict[str, Callable[..., EstimateResult]] = {
    "ml": estimate,
    "gu-direct": gu_direct,
    "ratio-power": ratio_power,
    "ratio-doppler": ratio_doppler,
    "ratio": ratio_both,
    "lecture-gn": lecture_gauss_newton,
}
"""Batch estimators by name; all return :class:`tmakit.batch.ml.EstimateResult`."""

_KINDS_USED = {"ratio-power": ("power",), "ratio-doppler": ("frequency",),
               "ratio": ("power", "frequency"), "gu-direct": ("power", "frequency"),
               "lecture-gn": ("frequency",)}


def _check_options(method: str, options: Mapping[str, Mapping[str, object]] | None) -> None:
    """The papers' models: known path-loss exponent 2, no carrier drift."""
    opts = dict(options or {})
    if opts.get("frequency", {}).get("drift", False):
        raise ValueError(f"{method}: the paper's model has no carrier drift; use method 'ml' "
                         "for drift")
    exponent = opts.get("power", {}).get("exponent", 2.0)
    if exponent is None or float(exponent) != 2.0:  # type: ignore[arg-type]
        raise ValueError(f"{method}: the paper's model has the path-loss exponent 2; use "
                         "method 'ml' for another or an unknown exponent")


def grid_start(meas: MeasurementSet, motion: MotionModel,
               options: Mapping[str, Mapping[str, object]] | None = None) -> np.ndarray:
    """tmakit's no-guess starting point: the best point of the likelihood grid."""
    obs = ObservationModel(meas, motion, options)
    problem = VarProProblem(obs, NoiseModel(meas))
    starts = best_starts(problem, obs.values)
    if starts.shape[0] == 0:
        raise ValueError("no starting point gives finite predictions; check the data")
    return starts[0]


def estimate_with(method: str, meas: MeasurementSet, motion: MotionModel,
                  init: Mapping[str, float] | ArrayLike | None = None,
                  options: Mapping[str, Mapping[str, object]] | None = None,
                  **kw: Any) -> EstimateResult:
    """Run the batch estimator ``method`` (a key of :data:`METHODS`).

    ``init`` is the starting point (by name or as a vector); ``None`` gives ``ml`` its own grid
    search and the papers' local methods the best grid point (tmakit's start, not the papers').
    ``options`` selects nuisance models for ``ml``; the papers' methods accept only their own
    model (no drift, path-loss exponent 2).  Other keywords go to the method.
    """
    if method not in METHODS:
        raise ValueError(f"unknown estimation method {method!r}; expected one of "
                         f"{', '.join(METHODS)}")
    if method == "ml":
        return estimate(meas, motion, init=init, options=options, **kw)
    _check_options(method, options)
    start_note = ""
    if init is None:
        kinds = [k for k in _KINDS_USED[method] if k in meas.kinds]
        if "kinds" in kw and kw["kinds"] is not None:
            wanted = (kw["kinds"],) if isinstance(kw["kinds"], str) else tuple(kw["kinds"])
            kinds = [k for k in kinds if k in wanted]
        rows = meas.take(np.isin(meas.kind, kinds)) if kinds else meas
        init = grid_start(rows, motion)
        start_note = "started from tmakit's likelihood-grid point (the papers' methods are local)"
    result = METHODS[method](meas, motion, init, **kw)
    if start_note:
        result.extra["start"] = "grid"
        result.extra["start_point"] = [float(v) for v in np.asarray(init, dtype=float)]
        result.message = f"{start_note}; {result.message}" if result.message else start_note
    return result
