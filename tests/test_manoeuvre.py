"""Manoeuvring targets (Hörst & Oispuu (2010)): analytic derivatives of exact and piecewise
curvilinear motion, the Cramér–Rao bound at a sequence of reference times, and the
reproduction of Fig. 2."""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.bounds import crlb, curvilinear_crb_sequence
from tmakit.motion import FixedParameters, PiecewiseCurvilinear, propagate_curvilinear
from tmakit.motion.curvilinear import propagate_curvilinear_derivatives

T1, T2 = 400.0, 600.0
SCENARIO = {"x": -9000.0, "y": 12000.0, "speed": 50.0, "course": np.pi / 2,
            "at_0": 0.0, "an_0": 0.0, "at_1": 0.0, "an_1": 0.5, "at_2": 0.0, "an_2": 0.0,
            "t_1": T1, "t_2": T2}
# the scenario with every acceleration non-zero, so that no derivative vanishes by symmetry
BUSY = {**SCENARIO, "at_0": 0.02, "an_0": -0.01, "at_1": -0.03, "at_2": 0.05, "an_2": 0.1}


def fourth_order(f, x0: float, h: float) -> np.ndarray:
    """(8 (f(x+h) - f(x-h)) - (f(x+2h) - f(x-2h))) / 12h: error O(h^4)."""
    return (8 * (f(x0 + h) - f(x0 - h)) - (f(x0 + 2 * h) - f(x0 - 2 * h))) / (12 * h)


def assert_columns_close(analytic, numeric, names, rtol):
    """Each column within ``rtol`` of its largest analytic entry."""
    for j, name in enumerate(names):
        a, n = analytic[..., j], numeric[..., j]
        scale = max(np.max(np.abs(a)), 1e-300)
        err = np.max(np.abs(a - n)) / scale
        assert err <= rtol, f"d / d {name}: relative error {err:.2e} > {rtol:.0e}"


# --------------------------------------------------------------------------------------------
# one segment: d (x, y, speed, course) / d (x0, y0, v0, phi0, a_t, a_n, dt)
# --------------------------------------------------------------------------------------------

SEGMENTS = {
    # name: (x, y, speed, course, a_t, a_n, dt)
    "turn": (-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, 0.5, 200.0),
    "accelerating_turn": (500.0, 700.0, 40.0, 1.0, 0.3, 0.2, 300.0),
    "decelerating_backward": (-4e4, 3e4, 50.0, 2.0, -0.1, -0.3, -400.0),
    "straight_acceleration": (100.0, 200.0, 10.0, 0.7, 0.5, 0.0, 100.0),
    "tiny_tangential": (0.0, 0.0, 50.0, 1.0, 1e-7, 0.5, 200.0),
    "log_series_edge": (0.0, 0.0, 50.0, 1.0, 0.0025, 0.5, 200.0),  # a_t dt / v0 = 0.01
    "series_side": (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 0.9 * 0.05 * 50.0 / 0.056),
    "closed_form_side": (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 1.1 * 0.05 * 50.0 / 0.056),
    "no_acceleration": (0.0, 0.0, 50.0, 1.0, 0.0, 0.0, 100.0),
}


@pytest.mark.parametrize("args", SEGMENTS.values(), ids=SEGMENTS.keys())
def test_propagation_derivatives_match_finite_differences(args):
    values, D = propagate_curvilinear_derivatives(*args)
    assert D.shape == (4, 7)
    np.testing.assert_array_equal(np.array(values), np.array(propagate_curvilinear(*args)))
    v0, dt = args[2], args[6]
    # steps on each input's natural scale: accelerations v0 / |dt| (the one that doubles
    # the speed over dt), speed v0, the course 1 rad
    a_scale = v0 / max(abs(dt), 1.0)
    steps = (1.0, 1.0, 1e-4 * v0, 1e-4, 1e-4 * a_scale, 1e-4 * a_scale, 1e-3)
    numeric = np.zeros((4, 7))
    for j in range(7):
        def f(v, j=j):
            a = list(args)
            a[j] = v
            return np.array(propagate_curvilinear(*a)[:4])
        numeric[:, j] = fourth_order(f, args[j], steps[j])
    assert_columns_close(D, numeric, ("x0", "y0", "v0", "phi0", "a_t", "a_n", "dt"), 1e-8)
    # exact facts: translation, d speed / d v0 = 1, d course / d phi0 = 1, d pos / d dt = vel
    np.testing.assert_array_equal(D[:2, :2], np.eye(2))
    assert D[2, 2] == 1.0 and D[3, 3] == 1.0
    np.testing.assert_allclose(D[:2, 6], [values[4], values[5]], rtol=1e-12, atol=1e-12)


