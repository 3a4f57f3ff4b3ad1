"""The typed public face: every public callable names its keywords, one random convention,
renamed keywords that warn for a release, and one serialisation of each result."""

from __future__ import annotations

import inspect
import json
import typing
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit import filters
from tmakit.cli import app

FILTER_CLASSES = list(filters.FILTERS.values())


def public_callables():
    """Every function and class a user calls: tk's names and the filter classes."""
    found = [(name, getattr(tk, name)) for name in tk.__all__]
    found += [(cls.__name__, cls) for cls in FILTER_CLASSES]
    for name, obj in found:
        if not callable(obj) or typing.get_origin(obj) is not None:
            continue  # constants (KINDS) and type aliases (Status)
        if inspect.isabstract(obj) or getattr(obj, "_is_protocol", False):
            continue  # interfaces, not constructors (MotionModel, SensorTrack)
        if isinstance(obj, type) and issubclass(obj, Exception) and "__init__" not in vars(obj):
            continue  # an exception with the base class's constructor
        yield name, obj


@pytest.mark.parametrize(("name", "obj"), list(public_callables()),
                         ids=[n for n, _ in public_callables()])
def test_every_public_callable_refuses_an_unknown_keyword_by_name(name, obj):
    with pytest.raises(TypeError, match="bogus_option"):
        obj(bogus_option=3)
    signature = inspect.signature(obj)
    loose = [p.name for p in signature.parameters.values()
             if p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL)]
    assert loose == [], f"{name} takes *{loose}: its keywords are not named"


def test_the_issue_examples_are_refused_naming_the_keyword(tmp_path):
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(rng=1)
    with pytest.raises(TypeError, match="bogus"):
        tk.estimate(meas, scn.motion, bogus=1)
    with pytest.raises(TypeError, match="exact"):  # a manoeuvre setting, no manoeuvres
        tk.estimate(meas, scn.motion, exact=True)
    with pytest.raises(TypeError, match="bogus_option"):
        filters.ExtendedKalmanFilter(np.zeros(4), np.eye(4), bogus_option=3)
    path = tk.write_measurements(meas, tmp_path / "m.csv")
    with pytest.raises(TypeError, match="bearing_sigm"):
        tk.read_measurements(path, bearing_sigm=0.5)


def test_a_filter_start_refuses_a_setting_its_class_does_not_take_by_name():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(rng=1)
    res = tk.estimate(meas, scn.motion)
    assert res.status == "converged"
    prior, first = tk.BearingPrior(2000.0, 30_000.0, 10.0), filters.first_bearing(meas)
    for cls in filters.FILTERS.values():
        with pytest.raises(TypeError, match="bogus_option"):
            cls.from_estimate(res, 100.0, bogus_option=3)
        with pytest.raises(TypeError, match="bogus_option"):
            cls.from_first_bearing(prior, first, bogus_option=3)
    with pytest.raises(TypeError, match="particles"):  # another filter's setting
        filters.ExtendedKalmanFilter.from_estimate(res, 100.0, particles=10)
    with pytest.raises(TypeError, match="componnet"):
        filters.GaussianSumFilter.from_mixture([1.0], [[5e3, 5e3, 0.0, 0.0]], np.eye(4)[None],
                                               componnet="ckf")
    with pytest.raises(TypeError, match="bearing_start"):
        filters.ParticleFilter.from_first_bearing(prior, first, bearing_start=(prior, first))
    with pytest.raises(TypeError, match="origin"):
        filters.ModifiedPolarEKF.from_first_bearing(prior, first, origin=np.zeros(4))
    # the settings a class takes reach it, the estimate's nuisance values by default
    pf = filters.ParticleFilter.from_estimate(res, 100.0, particles=50, rng=2, q=0.01)
    assert (pf.n_particles, pf.time, pf.dynamics.q) == (50, 100.0, 0.01)
    assert isinstance(pf, filters.ParticleFilter)


def settings_agree(declared_dict, classes, skip=()):
    """The TypedDict names every keyword of the classes' constructors, with its type."""
    declared = {k: v.__forward_arg__ for k, v in declared_dict.__annotations__.items()}
    taken: dict[str, set[str]] = {}
    for cls in classes:
        for p in inspect.signature(cls).parameters.values():
            if p.name not in skip:
                taken.setdefault(p.name, set()).add(str(p.annotation))
    assert set(declared) == set(taken)
    for name, types in taken.items():  # the same type, or that or None
        assert types <= {declared[name], declared[name].removesuffix(" | None")}, name


def test_filter_settings_name_every_keyword_of_the_filters_with_its_type():
    """FilterSettings (the ``from_*`` starts' keywords) is the union of the constructors'."""
    classes, todo = set(), [filters.TrackingFilter]
    while todo:
        todo += todo.pop().__subclasses__()
        classes.update(todo)
    settings_agree(filters.FilterSettings, classes, skip=("mean", "covariance", "time"))


def test_estimator_settings_name_every_keyword_of_the_batch_estimators_by_name():
    from tmakit.batch.methods import METHODS, EstimatorSettings, estimate_with, estimator
    from tmakit.batch.ml import estimate as estimate_ml

    settings_agree(EstimatorSettings, [m.cls for m in METHODS.values()])
    scn = tk.load_scenario("gu2007")
    meas = scn.simulate(rng=1)
    with pytest.raises(TypeError, match="bogus_option"):
        estimator("ml", bogus_option=3)
    with pytest.raises(TypeError, match="normal_equations"):  # gu-direct's, not ml's
        estimate_with("ml", meas, scn.motion, normal_equations=True)
    with pytest.raises(TypeError, match="'exact'"):
        estimate_ml(meas, scn.motion, exact=True)


