"""Maximum likelihood for manoeuvring targets (tmakit.batch.curvilinear): the batched
piecewise-curvilinear evaluator against the general model, the number of manoeuvres found,
estimates within their reported uncertainty, the stated order criteria, refusals, the CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from kernel_paths import numerical_jacobian
from typer.testing import CliRunner

import tmakit as tk
from tmakit.batch.curvilinear import (
    ManoeuvreSettings,
    OrderFit,
    estimate_manoeuvres,
    may_hold,
    select_order,
)
from tmakit.bounds import crlb
from tmakit.cli import app
from tmakit.motion import (
    FixedParameters,
    PiecewiseCurvilinear,
    propagate_curvilinear,
)
from tmakit.motion.curvilinear import ForwardPiecewise
from tmakit.motion.curvilinear_compiled import propagate_with_partials


@pytest.fixture(scope="module")
def scn():
    return tk.load_scenario("hoerst2010")


@pytest.fixture(scope="module")
def fits(scn):
    """Blind estimates of two seeded simulations (computed once for several tests)."""
    out = {}
    for seed in (11, 12):
        meas = scn.simulate(rng=seed)
        out[seed] = meas, tk.estimate(meas, "curvilinear:2")
    return out


@pytest.fixture(scope="module")
def straight(scn):
    """The Hörst & Oispuu (2010) geometry with a target that does not manoeuvre."""
    truth = {k: scn.truth[k] for k in ("x", "y", "speed", "course", "at_0", "an_0")}
    return dataclasses.replace(scn, motion=PiecewiseCurvilinear(0, 0.0), truth=truth)


# -- the batched evaluator --------------------------------------------------------------------


@pytest.mark.parametrize("args", [
    (-9000.0, 12000.0, 50.0, np.pi / 2, 0.0, 0.5, 200.0),     # turn (closed form)
    (500.0, 700.0, 40.0, 1.0, 0.3, 0.2, -100.0),              # accelerating, backwards
    (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 0.8e-3 * 50 / 0.056),   # series side of the switch
    (0.0, 0.0, 50.0, 1.0, 0.02, 0.03, 1.2e-3 * 50 / 0.056),   # closed-form side
    (0.0, 0.0, 50.0, 1.0, 0.0, 0.0, 900.0),                   # straight line
])
def test_segment_partials_match_central_differences(args):
    value, partials = propagate_with_partials(*args)
    ref = np.array(propagate_curvilinear(*args))
    np.testing.assert_allclose(value, ref, rtol=0, atol=1e-8)
    a = np.array(args, dtype=float)
    numeric = np.zeros((6, 7))
    for j in range(7):
        h = 1e-5 * max(1.0, abs(a[j]))
        up, down = a.copy(), a.copy()
        up[j] += h
        down[j] -= h
        numeric[:, j] = (propagate_with_partials(*up, partials=False)[0]
                         - propagate_with_partials(*down, partials=False)[0]) / (2 * h)
    scale = np.abs(numeric).max(axis=0) + 1e-9
    assert np.max(np.abs(partials - numeric) / scale) < 1e-6


def test_batched_model_equals_the_general_model_with_exact_derivatives(scn):
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 901.0, 3.0) + 0.5  # no sample on a change-over time
    theta = np.tile(scn.theta, (4, 1))
    theta[:, 4:10] += 0.02 * rng.normal(size=(4, 6))
    theta[:, 10:] += rng.normal(size=(4, 2)) * 30.0
    fast, general = ForwardPiecewise(2, 0.0), PiecewiseCurvilinear(2, 0.0)
    np.testing.assert_allclose(fast.states(theta, t), general.states(theta, t), rtol=0,
                               atol=1e-6)
    jac = fast.jacobian(theta, t)
    np.testing.assert_allclose(jac, numerical_jacobian(fast, theta, t), rtol=1e-6, atol=1e-4)
    d = rng.normal(size=(4, t.size, 6))
    np.testing.assert_allclose(fast.chain(d, theta, t), np.einsum("bni,bnip->bnp", d, jac),
                               rtol=1e-10, atol=1e-8)
    # change-over times out of order, or before the reference time: no trajectory
    bad = scn.theta.copy()
    bad[10], bad[11] = 600.0, 400.0
    assert np.all(np.isnan(fast.states(bad, t)))
    bad[10], bad[11] = -5.0, 400.0
    assert np.all(np.isnan(fast.states(bad, t)))


# -- the estimator ----------------------------------------------------------------------------


ZERO_IN_TRUTH = ["an_0", "an_2", "at_0", "at_1", "at_2"]  # hoerst2010: straight, turn, straight


def structure_crb(scn, held):
    """The CRB with the accelerations ``held`` known (zero): the bound of the selected model."""
    model = FixedParameters(scn.motion, dict.fromkeys(held, 0.0))
    return crlb(scn.simulate(noise=False), model,
                truth={k: v for k, v in scn.truth.items() if k not in held})


@pytest.mark.parametrize("seed", [11, 12])
def test_two_manoeuvres_found_and_estimates_within_their_reported_std(scn, fits, seed):
    _, res = fits[seed]
    assert res.status == "converged", res.message
    assert res.manoeuvres == 2 and res.selection.chosen == 2
    # the accelerations the data do not need are the ones that are zero in the truth
    assert sorted(res.held) == ZERO_IN_TRUTH and "held at zero" in res.message
    free = np.array([n not in res.held for n in res.parameters])
    assert np.all(res.estimate[~free] == 0.0) and np.all(res.std[~free] == 0.0)
    bound = structure_crb(scn, res.held)
    # reported std = inverse information at the estimate: close to the CRB at the truth for
    # the state; the change-over times' information depends on where they are estimated
    np.testing.assert_allclose(res.std[:4], bound.std[:4], rtol=0.25)
    times = [bound.std_of("t_1"), bound.std_of("t_2")]
    assert np.all((res.std[10:] > 0.5 * np.array(times)) & (res.std[10:] < 2 * np.array(times)))
    z = (res.estimate[free] - scn.theta[free]) / res.std[free]
    assert np.all(np.abs(z) < 4.0), dict(zip(np.array(res.parameters)[free], np.round(z, 2),
                                             strict=True))
    state, _ = bound.state_covariance(900.0)
    for i, k in enumerate(("x", "y")):
        value, std = res.final[k]
        assert abs(value - state[i]) < 4.0 * std
    assert res.final_time == 900.0
    chi2 = [o["chi2"] for o in res.selection.orders]
    assert chi2[0] > chi2[1] > chi2[2]
    assert [o["unknowns"] for o in res.selection.orders] == [6, 9, 7]
    assert res.selection.orders[2]["lr_statistic"] > 30.0


def test_every_acceleration_fitted_on_request(scn, fits):
    """accelerations="all": the model of Hörst & Oispuu (2010) as written; chi2 never grows
    with the order and
    the reported std is close to the CRB with every acceleration unknown."""
    meas, selected = fits[11]
    res = tk.estimate(meas, "curvilinear:2", accelerations="all")
    assert res.held == [] and res.status == "converged" and res.manoeuvres == 2
    bound = crlb(scn)
    np.testing.assert_allclose(res.std[:4], bound.std[:4], rtol=0.25)
    z = (res.estimate - scn.theta) / res.std
    assert np.all(np.abs(z) < 4.0)
    chi2 = [o["chi2"] for o in res.selection.orders]
    assert chi2[0] > chi2[1] > chi2[2] - 1e-6
    assert [o["unknowns"] for o in res.selection.orders] == [6, 9, 12]
    # five fewer unknowns cost less than 5 ln N in chi2 (BIC chose them)
    assert 0.0 <= selected.chi2 - res.chi2 < 5 * np.log(len(meas))


def test_an_acceleration_the_data_need_is_kept(scn):
    """A last leg that speeds up (a_t = 0.08 m/s^2, ~5.6 of its CRB std): a_t,2 is fitted, and
    estimated within 4 std."""
    truth = dict(scn.truth, at_2=0.08)
    faster = dataclasses.replace(scn, truth=truth)
    res = tk.estimate(faster.simulate(rng=3), "curvilinear:2")
    assert res.manoeuvres == 2 and "at_2" not in res.held
    i = res.parameters.index("at_2")
    assert abs(res.estimate[i] - 0.08) < 4.0 * res.std[i]


def test_no_manoeuvre_gives_zero_manoeuvres(straight):
    res = tk.estimate(straight.simulate(rng=1), PiecewiseCurvilinear(2, 0.0))
    assert res.manoeuvres == 0 and res.parameters == straight.motion.param_names
    assert res.status == "converged"
    free = res.std > 0
    assert set(res.held) == {n for n, f in zip(res.parameters, free, strict=True) if not f}
    z = (res.estimate[free] - straight.theta[free]) / res.std[free]
    assert np.all(np.abs(z) < 4.0)
    orders = res.selection.orders
    assert [o["manoeuvres"] for o in orders] == [0, 1, 2]


def test_a_given_start_fits_exactly_that_order_and_reference_time_is_respected(fits):
    meas, blind = fits[11]
    # the blind fit, referenced at the last measurement time, as a start: the same fit back
    ref, start = blind.motion.rereferenced(blind.estimate, 900.0)
    again = tk.estimate(meas, ref, init=start)
    assert again.selection is None and again.motion.ref_time == 900.0
    assert again.status == "converged"
    assert abs(again.chi2 - blind.chi2) < 1e-3
    t = np.arange(0.0, 901.0, 10.0)
    gap = again.motion.states(again.estimate, t) - blind.motion.states(blind.estimate, t)
    assert np.max(np.abs(gap[..., :2])) < 1.0  # m
    # referenced at 900 s, the position parameters are the final position, same std
    x, sx = blind.final["x"]
    assert again.estimate[0] == pytest.approx(x, abs=1.0)
    assert again.std[0] == pytest.approx(sx, rel=1e-3)


def test_order_criteria_as_stated():
    def fit(m, chi2):
        return OrderFit(m, np.zeros(6 + 3 * m), np.zeros(0), chi2, 6 + 3 * m, True, 1, 1)

    fits = [fit(0, 3400.0), fit(1, 1870.0), fit(2, 1780.0), fit(3, 1765.0)]
    n = 1802
    bic = select_order(fits, n, "bic")
    assert bic.chosen == 2  # 15 < 3 ln 1802 = 22.5
    assert bic.orders[3]["bic"] == pytest.approx(1765.0 + 15 * np.log(n))
    lrt = select_order(fits, n, "lrt", alpha=0.01)
    assert lrt.chosen == 3  # 15 > chi-square(3) 99 % quantile 11.34
    assert lrt.orders[3]["p_value"] == pytest.approx(0.0018166, rel=1e-3)
    assert select_order(fits, n, "lrt", alpha=0.001).chosen == 2
    # the sequence stops at the first manoeuvre that is not significant
    gap = [fit(0, 1800.0), fit(1, 1798.0), fit(2, 1700.0)]
    assert select_order(gap, n, "lrt").chosen == 0
    assert select_order(gap, n, "bic").chosen == 2


def test_two_neighbouring_legs_are_never_both_held_straight():
    # internal order: x, y, speed, course, at_0, an_0, at_1, an_1, at_2, an_2, t_1, t_2
    free = np.ones(12, dtype=bool)
    free[[4, 5]] = False  # leg 0 straight
    leg1_at_held = free.copy()
    leg1_at_held[6] = False
    assert not may_hold(leg1_at_held, 7, 2)  # leg 1 would be straight next to leg 0
    assert may_hold(leg1_at_held, 8, 2) and may_hold(leg1_at_held, 9, 2)  # leg 2 alone
    leg2_at_held = leg1_at_held.copy()
    leg2_at_held[8] = False
    assert may_hold(leg2_at_held, 9, 2)  # legs 0 and 2 straight, the turn between them
    assert may_hold(np.ones(6, dtype=bool), 4, 0) and may_hold(np.array([1, 1, 1, 1, 0, 1],
                                                                          dtype=bool), 5, 0)


def test_a_manoeuvre_with_fewer_unknowns_than_the_order_below_is_favoured():
    def fit(m, chi2, unknowns):
        return OrderFit(m, np.zeros(6 + 3 * m), np.zeros(0), chi2, unknowns, True, 1, 1)

    # M = 2 with five accelerations held: 7 unknowns against 9 for M = 1
    fits = [fit(0, 3500.0, 6), fit(1, 1816.0, 9), fit(2, 1714.0, 7)]
    sel = select_order(fits, 1802, "lrt")
    assert sel.orders[2]["p_value"] == 0.0 and sel.chosen == 2
    assert select_order(fits, 1802, "bic").chosen == 2


def test_a_small_alpha_prices_an_unknown_by_the_upper_tail_not_by_inf():
    """ppf(1 - alpha) was inf from alpha = 1e-17 (1 - alpha is 1): every fit's statistic
    inf - inf, so --alpha 1e-300 printed four 'equally good' solutions with LR = nan, p = nan,
    and the message called 1 - alpha 'the chi-square(1) quantile'."""
    from tmakit.batch.manoeuvre import fit_criterion, unknown_price

    for alpha, price in ((0.05, 3.841459), (1e-6, 23.928127), (1e-300, 1373.9)):
        s = ManoeuvreSettings(criterion="lrt", alpha=alpha)
        assert unknown_price(s, 100) == pytest.approx(price, rel=1e-4)
    words = fit_criterion(ManoeuvreSettings(criterion="lrt", alpha=1e-6))
    assert "by less than 23.93, the chi-square(1) quantile exceeded with probability 1e-06" in words


def test_bad_requests_are_refused_clearly(scn):
    meas = scn.simulate(rng=1)
    with pytest.raises(ValueError, match="curvilinear:M"):
        tk.estimate(meas, "curvilinear:two")
    with pytest.raises(ValueError, match="criterion must be one of bic, lrt"):
        estimate_manoeuvres(meas, 1, criterion="aic")
    with pytest.raises(ValueError, match="alpha"):
        estimate_manoeuvres(meas, 1, criterion="lrt", alpha=1.5)
    with pytest.raises(ValueError, match="max_manoeuvres"):
        ManoeuvreSettings(max_manoeuvres=-1)
    with pytest.raises(ValueError, match="inside the data span"):
        tk.estimate(meas, PiecewiseCurvilinear(1, 0.0),
                    init={"x": -9e3, "y": 12e3, "speed": 50.0, "course": 1.5, "at_0": 0.0,
                          "an_0": 0.0, "at_1": 0.0, "an_1": 0.5, "t_1": 950.0})
    with pytest.raises(ValueError, match="holds at most"):
        estimate_manoeuvres(meas.take(meas.time <= 60.0), 2, exact=True)
    with pytest.raises(TypeError, match="manoeuvring targets"):
        tk.estimate(meas, tk.ConstantVelocity(2), criterion="bic")


def test_cli_estimate_curvilinear_json_and_refusals(tmp_path, fits):
    runner = CliRunner()
    obs = tmp_path / "obs.csv"
    assert runner.invoke(app, ["simulate", "hoerst2010", "--seed", "12", "-o",
                               str(obs)]).exit_code == 0
    result = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear:2", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert {"parameters", "estimate", "std", "nuisance", "status", "iterations", "chi2", "dof",
            "model_order", "change_over_times", "final_state"} <= set(data)
    assert data["status"] == "converged" and data["manoeuvres"] == 2
    assert data["model_order"]["chosen"] == 2 and data["model_order"]["criterion"] == "bic"
    _, library = fits[12]  # the same data through tk.estimate: the same fit
    assert data["chi2"] == pytest.approx(library.chi2, abs=1e-3)
    assert [o["manoeuvres"] for o in data["model_order"]["orders"]] == [0, 1, 2]
    for (value, std), truth in zip(((c["value"], c["std"]) for c in data["change_over_times"]),
                                   (400.0, 600.0), strict=True):
        assert abs(value - truth) < 4.0 * std
    bad = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear:x"])
    assert bad.exit_code == 2 and "curvilinear:M" in bad.output
    wrong = runner.invoke(app, ["estimate", str(obs), "--motion", "cv2d", "--exact"])
    assert wrong.exit_code == 2 and "curvilinear" in wrong.output
    wrong = runner.invoke(app, ["estimate", str(obs), "--motion", "cv2d", "--accelerations",
                                "all"])
    assert wrong.exit_code == 2 and "--accelerations" in wrong.output
    bad = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear",
                              "--accelerations", "some"])
    assert bad.exit_code == 2 and "--accelerations 'some': expected select or all" in bad.output
    assert sorted(data["held_at_zero"]) == ZERO_IN_TRUTH
    paper = runner.invoke(app, ["estimate", str(obs), "--motion", "curvilinear",
                                "--method", "ratio"])
    assert paper.exit_code == 2 and "ml only" in paper.output