def test_propagation_derivatives_nan_where_the_target_stops():
    _, D = propagate_curvilinear_derivatives(0.0, 0.0, 10.0, 0.3, -1.0, 0.1,
                                             np.array([20.0, 5.0]))
    assert np.all(np.isnan(D[0])) and np.all(np.isfinite(D[1]))


# --------------------------------------------------------------------------------------------
# piecewise: every parameter, change-over times included, forwards and backwards chains
# --------------------------------------------------------------------------------------------

STEPS = {"x": 1.0, "y": 1.0, "speed": 5e-3, "course": 1e-4, "t_1": 1e-2, "t_2": 1e-2}
# samples before, between and after the change-over times, 0.1 s from each (the largest
# difference step in t_m is 2e-2 s: no difference straddles a change-over time)
SAMPLES = np.array([0.0, 100.0, 350.0, 399.9, 400.1, 450.0, 550.0, 599.9, 600.1, 650.0,
                    900.0])


def model_at(ref_time: float, values=BUSY) -> tuple[PiecewiseCurvilinear, np.ndarray]:
    base = PiecewiseCurvilinear(2, 0.0)
    return base.rereferenced(base.theta(values), ref_time)


@pytest.mark.parametrize("ref_time", [0.0, 250.0, 500.0, 750.0, 900.0])
def test_piecewise_jacobian_matches_finite_differences(ref_time):
    model, theta = model_at(ref_time)
    jac = model.jacobian(theta, SAMPLES)
    assert jac.shape == (SAMPLES.size, 6, 12)
    numeric = np.zeros_like(jac)
    for j, name in enumerate(model.param_names):
        def f(v, j=j):
            th = theta.copy()
            th[j] = v
            return model.states(th, SAMPLES)
        numeric[..., j] = fourth_order(f, theta[j], STEPS.get(name, 1e-4))
    assert_columns_close(jac, numeric, model.param_names, 1e-8)
    # the change-over time columns: zero on the reference's side of t_m, not on the other
    for m, tm in ((1, T1), (2, T2)):
        col = jac[..., model.param_names.index(f"t_{m}")]
        same_side = (SAMPLES <= tm) if ref_time <= tm else (SAMPLES > tm)
        np.testing.assert_array_equal(col[same_side], 0.0)
        assert np.all(np.abs(col[~same_side][:, [3, 4]]).max(axis=1) > 1e-3)


@pytest.mark.parametrize(("ref_time", "sample"), [(0.0, T1), (500.0, T1), (900.0, T1),
                                                  (T1, T1 + 50.0)])
def test_derivative_at_a_change_over_time_is_the_side_of_the_earlier_segment(ref_time, sample):
    """A sample (or the reference time) exactly at t_1 belongs to the earlier segment: the
    Jacobian is the derivative for t_1 increasing, where it stays there."""
    model, theta = model_at(ref_time)
    j = model.param_names.index("t_1")
    h = 1e-4

    def f(v):
        th = theta.copy()
        th[j] = v
        return model.states(th, [sample])[0]

    forward = (-3 * f(theta[j]) + 4 * f(theta[j] + h) - f(theta[j] + 2 * h)) / (2 * h)
    backward = (3 * f(theta[j]) - 4 * f(theta[j] - h) + f(theta[j] - 2 * h)) / (2 * h)
    jac = model.jacobian(theta, [sample])[0, :, j]
    np.testing.assert_allclose(jac, forward, rtol=0, atol=1e-6)
    # the velocity has a corner in t_1: the other side differs by the change of acceleration
    assert np.max(np.abs(jac[3:5] - backward[3:5])) > 0.1
    if sample == T1:  # the position at t_1 is smooth in t_1
        np.testing.assert_allclose(jac[:2], backward[:2], rtol=0, atol=1e-6)


