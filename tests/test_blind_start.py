"""Blind start: random observable geometries reach the global optimum with no initial guess,
and ``benchmarks/geometries.py`` draws what it says it draws.

The full study (1000 geometries, success rate with its confidence interval) is
``benchmarks/blind_start.py``; this is its fast, seeded subset.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from geometries import (
    BEARING_SIGMA_DEG,
    FREQUENCY_SIGMA_HZ,
    SNR_DB,
    STUDY_KINDS,
    observable_geometry,
    position_std,
    random_geometry,
)

from tmakit.batch import estimate
from tmakit.bounds import crlb

RELATIVE_TOLERANCE = 1e-6
"""Numerical floor of the cost: GHz-carrier frequencies in doubles reproduce it to ~1e-8."""

SEED = 0
N_GEOMETRIES = 40


def _geometry(index: int):
    """Geometry ``index`` exactly as ``benchmarks/blind_start.py`` draws it."""
    rng = np.random.default_rng([SEED, index])
    scn = observable_geometry(rng)
    return scn, scn.simulate(rng)


@pytest.mark.parametrize("index", range(N_GEOMETRIES))
def test_blind_start_reaches_the_global_optimum(index):
    scn, meas = _geometry(index)
    opts = scn.measurement_options
    blind = estimate(meas, scn.motion, options=opts)
    truth = estimate(meas, scn.motion, init=scn.truth, options=opts)
    assert blind.chi2 <= truth.chi2 * (1.0 + RELATIVE_TOLERANCE), (
        f"geometry {index} ({'+'.join(scn.kinds)}): blind chi2 {blind.chi2:.6f} > "
        f"truth-started {truth.chi2:.6f}\n{scn.summary()}")


def _same(a, b) -> None:
    assert a.truth == b.truth
    assert a.nuisance == b.nuisance
    assert a.kinds == b.kinds
    ta, tb = a.sensors["sensor"], b.sensors["sensor"]
    assert (ta.heading, ta.speed, ta.legs) == (tb.heading, tb.speed, tb.legs)
    for pa, pb in zip(a.plans, b.plans, strict=True):
        assert (pa.kind, pa.sigma, pa.snr_db) == (pb.kind, pb.sigma, pb.snr_db)
        np.testing.assert_array_equal(pa.times, pb.times)


def test_random_geometry_is_reproducible():
    for seed in range(5):
        _same(random_geometry(np.random.default_rng(seed)),
              random_geometry(np.random.default_rng(seed)))
    a = random_geometry(np.random.default_rng(1))
    b = random_geometry(np.random.default_rng(2))
    assert a.truth != b.truth
    scn_a, meas_a = _geometry(3)
    scn_b, meas_b = _geometry(3)
    _same(scn_a, scn_b)
    np.testing.assert_array_equal(meas_a.value, meas_b.value)


def _heading_spread_deg(scn) -> float:
    t = np.arange(*scn.time_span(), 0.5)
    v = scn.sensors["sensor"].states(t)[:, 3:5]
    heading = np.unwrap(np.arctan2(v[:, 0], v[:, 1]))
    return float(np.degrees(heading.max() - heading.min()))


def test_random_geometry_respects_its_ranges():
    rng = np.random.default_rng(12345)
    mixes = Counter()
    for _ in range(300):
        scn = random_geometry(rng)
        mixes[tuple(scn.kinds)] += 1
        distance = np.hypot(scn.truth["x"], scn.truth["y"])
        assert 500.0 <= distance <= 20_000.0
        assert np.hypot(scn.truth["vx"], scn.truth["vy"]) <= 40.0
        assert scn.motion.ref_time == 0.0 and scn.motion.param_names == ("x", "y", "vx", "vy")
        track = scn.sensors["sensor"]
        np.testing.assert_allclose(track.states([0.0])[0, :2], 0.0)
        assert 30.0 <= track.speed <= 80.0
        assert 3 <= len(track.legs) <= 5
        durations = np.array([leg.duration for leg in track.legs])
        assert np.all((durations >= 20.0 - 1e-9) & (durations <= 60.0 + 1e-9))
        rates = np.degrees(np.abs([leg.turn_rate for leg in track.legs]))
        assert np.all((rates == 0.0) | ((rates >= 1.0) & (rates <= 4.0)))
        turning = rates > 0
        assert np.all(turning[1:] != turning[:-1]), "legs must alternate straight and turn"
        assert _heading_spread_deg(scn) > 20.0
        t0, t1 = scn.time_span()
        assert t0 == 0.0 and 118.0 <= t1 <= 300.0
        assert 120.0 - 1e-9 <= durations.sum() <= 300.0 + 1e-9
        steps = {float(np.diff(p.times)[0]) for p in scn.plans}
        assert len(steps) == 1 and steps <= {1.0, 2.0}
        assert scn.kinds and set(scn.kinds) <= set(STUDY_KINDS)
        carrier = scn.nuisance["carrier"]
        assert 0.5e9 <= carrier <= 10e9
        for plan in scn.plans:
            if plan.kind == "bearing":
                assert BEARING_SIGMA_DEG[0] <= np.degrees(plan.sigma) <= BEARING_SIGMA_DEG[1]
            elif plan.kind == "frequency":
                assert FREQUENCY_SIGMA_HZ[0] <= plan.sigma <= FREQUENCY_SIGMA_HZ[1]
            else:
                assert plan.sigma is None and SNR_DB[0] <= plan.snr_db <= SNR_DB[1]
                assert scn.measurement_options["power"]["exponent"] == 2.0
    assert len(mixes) == 7, f"every non-empty mix of kinds should appear: {mixes}"


def test_kinds_can_be_fixed():
    rng = np.random.default_rng(7)
    for kinds in (["power"], ["bearing", "frequency"]):
        assert random_geometry(rng, kinds).kinds == kinds
    with pytest.raises(ValueError):
        random_geometry(rng, ["range"])
    with pytest.raises(ValueError):
        random_geometry(rng, [])


def test_observable_geometry_means_full_rank_and_a_bounded_position_std():
    rng = np.random.default_rng(99)
    for _ in range(5):
        scn = observable_geometry(rng, max_position_std=1500.0)
        bound = crlb(scn)
        assert bound.observability.full_rank
        t_mid = 0.5 * sum(scn.time_span())
        _, cov = bound.state_covariance(t_mid)
        assert np.sqrt(cov[0, 0] + cov[1, 1]) == pytest.approx(position_std(scn))
        assert position_std(scn) < 1500.0
    with pytest.raises(RuntimeError, match="no observable geometry"):
        observable_geometry(np.random.default_rng(0), max_position_std=1e-6, max_tries=3)
