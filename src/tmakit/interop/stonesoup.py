"""Stone Soup interoperability: detections, measurement models and a no-guess initiator.

Install with ``pip install "tmakit[stonesoup]"`` (Stone Soup ≥ 1.0).

* :func:`to_detections` turns a :class:`~tmakit.data.MeasurementSet` into Stone Soup
  ``Detection`` objects, one per measurement time (or per time and sensor), each carrying a
  :class:`TmakitMeasurementModel`; :func:`detection_feed` groups them by time for a Stone Soup
  tracker's ``detector``.
* :class:`TmakitMeasurementModel` is any mix of tmakit's measurement kinds (bearing,
  elevation, azimuth rate, range, range rate, frequency and power with known nuisance values,
  range differences) as a Stone Soup non-linear Gaussian measurement model: predictions,
  **analytic** Jacobians and the noise covariance come from tmakit's observation layer
  (:class:`~tmakit.observation.MeasurementGroup`), not from finite differences;
  :meth:`TmakitMeasurementModel.for_kinds` builds one from a sensor state for Stone Soup's
  own simulators and updaters.
* :func:`from_detections` turns Stone Soup detections back into a measurement set: those made
  with :class:`TmakitMeasurementModel`, and those of Stone Soup's own bearing, elevation and
  range models (:data:`NATIVE_MODELS`).
* :class:`BatchInitiator` is tmakit's no-guess batch maximum-likelihood estimate as a Stone
  Soup initiator: it collects detections until the estimate over them is a good start (the
  rule of :func:`tmakit.tracking.window.search_window`), then starts a track there.

Conventions.  Stone Soup's Cartesian state is ``[x, vx, y, vy(, z, vz)]`` (``mapping`` gives
the position indices, ``velocity_mapping`` the velocity ones), tmakit's ``[x, y(, z), vx,
vy(, vz)]``; both East-North-Up, metres and m/s.  tmakit's bearing is clockwise from North
(``atan2(east, north)``); Stone Soup's own models measure it counter-clockwise from the x axis
(East), ``phi = pi/2 - bearing``.  Angle rows are Stone Soup ``Bearing`` values, so
innovations wrap to (-pi, pi].  Time ``t`` seconds of a measurement set is the timestamp
``epoch + t`` (default :data:`EPOCH`).
"""

from __future__ import annotations

import importlib.util

if importlib.util.find_spec("stonesoup") is None:  # pragma: no cover - the extra is missing
    raise ModuleNotFoundError("tmakit.interop.stonesoup needs Stone Soup: "
                              "pip install \"tmakit[stonesoup]\" (or stonesoup>=1.0)",
                              name="stonesoup")

from .stonesoup_detections import NATIVE_MODELS, detection_feed, from_detections, to_detections
from .stonesoup_initiator import BatchInitiator
from .stonesoup_models import EPOCH, TmakitMeasurementModel, cartesian_mapping

__all__ = ["EPOCH", "NATIVE_MODELS", "BatchInitiator", "TmakitMeasurementModel",
           "cartesian_mapping", "detection_feed", "from_detections", "to_detections"]