def test_batched_states_and_jacobian_equal_one_at_a_time():
    model = PiecewiseCurvilinear(2, 300.0)
    a = model.theta({**BUSY, "x": -4000.0})
    b = model.theta({**SCENARIO, "t_1": 250.0, "t_2": 700.0})       # ref inside segment 1
    bad = model.theta({**SCENARIO, "t_1": T2, "t_2": T1})            # out of order
    batch = np.stack([[a, b], [bad, a]])                             # shape (2, 2, p)
    t = np.array([0.0, 250.0, 310.0, 600.0, 900.0])
    states, jac = model.states(batch, t), model.jacobian(batch, t)
    assert states.shape == (2, 2, 5, 6) and jac.shape == (2, 2, 5, 6, 12)
    for idx, theta in (((0, 0), a), ((0, 1), b), ((1, 1), a)):
        np.testing.assert_allclose(states[idx], model.states(theta, t), rtol=0, atol=1e-9)
        np.testing.assert_allclose(jac[idx], model.jacobian(theta, t), rtol=1e-12,
                                   atol=1e-12)
    assert np.all(np.isnan(states[1, 0])) and np.all(np.isnan(jac[1, 0]))


def test_fixed_parameters_model():
    model = PiecewiseCurvilinear(1, 0.0)
    theta = model.theta({k: BUSY[k] for k in model.param_names})
    known = {n: float(v) for n, v in zip(model.param_names[4:], theta[4:], strict=True)}
    fixed = FixedParameters(model, known)
    assert fixed.param_names == ("x", "y", "speed", "course")
    t = np.array([0.0, 500.0])
    np.testing.assert_array_equal(fixed.states(theta[:4], t), model.states(theta, t))
    np.testing.assert_array_equal(fixed.jacobian(theta[:4], t), model.jacobian(theta, t)[..., :4])
    with pytest.raises(ValueError, match="not parameters"):
        FixedParameters(model, {"t_9": 1.0})


# --------------------------------------------------------------------------------------------
# the bound at a sequence of reference times
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scn():
    return tk.load_scenario("hoerst2010")


@pytest.fixture(scope="module")
def coarse(scn):
    """Azimuth only and azimuth + rate, manoeuvres unknown and known, every 100 s and just
    after each manoeuvre starts."""
    refs = [100.0, 200.0, 300.0, 400.0, 410.0, 500.0, 600.0, 610.0, 700.0, 800.0, 900.0]
    both = ("azimuth", "azimuth_rate")
    return {(kinds, known): curvilinear_crb_sequence(scn, refs, kinds, known)
            for kinds in (("azimuth",), both) for known in (False, True)}


def test_azimuth_rate_beats_azimuth_only(coarse):
    az = coarse[(("azimuth",), False)]
    azr = coarse[(("azimuth", "azimuth_rate"), False)]
    for t in (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0, 900.0):
        a, b = az.at(t).rms, azr.at(t).rms
        assert np.isfinite(a) and np.isfinite(b), t
        assert b < 0.7 * a, (t, a, b)   # at 10 s spacing the largest ratio is 0.6


def test_bound_grows_when_a_manoeuvre_starts(coarse):
    for key in ((("azimuth",), False), (("azimuth", "azimuth_rate"), False)):
        s = coarse[key]
        for tm in (T1, T2):
            before, after = s.at(tm), s.at(tm + 10.0)
            assert np.isfinite(before.rms)
            assert after.rms > before.rms, (key, tm, before.rms, after.rms)
            assert after.manoeuvres == before.manoeuvres + 1
            assert len(after.parameters) == len(before.parameters) + 3
    # with azimuth rates the bound 10 s into the turn is still finite, and several times larger
    azr = coarse[(("azimuth", "azimuth_rate"), False)]
    assert 3.0 * azr.at(T1).rms < azr.at(T1 + 10.0).rms < np.inf


def test_known_manoeuvres_never_worse(coarse):
    for kinds in (("azimuth",), ("azimuth", "azimuth_rate")):
        unknown, known = coarse[(kinds, False)], coarse[(kinds, True)]
        for pu, pk in zip(unknown.points, known.points, strict=True):
            assert pk.parameters == ("x", "y", "speed", "course")
            assert np.isfinite(pk.rms) and pk.rms <= pu.rms
            if np.isfinite(pu.rms):  # Loewner order: C_unknown - C_known is positive
                diff = pu.covariance - pk.covariance
                assert np.linalg.eigvalsh(diff).min() >= -1e-9 * np.trace(pu.covariance)


