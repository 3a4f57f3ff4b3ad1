"""The answers of a manoeuvre fit that holds accelerations and cannot see every parameter.

A manoeuvre fit's bound covers the parameters it fitted (7 of curvilinear:2's 12 when five
accelerations are held at zero); the answer at a time maps the bound's unseen directions
through the bound's own motion model, not the full one (a shape error, exit 3 in ``tma
estimate``, before).
"""

from __future__ import annotations

import dataclasses

import numpy as np

import tmakit as tk
from tmakit.results.answers import estimate_answer


def test_an_unseen_direction_of_a_fit_with_held_accelerations_reaches_the_answer():
    scn = tk.load_scenario("hoerst2010")
    meas = scn.simulate(rng=3)
    meas = meas.take(np.arange(0, len(meas), 6))  # (300 rows: enough to hold five)
    res = tk.estimate(meas, "curvilinear:2")
    bound = res.bound
    assert bound.motion.n_params < res.motion.n_params  # accelerations held
    clear = estimate_answer(res, meas)
    assert clear.enu[0] is not None and clear.enu[1] is not None
    # The same fit, its bound blind along the east position at the reference time.
    unseen = np.zeros((len(bound.parameters), 1))
    unseen[list(bound.parameters).index("x"), 0] = 1.0
    blind = dataclasses.replace(bound, observability=dataclasses.replace(
        bound.observability, rank=len(bound.parameters) - 1, null_basis=unseen))
    answer = estimate_answer(dataclasses.replace(res, bound=blind), meas)
    assert answer.enu[0] is None and answer.enu[1] is not None  # east unseen, north seen
    assert answer.speed == clear.speed
