"""The posterior CRB's final position RMS of a scenario, by name or object (``docs/bounds.md``)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..bounds import deterministic_pcrb, posterior_crb
from ..scenario.files import load_scenario
from ..scenario.model import Scenario


def final_position_rms(source: str | Scenario = "bearings-only-2d",
                       prior_mean: ArrayLike | None = None,
                       prior_cov: ArrayLike | None = None, time0: float | None = None, *,
                       q: float | ArrayLike = 0.0, trajectories: int | None = 200,
                       rng: np.random.Generator | int | None = None) -> float:
    """Return the posterior CRB's RMS position error (m) after the last update."""
    if prior_cov is None:
        raise ValueError("prior_cov is required (n x n, SI)")
    scenario = load_scenario(source) if isinstance(source, str) else source
    if trajectories is None:
        bound = deterministic_pcrb(scenario, prior_mean, prior_cov, time0, q=q)
    else:
        bound = posterior_crb(scenario, prior_mean, prior_cov, time0, q=q,
                              trajectories=trajectories, rng=rng)
    return float(bound.position_rms[-1])
