"""The Gaussian-sum smoother (issue 28): each component smoothed along its lineage."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from leong2014 import Q_DENSITY, SCENARIOS, simulate  # benchmarks/ (tests/conftest.py)
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.filters import GaussianSumFilter, first_bearing, smooth
from tmakit.filters.gaussian_sum import SumStep
from tmakit.motion.dynamics import NearlyConstantVelocity
from tmakit.tracking import BearingInitiator

MODERATE = SCENARIOS["moderate"]
CHI2_95_2DOF = 5.991464547107979


def moderate_run(i: int):
    return simulate(MODERATE, np.random.default_rng([11, i]))


def without_history(tr):
    return dataclasses.replace(tr, extra=dataclasses.replace(tr.extra, history=None))


def test_with_neither_split_nor_merge_each_component_is_its_own_rts():
    """Without split, prune or merge the components never meet: the smoothed sum's component i
    is the RTS smoother of a filter started from component i alone."""
    meas, _ = moderate_run(1)
    first = first_bearing(meas)
    rest = meas.take(np.arange(1, len(meas)))
    w, m, p = MODERATE.prior().mixture(first, 2, components=4)
    dyn = NearlyConstantVelocity(2, q_density=Q_DENSITY)
    plain = {"split_threshold": 0.0, "prune": 0.0, "merge": 0.0, "dynamics": dyn}
    tr = GaussianSumFilter.from_mixture(w, m, p, first.time, history=True, **plain).run(rest)
    sm = smooth(tr, dynamics=dyn)
    assert sm.extra.options["smoother"] == "gaussian-sum rts" and len(sm.extra.history) == len(tr)
    for i in range(4):
        alone = GaussianSumFilter.from_mixture(w[i:i + 1], m[i:i + 1], p[i:i + 1], first.time,
                                               **plain).run(rest)
        ref = smooth(alone, dynamics=dyn)
        got = np.array([s.means[i] for s in sm.extra.history])
        assert np.allclose(got, ref.states, rtol=1e-9, atol=1e-6)
        assert np.allclose([s.covariances[i] for s in sm.extra.history], ref.covariances,
                           rtol=1e-7, atol=1e-6)


def test_compiled_and_python_paths_keep_the_same_lineage():
    """One bearing at a time in 2-D runs compiled; through update() it runs in Python: the
    sums and the lineage they keep agree."""
    meas, _ = moderate_run(2)
    first = first_bearing(meas)
    rest = meas.take(np.arange(1, len(meas)))
    kw = {"dynamics": NearlyConstantVelocity(2, q_density=Q_DENSITY), "history": True}
    fast = GaussianSumFilter.from_first_bearing(MODERATE.prior(), first, **kw)
    fast.run(rest)
    slow = GaussianSumFilter.from_first_bearing(MODERATE.prior(), first, **kw)
    for t in rest.time:
        slow.predict(float(t))
        slow.update(rest.take(rest.time == t))
    assert len(fast.history) == len(slow.history) == len(rest) + 1
    assert max(len(s.weights) for s in fast.history) > 10  # splits and merges happened
    for a, b in zip(fast.history, slow.history, strict=True):
        assert np.array_equal(a.origins, b.origins)
        assert np.allclose(a.weights, b.weights, rtol=1e-6, atol=1e-12)
        assert np.allclose(a.means, b.means, rtol=1e-6, atol=1e-6)


def test_lineage_must_be_whole():
    meas, _ = moderate_run(3)
    tr = tk.track(meas, "gsf", q_density=Q_DENSITY, bearing_prior=MODERATE.prior(),
                  settings={"history": True})
    broken = list(tr.extra.history)
    broken[5] = dataclasses.replace(broken[5], origins=np.full(len(broken[5].weights), -1))
    tr.extra.history = broken
    with pytest.raises(ValueError, match="no lineage at step 5"):
        smooth(tr)
    tr.extra.history = broken[1:]
    with pytest.raises(ValueError, match="does not match the track's rows"):
        smooth(tr)


def test_fixed_lag_spans_filtered_to_fixed_interval():
    meas, _ = moderate_run(5)
    tr = tk.track(meas, "gsf", q_density=Q_DENSITY, bearing_prior=MODERATE.prior(),
                  settings={"history": True})
    assert isinstance(tr.extra.history[0], SumStep) and len(tr.extra.history) == len(tr)
    whole = smooth(tr)
    assert np.allclose(smooth(tr, lag=len(tr)).states, whole.states)
    assert np.allclose(smooth(tr, lag=0).states, tr.states)
    lag3 = smooth(tr, lag=3)
    assert np.allclose(lag3.states[-4:], whole.states[-4:])
    assert lag3.extra.options["smoother"] == "gaussian-sum fixed-lag 3"


@pytest.fixture(scope="module")
def moderate_mc():
    """20 seeded runs of the moderate scenario from the first bearing: squared position
    errors and 95 %-ellipse hits of the filtered track and of both smoothers."""
    prior = MODERATE.prior()
    out: dict[str, list] = {k: [] for k in ("filtered", "moments", "sum")}
    inside: dict[str, list] = {k: [] for k in out}
    for i in range(20):
        meas, truth = moderate_run(100 + i)
        tr = tk.track(meas, "gsf", q_density=Q_DENSITY, initiator=BearingInitiator(prior),
                      settings={"history": True})
        for name, t in (("filtered", tr), ("moments", smooth(without_history(tr))),
                        ("sum", smooth(tr))):
            d = t.states[:, :2] - truth[:, :2]
            out[name].append(np.sum(d**2, axis=1))
            m2 = np.einsum("ki,ki->k", d, np.linalg.solve(t.covariances[:, :2, :2],
                                                          d[..., None])[..., 0])
            inside[name].append(m2 <= CHI2_95_2DOF)
    return ({k: np.sqrt(np.mean(v, axis=0)) for k, v in out.items()},
            {k: float(np.mean(v)) for k, v in inside.items()})


def test_sum_smoother_beats_the_filter_at_every_step_and_holds_the_truth(moderate_mc):
    """The issue's figure on 20 runs: smoothed RMS <= 0.3x the filtered at the first bearing,
    and at most the filtered at every step to 2 % (on these runs both smoothers are 1.6 %
    above it at k = 28, where the smoother has little left to add; the benchmark's 100 runs
    have it at or below at every step: docs/tracking.md); the truth inside the smoothed 95 %
    ellipse in >= 85 % of the (run, step) pairs (91 % here, 95 % over the benchmark's)."""
    rms, cover = moderate_mc
    assert np.all(rms["sum"] <= 1.02 * rms["filtered"])
    assert rms["sum"][0] <= 0.3 * rms["filtered"][0]
    assert rms["sum"][-1] == pytest.approx(rms["filtered"][-1])
    assert cover["sum"] >= 0.85
    # the moment-matched smoother it replaces: within 10 % of it at every step
    assert np.all(np.abs(rms["sum"] / rms["moments"] - 1) <= 0.1)


def track_moderate(tmp_path, *args):
    """``tma track`` of moderate run 7 with ``args``; the runner's result."""
    path = tmp_path / "moderate.csv"
    tk.write_measurements(moderate_run(7)[0], path)
    return CliRunner().invoke(app, ["track", str(path), *args]), path


#: The first-bearing Gaussian sum on the moderate scenario, as the benchmark runs it.
GSF = ["--filter", "gsf", "--q-density", "9e-6", "--range-prior", "499:10990",
       "--speed-prior", "5.14"]


def test_command_smooths_the_sum_per_component(tmp_path):
    out, _ = track_moderate(tmp_path, *GSF, "--lag", "4", "--json")
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert data["smoother"] == "gaussian-sum fixed-lag 4"
    assert len(data["smoothed"]) == len(data["estimate"])


def moments(sums):
    """The moment match of each row's sum, in numpy alone."""
    out = []
    for row in sums:
        w, m, p = (np.array(row[k]) for k in ("weights", "means", "covariances"))
        mean = w @ m
        d = m - mean
        out.append((mean, np.einsum("c,cij->ij", w, p) + np.einsum("c,ci,cj->ij", w, d, d)))
    return np.array([a for a, _ in out]), np.array([b for _, b in out])


def test_command_gives_the_filtered_and_smoothed_sums(tmp_path):
    """``--sums`` puts each row's filtered and smoothed Gaussian sum in the JSON: their moment
    match is the reported estimate and smoothed track, with their covariances."""
    out, path = track_moderate(tmp_path, *GSF, "--smooth", "--sums", "--json")
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    rows = len(data["time"])
    assert len(data["sums"]) == len(data["smoothed_sums"]) == rows
    # the first row is the prior's sum; ``components`` counts the sums after each update
    assert [len(r["weights"]) for r in data["sums"][1:]] == data["components"]
    assert {len(r["weights"]) for r in data["smoothed_sums"]} == {data["components"][-1]}
    for key, mean, cov in (("sums", "estimate", "covariance"),
                           ("smoothed_sums", "smoothed", "smoothed_covariance")):
        m, p = moments(data[key])
        assert np.allclose([sum(r["weights"]) for r in data[key]], 1.0)
        assert np.allclose(m, data[mean], rtol=1e-9, atol=1e-6), key
        assert np.allclose(p, data[cov], rtol=1e-7, atol=1e-6), key
    plain = tk.track(tk.read_measurements(path), "gsf")
    with pytest.raises(ValueError, match="kept no Gaussian sums"):
        tk.tracking.track_dict(plain, sums=True)


@pytest.mark.parametrize("args, words", [
    (["--filter", "pf", "--sums", "--json"], "--filter pf keeps no Gaussian sum"),
    (["--filter", "gsf", "--sums"], "give --json"),
])
def test_command_refuses_sums_without_a_sum_or_json(tmp_path, args, words):
    out, _ = track_moderate(tmp_path, *args)
    assert out.exit_code == 2 and words in out.output, out.output


def test_three_d_sums_smooth_through_the_general_path():
    """Bearings and elevations in 3-D take the Python path; its lineage smooths the same way:
    the last row is the filtered sum, and the first bearing's position is known far better
    with the whole track than from the prior alone."""
    from modified_spherical import SCENARIO  # benchmarks/ (tests/conftest.py)

    meas = tk.load_scenario(SCENARIO).simulate(rng=4)
    prior = tk.BearingPrior(5000.0, 60_000.0, 300.0)
    tr = tk.track(meas, "gsf", dim=3, q_density=1e-2, bearing_prior=prior,
                  settings={"history": True})
    sm = smooth(tr)
    assert sm.extra.options["smoother"] == "gaussian-sum rts"
    assert sm.extra.history[0].means.shape[1] == 6
    assert np.allclose(sm.states[-1], tr.states[-1], rtol=1e-9, atol=1e-6)
    assert np.trace(sm.covariances[0][:3, :3]) < 0.05 * np.trace(tr.covariances[0][:3, :3])
