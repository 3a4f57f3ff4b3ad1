"""Stone Soup interoperability: detections, measurement models and two initiators.

Install with ``pip install "tmakit[stonesoup]"`` (Stone Soup ≥ 1.0).
"""

from __future__ import annotations

import importlib.util

if importlib.util.find_spec("stonesoup") is None:  # pragma: no cover - the extra is missing
    raise ModuleNotFoundError("tmakit.interop.stonesoup needs Stone Soup: "
                              "pip install \"tmakit[stonesoup]\" (or stonesoup>=1.0)",
                              name="stonesoup")

from .stonesoup_detections import NATIVE_MODELS, detection_feed, from_detections, to_detections
from .stonesoup_initiator import BatchInitiator, BearingInitiator
from .stonesoup_models import EPOCH, TmakitMeasurementModel, cartesian_mapping

__all__ = ["EPOCH", "NATIVE_MODELS", "BatchInitiator", "BearingInitiator",
           "TmakitMeasurementModel", "cartesian_mapping", "detection_feed", "from_detections",
           "to_detections"]