def test_monte_carlo_takes_rng_and_seed_warns_for_one_release():
    a = tk.monte_carlo("gu2007", runs=2, rng=4, progress=False)
    with pytest.warns(DeprecationWarning, match=r"monte_carlo\(seed=...\) is deprecated"):
        b = tk.monte_carlo("gu2007", runs=2, seed=4, progress=False)
    assert a.seed == b.seed == 4
    assert a.table.equals(b.table)
    drawn = tk.monte_carlo("gu2007", runs=2, rng=np.random.default_rng(1), progress=False)
    again = tk.monte_carlo("gu2007", runs=2, rng=drawn.seed, progress=False)
    assert drawn.table.equals(again.table)  # a Generator's seed is recorded and reproduces
    with pytest.warns(DeprecationWarning), pytest.raises(TypeError, match="both rng and seed"):
        tk.monte_carlo("gu2007", runs=2, rng=5, seed=4, progress=False)


def test_plan_takes_rng_and_seed_warns():
    with pytest.warns(DeprecationWarning, match=r"plan\(seed=...\)"), \
            pytest.raises(TypeError, match="both rng and seed"):
        tk.plan("plan-bearings-only", rng=2, seed=3)
    assert "rng" in inspect.signature(tk.plan).parameters


def test_track_tracker_keyword_and_the_old_filter_keyword_warns():
    meas = tk.load_scenario("bearings-only-2d").simulate(rng=3)
    new = tk.track(meas, tracker="ekf")
    with pytest.warns(DeprecationWarning, match=r"track\(filter=...\) is deprecated"):
        old = tk.track(meas, filter="ekf")
    np.testing.assert_array_equal(new.states, old.states)
    with pytest.warns(DeprecationWarning), pytest.raises(TypeError, match="both tracker"):
        tk.track(meas, tracker="ukf", filter="ekf")


def test_status_is_a_literal_of_the_statuses():
    from tmakit.results import STATUSES

    assert typing.get_origin(tk.Status) is typing.Literal
    assert set(typing.get_args(tk.Status)) == set(STATUSES) == {
        "converged", "did not converge", "unobservable", "diverged"}
    meas = tk.load_scenario("gu2007").simulate(rng=2)
    assert tk.estimate(meas, "cv2d").status in STATUSES


@pytest.mark.parametrize(("scenario", "motion"), [("gu2007", "cv2d"),
                                                  ("hoerst2010", "curvilinear:1")])
def test_estimate_json_is_the_results_own_serialisation(tmp_path, scenario, motion):
    """`tma estimate --json` prints the result's as_dict: the same keys, the same values."""
    meas = tk.load_scenario(scenario).simulate(rng=5)
    path = tk.write_measurements(meas, tmp_path / "m.csv")
    out = CliRunner().invoke(app, ["estimate", str(path), "--motion", motion, "--json"])
    assert out.exit_code in (0, 1), out.output
    printed = json.loads(out.stdout)
    res = tk.estimate(tk.read_measurements(path), motion)
    mine = json.loads(res.to_json(tk.read_measurements(path)))
    assert set(printed) == set(mine)
    for key in ("covariance", "chi2_p_value", "answer", "warnings", "sigma_scale", "geodetic"):
        assert key in mine
    assert mine["chi2_p_value"] == pytest.approx(printed["chi2_p_value"], rel=1e-9)
    assert res.chi2_p_value == pytest.approx(printed["chi2_p_value"], rel=1e-9)
    assert mine["estimate"] == pytest.approx(printed["estimate"], rel=1e-9)
    # without the measurements: the same keys, what needs them is None
    alone = res.as_dict()
    assert set(alone) == set(mine)
    assert alone["answer"] is None and alone["warnings"] is None


def test_the_namespace_exports_every_result_type():
    for name in ("EstimateResult", "ManoeuvreEstimate", "Bound", "PosteriorBound", "Track",
                 "MonteCarloResult", "PlanRun", "Recommendation", "Answer", "Status"):
        assert name in tk.__all__
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not hasattr(tk, "import_module")


def test_names_say_the_unit_and_the_old_names_warn(tmp_path):
    """MeasurementSet takes file units (value_file, sigma_file: degrees for a bearing),
    MeasurementSet.from_si and MeasurementPlan SI; the old names warn for one release."""
    from sample_logs import replay_sample

    states = np.zeros((2, 6))
    new = tk.MeasurementSet([0.0, 1.0], ["s", "s"], ["bearing"] * 2, value_file=[10.0, 20.0],
                            sigma_file=[1.0, 1.0], sensor_state=states)
    np.testing.assert_allclose(new.value_si, np.deg2rad([10.0, 20.0]))
    with pytest.warns(DeprecationWarning, match=r"MeasurementSet\(value=...\) is deprecated"):
        old = tk.MeasurementSet([0.0, 1.0], ["s", "s"], ["bearing"] * 2, value=[10.0, 20.0],
                                sigma_file=[1.0, 1.0], sensor_state=states)
    assert old.equals(new)
    with pytest.raises(TypeError, match="needs value_file"):
        tk.MeasurementSet([0.0], ["s"], ["bearing"], sigma_file=[1.0], sensor_state=states[:1])
    text, _ = replay_sample(0)
    rep = tmp_path / "c.rep"
    rep.write_text(text)
    named = tk.read_measurements(rep, ownship="OWNSHIP", contact="CONTACT",
                                 bearing_sigma_deg=0.5)
    with pytest.warns(DeprecationWarning, match="bearing_sigma_deg"):
        renamed = tk.read_measurements(rep, ownship="OWNSHIP", contact="CONTACT",
                                       bearing_sigma=0.5)
    assert renamed.equals(named)
    np.testing.assert_allclose(named.sigma_si[named.kind_mask("bearing")], np.deg2rad(0.5))
