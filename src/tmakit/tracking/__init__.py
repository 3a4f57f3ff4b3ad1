"""Tracking a measurement set with a recursive filter: the start policy, the run, the outputs.

>>> import tmakit as tk
>>> tr = tk.track(meas, "ekf")                        # no initial guess: a batch start
>>> tr = tk.track(meas, "ukf", initiator=BatchInitiator(max_relative_std=0.2))
>>> tr = tk.track(meas, initiator=PriorInitiator({"x": 4e3, ...}, {"x": 3e3, ...}))

One job per module:

* :mod:`.initiators` — the start policy as objects: :class:`BatchInitiator` (a batch
  estimate over the shortest good initial window, :mod:`.window`, confirmed by the
  innovations) and :class:`PriorInitiator`; each returns a typed record (:mod:`.records`).
* :mod:`.filter_setup` — the filter's class, dimension, process noise and settings, from
  typed values.
* :mod:`.tracker` — :func:`track`, the short form.
* :mod:`.output` — the JSON form and the table of a track (written by
  :func:`tmakit.io.track_files.write_track`).
* :mod:`.pcrb` — the posterior CRB of a track's start and updates.
* :mod:`.errors` — :class:`TrackingError`, naming library parameters (never CLI flags).

The true states of a simulated set are :func:`tmakit.scenario.truth_states`
(re-exported here).
"""

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
    BatchInitiator,
    BearingInitiator,
    Initiation,
    Initiator,
    PriorInitiator,
)
from .output import TrackTable, track_dict, track_table
from .pcrb import track_pcrb
from .records import BatchStart, BearingStart, Confirmation, PriorStart, Rejection, StartRecord
from .tracker import start_record, track
from .window import MIN_WINDOW, WindowChoice, WindowEstimate, search_window

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
