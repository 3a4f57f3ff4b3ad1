"""Tracking a measurement set with a recursive filter: the start policy, the run, the outputs."""

from __future__ import annotations

from ..scenario.truth import truth_states
from .errors import MissingNuisanceError, StartError, TrackingError
from .filter_setup import (
    FilterSetup,
    filter_class,
    filter_dim,
    noise_density,
    process_noise,
    random_filters,
)
from .initiators import (
    CONFIRM_P_VALUE,
    DEFAULT_MAX_RELATIVE_STD,
    MIN_WINDOW,
    BatchInitiator,
    BatchStart,
    BearingInitiator,
    BearingStart,
    Confirmation,
    Initiation,
    Initiator,
    PriorInitiator,
    PriorStart,
    Rejection,
    StartRecord,
    Widening,
    WindowChoice,
    WindowEstimate,
    search_window,
)
from .output import TrackTable, track_dict, track_pcrb, track_table
from .tracker import start_record, track

__all__ = [
    "CONFIRM_P_VALUE",
    "DEFAULT_MAX_RELATIVE_STD",
    "MIN_WINDOW",
    "BatchInitiator",
    "BatchStart",
    "BearingInitiator",
    "BearingStart",
    "Confirmation",
    "FilterSetup",
    "Initiation",
    "Initiator",
    "MissingNuisanceError",
    "PriorInitiator",
    "PriorStart",
    "Rejection",
    "StartError",
    "StartRecord",
    "TrackTable",
    "TrackingError",
    "Widening",
    "WindowChoice",
    "WindowEstimate",
    "filter_class",
    "filter_dim",
    "noise_density",
    "process_noise",
    "random_filters",
    "search_window",
    "start_record",
    "track",
    "track_dict",
    "track_pcrb",
    "track_table",
    "truth_states",
]
