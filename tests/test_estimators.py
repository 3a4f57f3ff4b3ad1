"""Batch estimators as objects (settings in the constructor, ``fit(meas, motion)``), their
registry, the one type for known nuisance parameters, and the one result assembly."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch import GuDirect, LectureGaussNewton, RatioMethod
from tmakit.batch.estimator import BatchEstimator
from tmakit.batch.manoeuvre import ManoeuvreEstimator
from tmakit.batch.methods import METHODS, MLByMotion, estimate_with, estimator
from tmakit.batch.ml import MaximumLikelihood
from tmakit.batch.ml import estimate as estimate_ml
from tmakit.bounds import crlb
from tmakit.reproduce.doppler_lecture import with_receivers
from tmakit.results import DIVERGED, KnownNuisance
from tmakit.results.estimate import diverged_result, result_from_covariance
from tmakit.results.nuisance import as_known_nuisance

SRC = Path(__file__).resolve().parents[1] / "src" / "tmakit"
PAPER_START = (4900.0, 1200.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def gu():
    return tk.load_scenario("gu2007")


@pytest.fixture(scope="module")
def meas(gu):
    return gu.simulate(rng=5)


def same(a, b) -> None:
    """Two results equal bit for bit."""
    assert a.as_dict() == b.as_dict()
    np.testing.assert_array_equal(a.covariance, b.covariance)
    assert a.extra.keys() == b.extra.keys()


# -- objects and their short forms -------------------------------------------------------------
def test_every_object_equals_its_short_form(gu, meas):
    opts = gu.measurement_options
    same(MaximumLikelihood(options=opts).fit(meas, gu.motion),
         estimate_ml(meas, gu.motion, options=opts))
    same(MaximumLikelihood(options=opts).fit(meas, gu.motion),
         tk.estimate(meas, gu.motion, options=opts))
    same(GuDirect(init=PAPER_START, kinds="frequency").fit(meas, gu.motion),
         GuDirect(kinds="frequency").iterate(meas, gu.motion, PAPER_START))
    same(RatioMethod(init=PAPER_START, covariance="paper", max_iter=5).fit(meas, gu.motion),
         RatioMethod(covariance="paper", max_iter=5).iterate(meas, gu.motion, PAPER_START))
    scn = with_receivers(3)
    m3 = scn.simulate(rng=1)
    start = scn.theta + np.array([300.0, -200.0, 100.0, 5.0, -5.0, 1.0])
    same(LectureGaussNewton(init=start).fit(m3, scn.motion),
         LectureGaussNewton().iterate(m3, scn.motion, start))


def test_the_registry_builds_objects_that_carry_their_names(gu, meas):
    assert list(METHODS) == ["ml", "gu-direct", "ratio-power", "ratio-doppler", "ratio",
                             "lecture-gn", "chan-ho", "ho-xu"]
    for name, method in METHODS.items():
        est = method()
        assert isinstance(est, BatchEstimator)
        assert est.name == name
        assert method.takes_known_nuisance == (name == "ml")
    assert isinstance(estimator("ratio-doppler"), RatioMethod)
    assert estimator("ratio-doppler").kinds == ("frequency",)
    same(estimate_with("ratio-power", meas, gu.motion, init=PAPER_START),
         RatioMethod(init=PAPER_START, kinds="power").fit(meas, gu.motion))
    with pytest.raises(TypeError, match="kinds fixed by the method's name"):
        estimator("ratio-power", kinds="frequency")
    with pytest.raises(TypeError):
        estimator("gu-direct", known_nuisance={"carrier": 1.9e9})


def test_papers_methods_without_init_start_from_the_grid_and_say_so(gu, meas):
    blind = RatioMethod(kinds="frequency").fit(meas, gu.motion)
    assert blind.extra["start"] == "grid"
    assert blind.message.startswith("started from tmakit's likelihood-grid point")
    started = RatioMethod(kinds="frequency").iterate(meas, gu.motion, blind.extra["start_point"])
    np.testing.assert_array_equal(blind.estimate, started.estimate)
    assert "start" not in started.extra
    with pytest.raises(ValueError, match="starting point"):
        GuDirect().iterate(meas, gu.motion, None)


def test_settings_are_checked_when_the_object_is_made():
    with pytest.raises(ValueError, match="no carrier drift"):
        GuDirect(options={"frequency": {"drift": True}})
    with pytest.raises(ValueError, match="path-loss exponent 2"):
        RatioMethod(options={"power": {"exponent": None}})
    with pytest.raises(ValueError, match="covariance must be one of"):
        RatioMethod(covariance="other")


def test_ml_by_motion_chooses_the_estimator_by_the_motion(gu, meas):
    opts = gu.measurement_options
    same(MLByMotion(options=opts).fit(meas, "cv2d"),
         MaximumLikelihood(options=opts).fit(meas, tk.ConstantVelocity(2, 0.0)))
    with pytest.raises(TypeError, match="manoeuvring target"):
        MaximumLikelihood().fit(meas, tk.PiecewiseCurvilinear(1, 0.0))
    with pytest.raises(TypeError, match="options for manoeuvring targets"):
        MLByMotion(criterion="bic").fit(meas, gu.motion)


def test_manoeuvre_estimator_equals_tk_estimate():
    ho = tk.load_scenario("hoerst2010")
    meas = ho.simulate(rng=2)
    motion = tk.PiecewiseCurvilinear(0, 0.0)
    same(ManoeuvreEstimator(exact=True).fit(meas, motion),
         tk.estimate(meas, motion, exact=True))


# -- which nuisance parameters are known: one type ---------------------------------------------
def test_known_nuisance_spellings_convert_to_one_type():
    assert as_known_nuisance(None) is None
    assert as_known_nuisance(False) is None
    assert as_known_nuisance(np.False_) is None
    assert as_known_nuisance(True) == KnownNuisance()
    assert as_known_nuisance({}) == KnownNuisance()  # an empty mapping is "known"
    assert bool(KnownNuisance())
    known = KnownNuisance({"carrier": 1.9e9})
    assert as_known_nuisance(known) is known
    assert as_known_nuisance({"carrier": 1.9e9}) == known
    assert known.over({"carrier": 1.0, "power_constant_db": -30.0}) == {
        "carrier": 1.9e9, "power_constant_db": -30.0}
    with pytest.raises(TypeError, match="known_nuisance must be"):
        as_known_nuisance("yes")


def test_known_nuisance_in_bounds_and_estimates(gu, meas):
    flag, typed = crlb(gu, known_nuisance=True), crlb(gu, known_nuisance=KnownNuisance())
    np.testing.assert_array_equal(flag.std, typed.std)
    assert crlb(gu).known_nuisance is None
    assert flag.known_nuisance == KnownNuisance(flag.nuisance_values)
    assert flag.as_dict()["nuisance"] == "known"
    # Values the KnownNuisance names are those the bound is evaluated at.
    other = crlb(gu, known_nuisance={"carrier": 2.0e9})
    assert other.nuisance_values["carrier"] == 2.0e9
    values = dict(gu.nuisance)
    a = tk.estimate(meas, gu.motion, options=gu.measurement_options, known_nuisance=values)
    b = MaximumLikelihood(options=gu.measurement_options,
                          known_nuisance=KnownNuisance(values)).fit(meas, gu.motion)
    same(a, b)
    assert b.bound is not None and b.bound.known_nuisance is not None
    assert all(std == 0.0 for _, std in b.nuisance.values())


def test_known_nuisance_runs_through_the_manoeuvre_estimator_as_one_type(monkeypatch):
    """A KnownNuisance reaches the manoeuvre search as itself (no dict or bool in between),
    and every spelling gives the same fit."""
    import tmakit.batch.manoeuvre as manoeuvre

    ho = tk.load_scenario("hoerst2010")
    m = ho.simulate(rng=2)
    motion = tk.PiecewiseCurvilinear(0, 0.0)
    seen = []
    search = manoeuvre.ManoeuvreSearch

    def spy(meas, options, known, settings):
        seen.append(known)
        return search(meas, options, known, settings)

    monkeypatch.setattr(manoeuvre, "ManoeuvreSearch", spy)
    typed = ManoeuvreEstimator(exact=True, known_nuisance=KnownNuisance()).fit(m, motion)
    flag = tk.estimate(m, motion, exact=True, known_nuisance=True)
    same(typed, flag)
    assert seen == [KnownNuisance(), KnownNuisance()]
    assert all(isinstance(k, KnownNuisance) for k in seen)
    assert typed.bound is not None and typed.bound.known_nuisance is not None
    free = ManoeuvreEstimator(exact=True).fit(m, motion)
    assert seen[-1] is None and free.bound.known_nuisance is None


def test_ml_by_motion_reads_a_name_once_and_sends_fixed_models_straight_to_ml(gu, meas,
                                                                            monkeypatch):
    import tmakit.batch.manoeuvre as method
    import tmakit.batch.methods as methods

    calls = []
    parse = methods.motion_from_name
    monkeypatch.setattr(methods, "motion_from_name",
                        lambda name, ref=0.0: calls.append(name) or parse(name, ref))

    def refuse(*a, **k):
        raise AssertionError("a fixed motion model reached the manoeuvre estimator")

    monkeypatch.setattr(method, "estimate_for", refuse)
    opts = gu.measurement_options
    same(MLByMotion(options=opts).fit(meas, "cv2d"),
         MaximumLikelihood(options=opts).fit(meas, tk.ConstantVelocity(2, 0.0)))
    same(MLByMotion(options=opts, ref_time=10.0).fit(meas, "cv2d"),
         MaximumLikelihood(options=opts).fit(meas, tk.ConstantVelocity(2, 10.0)))
    assert calls == ["cv2d", "cv2d"]
    # a manoeuvring name is read into its model, referenced at the first measurement time
    model = methods.model_of("curvilinear:1", meas, None)
    assert model.manoeuvres == 1 and model.ref_time == float(meas.time.min())
    assert methods.model_of("curvilinear", meas, 4.0).ref_time == 4.0


# -- many data sets at once: the batched fit is the one-by-one fit ------------------------------
def test_fit_many_equals_fit_set_by_set(gu):
    sets = [gu.simulate(rng=s) for s in (11, 12, 13)]
    opts = gu.measurement_options
    start = {"x": 3000.0, "y": 3500.0, "vx": -20.0, "vy": -10.0}
    for ml in (MaximumLikelihood(options=opts),
               MaximumLikelihood(options=opts, known_nuisance=KnownNuisance(gu.nuisance)),
               MaximumLikelihood(options=opts, init=start)):
        many = ml.fit_many(sets, gu.motion)
        assert len(many) == len(sets)
        for one, data in zip(many, sets, strict=True):
            alone = ml.fit(data, gu.motion)
            assert one.status == alone.status and one.starts == alone.starts
            # a batched solve may round a convergence test the other way on its last step
            assert abs(one.iterations - alone.iterations) <= 1
            np.testing.assert_allclose(one.estimate, alone.estimate, rtol=1e-6)
            np.testing.assert_allclose(one.chi2, alone.chi2, rtol=1e-6)
            np.testing.assert_allclose(one.std, alone.std, rtol=1e-5)
    assert MaximumLikelihood().fit_many([], gu.motion) == []


def test_fit_many_fits_sets_of_other_rows_one_by_one_and_returns_errors_per_set(gu):
    from tmakit.batch.ml import same_rows

    a, b = gu.simulate(rng=1), gu.simulate(rng=2)
    short = a.take(np.arange(len(a) - 4))
    assert same_rows([a, b]) and not same_rows([a, short])
    ml = MaximumLikelihood(options=gu.measurement_options)
    many = ml.fit_many([a, short], gu.motion)
    same(many[0], ml.fit(a, gu.motion))
    same(many[1], ml.fit(short, gu.motion))
    # a set no fit can use gives its error in its place; the others are fitted as alone
    bad = gu.simulate(rng=2)
    bad.value_si = np.full(len(bad), np.nan)
    batch = ml.fit_many([a, bad, b], gu.motion)
    same(batch[0], ml.fit(a, gu.motion))
    assert isinstance(batch[1], ValueError)
    with pytest.raises(ValueError) as alone:
        ml.fit(bad, gu.motion)
    assert str(alone.value) == str(batch[1])
    assert batch[2].status == ml.fit(b, gu.motion).status
    np.testing.assert_allclose(batch[2].estimate, ml.fit(b, gu.motion).estimate, rtol=1e-6)
    with pytest.raises(ValueError, match="init must give 4 values"):
        MaximumLikelihood(init=[1.0, 2.0]).fit_many([a, b], gu.motion)
    # a start at 1e300 m was fitted and called unobservable (exit 4 from tma estimate)
    for init, words in (({"x": 1e300, "y": 0.0, "vx": 0.0, "vy": 0.0}, "init x=1e+300"),
                        ([0.0, 0.0, 1e9, 0.0], "init vx=1e+09")):
        with pytest.raises(ValueError, match=words.replace("+", r"\+") + ": expected positions "
                                             "within 1e.09 m of the origin and speeds below"):
            tk.estimate(a, gu.motion, init=init)
    with pytest.raises(TypeError, match="manoeuvring target"):
        ml.fit_many([a], tk.PiecewiseCurvilinear(1, 0.0))


# -- one result assembly -----------------------------------------------------------------------
def test_diverged_and_own_covariance_results(gu):
    res = diverged_result(gu.motion, ["carrier"], 7, 10, "x", "why", extra={"k": 1})
    assert res.status == DIVERGED and np.isnan(res.estimate).all()
    assert res.chi2 == np.inf and np.isnan(res.nuisance["carrier"]).all()
    assert res.extra == {"k": 1} and res.message == "why" and res.dof == 10
    cov = np.diag([4.0, 9.0, -1e-30, 1.0, 25.0])
    res = result_from_covariance(gu.motion, np.arange(4.0), cov, {}, "converged", 3, 1.5, 8,
                                 "x")
    np.testing.assert_array_equal(res.std, [2.0, 3.0, 0.0, 1.0])
    assert res.covariance.shape == (4, 4) and res.bound is None


# -- what the estimators' modules import -------------------------------------------------------
def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            names.add("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def test_ml_imports_no_manoeuvre_code():
    imported = _imports(SRC / "batch" / "ml.py")
    assert not {n for n in imported
                if any(w in n for w in ("curvilinear", "manoeuvre", "methods"))}, imported


def test_no_estimator_is_inspected_to_find_out_what_it_accepts():
    # Everywhere but the package's lazy attribute loading and the CLI's lazy command modules
    # (`tma reproduce`; `tma report`, whose options are `tma estimate`'s signature with the page
    # required; the readers' options added to a command's signature, cli/common.py).
    lazy = {SRC / "__init__.py", SRC / "cli" / "studies.py", SRC / "cli" / "estimate.py",
            SRC / "cli" / "common.py"}
    for path in sorted(set(SRC.rglob("*.py")) - lazy):
        text = path.read_text()
        assert "inspect.signature" not in text, path
        assert "import_module" not in text, path