def test_sample_and_reference_at_a_change_over_time(scn):
    """At t_ref = t_1 the manoeuvre has not started: its parameters are not unknowns, the
    sample at t_1 is used and belongs to the straight leg — the bound is that of a target
    without manoeuvres on the same data."""
    seq = curvilinear_crb_sequence(scn, [T1, T1 + 0.5], ["azimuth", "azimuth_rate"])
    at, after = seq.points
    assert at.manoeuvres == 0 and at.parameters == ("x", "y", "speed", "course", "at_0",
                                                    "an_0")
    assert at.n_measurements == 2 * 401                         # 0, 1, ..., 400 s, both kinds
    assert after.manoeuvres == 1 and len(after.parameters) == 9
    assert after.n_measurements == at.n_measurements            # no sample in (400, 400.5]
    meas = scn.simulate(noise=False)
    rows = meas.take(meas.time <= T1)
    plain = PiecewiseCurvilinear(0, T1)
    state = scn.motion.intrinsic_states(scn.theta, [T1])[0]
    ref = crlb(rows, plain, np.concatenate([state, [0.0, 0.0]]))
    np.testing.assert_allclose(at.covariance, ref.state_covariance(T1)[1][:2, :2],
                               rtol=1e-9)
    # half a second into the turn with no sample in it: the turn cannot be seen
    assert not after.observable and after.bound.rank < 9


def test_bound_does_not_depend_on_where_the_trajectory_is_referenced(scn):
    """Once every manoeuvre has started, the position bound at t_ref from the model
    referenced at t_ref (chained backwards) equals the delta-method bound from the model
    referenced at 0 (chained forwards) on the same data."""
    t_ref = 800.0
    seq = curvilinear_crb_sequence(scn, [t_ref])
    meas = scn.simulate(noise=False)
    rows = meas.take(meas.time <= t_ref)
    forward = crlb(rows, scn.motion, scn.theta).state_covariance(t_ref)[1][:2, :2]
    np.testing.assert_allclose(seq.points[0].covariance, forward, rtol=1e-6)


def test_bound_sequence_refuses_bad_input(scn):
    with pytest.raises(ValueError, match=r"strictly increasing.*t_1 = 600 s, t_2 = 400 s"):
        curvilinear_crb_sequence(scn, [500.0], truth={**scn.truth, "t_1": T2, "t_2": T1})
    with pytest.raises(ValueError, match=r"reference time 950 s is outside the data "
                                         r"\(samples from 0 to 900 s\)"):
        curvilinear_crb_sequence(scn, [100.0, 950.0])
    with pytest.raises(ValueError, match="reference time -5 s is outside the data"):
        curvilinear_crb_sequence(scn, [-5.0])
    with pytest.raises(ValueError, match="frequency not in the data"):
        curvilinear_crb_sequence(scn, [100.0], ["frequency"])
    with pytest.raises(ValueError, match="piecewise curvilinear"):
        curvilinear_crb_sequence(tk.load_scenario("gu2007"), [10.0])
    with pytest.raises(ValueError, match="level"):
        curvilinear_crb_sequence(scn, [100.0], level=90.0)
    with pytest.raises(ValueError, match="non-empty"):
        curvilinear_crb_sequence(scn, [])
    seq = curvilinear_crb_sequence(scn, [100.0])
    with pytest.raises(KeyError, match="no bound at reference time 200 s"):
        seq.at(200.0)


# --------------------------------------------------------------------------------------------
# the reproduction
# --------------------------------------------------------------------------------------------


def test_reproduction_checks_and_draws_fig2(tmp_path):
    from tmakit.reproduce import hoerst2010

    rep = hoerst2010.run(step=50.0)
    checks = next(s for s in rep.sections if s.title.startswith("Fig. 2: the paper"))
    assert len(checks.rows) == 5 and all(row[-1] == "yes" for row in checks.rows), checks.rows
    table = rep.sections[0]
    assert [row[0] for row in table.rows] == [300.0, 400.0, 600.0, 750.0, 900.0]
    rms = rep.figures["rms_m"]
    for i in range(5):
        assert rms["azimuth+rate, known"][i] <= rms["azimuth+rate"][i] < rms["azimuth"][i]
    path = hoerst2010.plot(rep, tmp_path / "fig2.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_reproduce_plot_option_refusals(tmp_path):
    from typer.testing import CliRunner

    from tmakit.cli import app

    runner = CliRunner()
    existing = tmp_path / "fig.png"
    existing.write_bytes(b"x")
    result = runner.invoke(app, ["reproduce", "hoerst2010", "--plot", str(existing)])
    assert result.exit_code == 2 and "already exists" in result.output
    result = runner.invoke(app, ["reproduce", "gu2007", "--runs", "0", "--plot",
                                 str(tmp_path / "new.png")])
    assert result.exit_code == 2 and "draws no figure" in result.output
    assert not (tmp_path / "new.png").exists()
