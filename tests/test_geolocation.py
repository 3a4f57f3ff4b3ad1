"""TDOA and FDOA between sensors: the noise shared through the reference sensor, the bound,
the maximum likelihood, files and scenario files (issue 30, items 1 and 2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tmakit as tk
from tmakit.core.units import SPEED_OF_LIGHT
from tmakit.data import MeasurementSet
from tmakit.io import MeasurementFileError
from tmakit.measurements import shared_reference_covariance
from tmakit.observation import NoiseModel

LAYOUT = Path(__file__).parent / "data" / "geolocation" / "four_sensors.toml"
SENSORS = np.array([[0.0, 0.0, 0.0], [10e3, 0.0, 0.0], [0.0, 10e3, 0.0], [10e3, 10e3, 0.0]])
EMITTER = np.array([4e3, 7e3, 0.0])
SIGMA_M = 10.0  # one difference's std as a range (m)


def fixed_tdoa_set(emitter: np.ndarray = EMITTER, times: int = 10,
                   metadata: dict[str, str] | None = None) -> MeasurementSet:
    """Sensors 2-4 against sensor 1 at ``times`` times, noise-free, sigma 10 m / c."""
    rows = [(t, i) for t in range(times) for i in (1, 2, 3)]
    t = np.array([r[0] for r in rows], float)
    idx = np.array([r[1] for r in rows])
    own = np.zeros((len(rows), 6))
    own[:, :3] = SENSORS[idx]
    ref = np.zeros((len(rows), 6))
    ref[:, :3] = SENSORS[0]
    value = (np.linalg.norm(emitter - SENSORS[idx], axis=1)
             - np.linalg.norm(emitter - SENSORS[0])) / SPEED_OF_LIGHT
    return MeasurementSet.from_si(t, [f"S{i + 1}" for i in idx], ["tdoa"] * len(rows), value,
                                  np.full(len(rows), SIGMA_M / SPEED_OF_LIGHT), own, t, ref,
                                  metadata)


def hand_fisher(times: int, shared: bool) -> np.ndarray:
    """The Fisher information of the 2-D emitter position, written out by hand."""
    unit = [(EMITTER - s) / np.linalg.norm(EMITTER - s) for s in SENSORS]
    h = np.array([(unit[i] - unit[0])[:2] / SPEED_OF_LIGHT for i in (1, 2, 3)])
    r = (SIGMA_M / SPEED_OF_LIGHT) ** 2 * ((np.eye(3) + np.ones((3, 3))) / 2 if shared
                                           else np.eye(3))
    return times * h.T @ np.linalg.solve(r, h)


@pytest.mark.parametrize("shared", [True, False])
def test_bound_equals_the_hand_written_fisher_matrix(shared):
    meas = fixed_tdoa_set(metadata=None if shared else {"tdoa_noise": "independent"})
    bound = tk.crlb(meas, tk.motion_from_name("static2d"), truth=EMITTER[:2])
    want = np.linalg.inv(hand_fisher(10, shared))
    assert np.allclose(bound.covariance, want, rtol=1e-9)


def test_noise_model_whitens_by_blocks_of_one_time_and_reference():
    meas = fixed_tdoa_set(times=3)
    noise = NoiseModel(meas)
    assert noise.correlated and noise.rank == 9
    sigma = SIGMA_M / SPEED_OF_LIGHT
    want = np.kron(np.eye(3), sigma**2 * (np.eye(3) + np.ones((3, 3))) / 2)
    assert np.allclose(shared_reference_covariance(np.full(3, sigma)), want[:3, :3])
    # whitening by the blocks gives unit covariance: W R W' = I
    w = noise.whiten(np.eye(9), axis=0)
    assert np.allclose(w @ want @ w.T, np.eye(9), atol=1e-9)
    assert np.allclose(noise.covariance(), want, rtol=1e-12)


def test_bad_metadata_noise_form_is_refused():
    with pytest.raises(ValueError, match=r"tdoa_noise.*shared, independent"):
        tk.crlb(fixed_tdoa_set(metadata={"tdoa_noise": "sometimes"}),
                tk.motion_from_name("static2d"), truth=EMITTER[:2])


def test_simulated_noise_has_the_shared_covariance():
    scenario = tk.load_scenario(LAYOUT)
    template, values = scenario.simulate_values(list(range(3000)))
    err = values - template.value_si
    tdoa = np.flatnonzero((template.kind == "tdoa") & (template.time == 0.0))
    sigma = template.sigma_si[tdoa]
    got = np.cov(err[:, tdoa].T) / np.outer(sigma, sigma)
    # 3000 draws: the standard error of a sample correlation near 0.5 is about 0.014
    assert np.allclose(got, (np.eye(3) + np.ones((3, 3))) / 2, atol=0.06)
    fdoa = np.flatnonzero((template.kind == "fdoa") & (template.time == 0.0))
    got = np.cov(err[:, fdoa].T)
    assert np.allclose(got, [[1.0, 0.5], [0.5, 1.0]], atol=0.08)
    # rows at different times, or against different references, are independent
    later = np.flatnonzero((template.kind == "tdoa") & (template.time == 10.0))
    assert abs(np.corrcoef(err[:, tdoa[0]], err[:, later[0]])[0, 1]) < 0.06
    assert abs(np.corrcoef(err[:, tdoa[0]], err[:, fdoa[0]])[0, 1]) < 0.06


def test_maximum_likelihood_reaches_the_bound_over_a_seeded_monte_carlo():
    """TDOA against S1 and FDOA against S4 (unknown carrier), a moving emitter: the
    estimate's RMSE over 150 seeded runs within 0.8-1.25 of the CRLB (150 runs: the RMSE's
    relative standard error is about 6 %), and the errors inside the printed 2-sigma box."""
    scenario = tk.load_scenario(LAYOUT)
    bound = tk.crlb(scenario)
    errors = []
    for meas in scenario.simulate_many(list(range(150))):
        fit = tk.estimate(meas, scenario.motion)
        assert fit.status == "converged"
        errors.append(fit.estimate - scenario.theta)
    rmse = np.sqrt(np.mean(np.square(errors), axis=0))
    ratio = rmse / bound.std[:4]
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def test_filters_take_the_rows(tmp_path):
    scenario = tk.load_scenario(LAYOUT)
    meas = scenario.simulate(rng=4)
    for tracker in ("ekf", "ukf"):
        track = tk.track(meas, tracker)
        err = track.states[-1, :2] - scenario.target_states(track.times[-1])[0, :2]
        assert np.all(np.abs(err) < 5 * np.sqrt(np.diag(track.covariances[-1])[:2]))


def test_file_round_trip_and_refusals(tmp_path):
    meas = fixed_tdoa_set(times=2, metadata={"tdoa_noise": "independent"})
    path = tmp_path / "tdoa.csv"
    tk.write_measurements(meas, path)
    back = tk.read_measurements(path)
    assert back.equals(meas) and back.metadata["tdoa_noise"] == "independent"
    lines = path.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[head].split(",")
    lines = [*lines[:head - 1], *lines[head - 1:]]
    at = header.index("time_ref")
    row = lines[head + 1].split(",")
    row[at] = str(float(row[0]) - 1.0)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join([*lines[:head + 1], ",".join(row), *lines[head + 2:]]) + "\n")
    with pytest.raises(MeasurementFileError, match=r"time_ref.*own time"):
        tk.read_measurements(bad)
    row = lines[head + 1].split(",")
    for axis in ("x", "y", "z", "vx", "vy", "vz"):
        row[header.index(f"ref_sensor_{axis}")] = ""
    bad.write_text("\n".join([*lines[:head + 1], ",".join(row), *lines[head + 2:]]) + "\n")
    with pytest.raises(MeasurementFileError, match="reference sensor's state"):
        tk.read_measurements(bad)


def _rewrite(path: Path, out: Path, edit) -> None:
    """Rewrite a written CSV file's table through ``edit(frame)`` (metadata kept)."""
    import pandas as pd

    lines = path.read_text().splitlines()
    frame = pd.read_csv(path, comment="#", keep_default_na=False, dtype=str)
    out.write_text("\n".join(x for x in lines if x.startswith("#")) + "\n"
                   + edit(frame).to_csv(index=False))


def test_ref_sensor_named_takes_its_state_from_its_own_rows(tmp_path):
    """A tdoa row naming its reference (``ref_sensor``) without its state reads as the one
    giving it: the state comes from the reference's own rows (here S1's bearings)."""
    scenario = tk.load_scenario(LAYOUT)
    scenario.plans.append(tk.MeasurementPlan("bearing", "S1", np.arange(0.0, 61.0, 10.0), 0.01))
    scenario.plans = [p for p in scenario.plans if p.kind == "bearing"
                      or p.ref_sensor == "S1"]
    meas = scenario.simulate(rng=2)
    path, named = tmp_path / "given.csv", tmp_path / "named.csv"
    tk.write_measurements(meas, path)
    refs = [c for c in meas_columns(path) if c.startswith("ref_sensor_")]

    def name_it(frame):
        frame["ref_sensor"] = np.where(frame["kind"] == "tdoa", "S1", "")
        return frame.drop(columns=refs)

    _rewrite(path, named, name_it)
    back = tk.read_measurements(named)
    assert np.array_equal(back.ref_sensor_state, tk.read_measurements(path).ref_sensor_state,
                          equal_nan=True)
    for edit, match in [
            (lambda f: f.assign(ref_sensor=np.where(f["kind"] == "tdoa", "S9", "")),
             "'S9': it has no other usable rows"),
            (lambda f: f.assign(ref_sensor="S1"), "only tdoa and fdoa rows name"),
            (lambda f: f.assign(ref_sensor=np.where(f["kind"] == "tdoa", f["sensor"], "")),
             "another sensor than the row's own"),
            (lambda f: f.assign(ref_sensor=""), "name it in a ref_sensor column")]:
        _rewrite(named, tmp_path / "bad.csv", edit)
        with pytest.raises(MeasurementFileError, match=match):
            tk.read_measurements(tmp_path / "bad.csv")


def meas_columns(path: Path) -> list[str]:
    """The header of a written CSV file."""
    return next(x for x in path.read_text().splitlines() if not x.startswith("#")).split(",")


def test_fdoa_rows_with_their_own_carrier_read_as_at_the_files_carrier(tmp_path):
    """Rows of a hopping emitter (carrier per row) are the rows the file's carrier would give
    times F / f: read back, they equal the set simulated at one carrier."""
    from tmakit.reproduce import ho_xu2004

    meas = ho_xu2004.scenario_at(1.0).simulate(rng=5)
    path = tmp_path / "one.csv"
    tk.write_measurements(meas, path)
    hops = np.array([0.8e9, 1.2e9, 2.5e9, 0.9e9])

    def hop(frame):
        f = frame["kind"] == "fdoa"
        own = np.resize(hops, int(f.sum()))
        for c in ("value", "sigma"):
            frame.loc[f, c] = [str(float(v) * h / ho_xu2004.CARRIER_HZ)
                               for v, h in zip(frame.loc[f, c], own, strict=True)]
        frame["carrier"] = ""
        frame.loc[f, "carrier"] = [str(h) for h in own]
        return frame

    _rewrite(path, tmp_path / "hops.csv", hop)
    back = tk.read_measurements(tmp_path / "hops.csv")
    assert float(back.metadata["fdoa_carrier"]) == ho_xu2004.CARRIER_HZ
    assert np.allclose(back.value_si, meas.value_si, rtol=1e-12, atol=0)
    assert np.allclose(back.sigma_si, meas.sigma_si, rtol=1e-12, atol=0)
    _rewrite(tmp_path / "hops.csv", tmp_path / "bad.csv",
             lambda f: f.assign(carrier=np.where(f["kind"] == "fdoa", "-1", "")))
    with pytest.raises(MeasurementFileError, match="carrier frequency > 0"):
        tk.read_measurements(tmp_path / "bad.csv")
    _rewrite(tmp_path / "hops.csv", tmp_path / "bad.csv",
             lambda f: f.assign(carrier=np.where(f["kind"] == "tdoa", "1e9", "")))
    with pytest.raises(MeasurementFileError, match="only fdoa rows have a carrier"):
        tk.read_measurements(tmp_path / "bad.csv")


def test_scenario_file_refuses_a_difference_without_its_reference():
    data = tk.read_scenario_file(LAYOUT)  # the file is good
    assert {p.ref_sensor for p in data.plans} == {"S1", "S4"}
    assert sorted(p.sensor for p in data.plans if p.kind == "tdoa") == ["S2", "S3", "S4"]
    with pytest.raises(ValueError, match="ref_sensor"):
        tk.MeasurementPlan("tdoa", "S2", np.arange(3.0), 1e-8)
    with pytest.raises(ValueError, match="ref_sensor"):
        tk.MeasurementPlan("bearing", "S2", np.arange(3.0), 0.01, ref_sensor="S1")


# -- closed forms (issue 30, item 3) ---------------------------------------------------------

def test_closed_forms_are_exact_without_noise():
    from tmakit.batch.hyperbolic import two_stage_wls
    from tmakit.reproduce.ho_xu2004 import SENSORS, SOURCE, VELOCITIES

    u = np.array([SOURCE[k] for k in ("x", "y", "z")])
    ud = np.array([SOURCE[k] for k in ("vx", "vy", "vz")])
    r = np.linalg.norm(u - SENSORS, axis=1)
    rdot = np.sum((u - SENSORS) * (ud - VELOCITIES), axis=1) / r
    rd, rrd = r[1:] - r[0], rdot[1:] - rdot[0]
    pos, vel = two_stage_wls(SENSORS[1:], SENSORS[0], rd, np.eye(4))
    assert vel is None and np.allclose(pos, u, atol=1e-6)
    pos, _ = two_stage_wls(SENSORS[1:], SENSORS[0], rd, np.eye(4), height=u[2])
    assert np.allclose(pos, u, atol=1e-6)
    pos, vel = two_stage_wls(SENSORS[1:], SENSORS[0], rd, np.eye(8), VELOCITIES[1:],
                             VELOCITIES[0], rrd)
    assert np.allclose(pos, u, atol=1e-6) and np.allclose(vel, ud, atol=1e-6)
    with pytest.raises(ValueError, match="at least 4 are needed, from 5 sensors"):
        two_stage_wls(SENSORS[1:3], SENSORS[0], rd[:2], np.eye(2))


def test_ho_xu_reaches_the_bound_at_small_noise():
    """Ho & Xu's five moving sensors, 300 seeded runs at sigma = 0.1 m: the closed form's and
    the ML's position and velocity MSE within 0.75-1.3 of the CRLB (300 runs: the MSE's
    relative standard error is about 8 %)."""
    from tmakit.reproduce import geolocation_sweep, ho_xu2004

    result = geolocation_sweep.sweep(ho_xu2004.scenario_at, [0.1], 300, seed=5)
    for which in ("ml", "closed"):
        for block in ("position", "velocity"):
            ratio = result.ratio(which, block)[0]
            assert 0.75 < ratio < 1.3, (which, block, ratio)
            # over the linearised efficient estimator on the same draws: the draws' luck
            # cancels, a few per cent of excess would show
            paired = getattr(result, which + "_paired")
            assert abs(paired[block][0] - 1.0) < 0.02, (which, block, paired)
            assert paired[block + "_se"][0] < 0.005


def test_the_ml_starts_at_the_closed_form_of_interleaved_tdoa_and_fdoa_rows():
    """Ho & Xu's rows alternate TDOA and FDOA: the ML's start is the closed form of the set's
    own rows (not of the rows regrouped by kind), which settles every fit at small noise, and
    a batch of data sets gives each set's own closed form."""
    from tmakit.batch.hyperbolic import closed_form_many
    from tmakit.batch.ml import MaximumLikelihood
    from tmakit.reproduce import ho_xu2004

    scenario = ho_xu2004.scenario_at(0.1)
    sets = scenario.simulate_many([1, 2, 3])
    assert list(sets[0].kind[:2]) == ["tdoa", "fdoa"]
    ys = np.stack([m.value_si for m in sets])
    batch = closed_form_many(sets[0], ys, scenario.motion, scenario.measurement_options)
    one = [closed_form_many(m, m.value_si[None], scenario.motion,
                            scenario.measurement_options) for m in sets]
    assert batch is not None and np.allclose(batch, np.concatenate(one), rtol=1e-9, atol=1e-9)
    bound = tk.crlb(scenario)
    assert np.all(np.abs(batch - scenario.theta) < 5 * bound.std)
    fits = MaximumLikelihood().fit_many(sets, scenario.motion)
    assert all(f.starts == 1 and f.converged for f in fits)  # type: ignore[union-attr]


def test_row_labels_group_rows_as_numpy_unique_does():
    from tmakit.core.arrays import row_labels

    rng = np.random.default_rng(0)
    for _ in range(50):
        key = rng.integers(0, 3, (int(rng.integers(1, 30)), 4)).astype(float)
        _, label, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        mine, mine_counts = row_labels(key)
        assert np.array_equal(mine, label.ravel()) and np.array_equal(mine_counts, counts)
    assert [a.size for a in row_labels(np.zeros((0, 4)))] == [0, 0]


def test_chan_ho_method_and_refusals():
    from tmakit.batch.methods import estimate_with
    from tmakit.reproduce import chan_ho1994

    scenario = chan_ho1994.scenario_at(10.0)
    meas = scenario.simulate(rng=2)
    res = estimate_with("chan-ho", meas, scenario.motion)
    bound = tk.crlb(scenario)
    assert res.method == "chan-ho" and res.status == "converged"
    assert np.all(np.abs(res.estimate - scenario.theta) < 4 * bound.std)
    assert np.allclose(res.std, bound.std, rtol=0.05)
    ml = tk.estimate(meas, scenario.motion)
    assert ml.starts == 1  # the closed form's start settled it: no grid
    with pytest.raises(ValueError, match="stationary source"):
        estimate_with("chan-ho", meas, tk.motion_from_name("cv2d"))
    with pytest.raises(ValueError, match="takes no starting point"):
        estimate_with("chan-ho", meas, scenario.motion, init=[0.0, 0.0])
    with pytest.raises(ValueError, match="carrier must be known"):
        estimate_with("ho-xu", tk.load_scenario(LAYOUT).simulate(rng=1),
                      tk.motion_from_name("cv2d"))


def test_ho_xu_method_on_a_file_with_the_carrier_in_its_metadata(tmp_path):
    from tmakit.batch.methods import estimate_with
    from tmakit.reproduce import ho_xu2004

    scenario = ho_xu2004.scenario_at(0.05)
    path = tmp_path / "hoxu.csv"
    tk.write_measurements(scenario.simulate(rng=3), path)
    meas = tk.read_measurements(path)
    assert float(meas.metadata["fdoa_carrier"]) == ho_xu2004.CARRIER_HZ
    res = estimate_with("ho-xu", meas, scenario.motion)
    bound = tk.crlb(scenario)
    assert np.all(np.abs(res.estimate - scenario.theta) < 4 * bound.std)


# -- the layout bound and tma gdop (issue 30, item 5) ----------------------------------------

def test_layout_bound_equals_the_crlb_with_moving_sensors_and_fdoa():
    """Ho & Xu's moving sensors, TDOA and FDOA (known carrier) of a stationary emitter at
    three times: the layout bound at one point equals tk.crlb (static3d), and the 2-D one
    (height known) the crlb of static2d."""
    from tmakit.bounds.layout import LayoutRows, layout_information
    from tmakit.reproduce import ho_xu2004

    scenario = ho_xu2004.scenario_at(1.0)
    for plan in scenario.plans:
        plan.times = np.array([-0.5, 0.0, 0.5])
    meas = scenario.simulate(rng=0, noise=False)
    emitter = np.array([2000.0, 2500.0, 0.0])
    for noise in ("shared", "independent"):
        meas.metadata.update({"tdoa_noise": noise, "fdoa_noise": noise})
        rows = LayoutRows(meas)
        for dim, name in ((3, "static3d"), (2, "static2d")):
            want = tk.crlb(meas, tk.motion_from_name(name), truth=emitter[:dim]).covariance
            got = np.linalg.inv(layout_information(rows, emitter[None, :], dim)[0])
            assert np.allclose(got, want, rtol=1e-8)


def test_cep_against_a_seeded_monte_carlo():
    from tmakit.bounds.layout import cep

    rng = np.random.default_rng(7)
    for cov in ([[4.0, 1.0], [1.0, 1.0]], [[1e6, 30.0], [30.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]]):
        cov = np.array(cov)
        radius = np.linalg.norm(rng.multivariate_normal([0.0, 0.0], cov, 200_000), axis=1)
        # 200,000 draws: the sample quantiles are good to about 0.4 %
        assert cep(cov, 0.5) == pytest.approx(np.quantile(radius, 0.5), rel=0.01)
        assert cep(cov, 0.9) == pytest.approx(np.quantile(radius, 0.9), rel=0.01)
    assert cep(np.eye(2), 0.5) == pytest.approx(np.sqrt(2 * np.log(2)), rel=1e-6)
    assert np.isinf(cep(np.full((2, 2), np.inf), 0.5))


def test_tma_gdop_prints_the_map_and_refuses_a_layout_without_pairs(tmp_path):
    import json

    from typer.testing import CliRunner

    from tmakit.cli import app

    runner = CliRunner()
    picture = tmp_path / "cep.png"
    res = runner.invoke(app, ["gdop", str(LAYOUT), "--points", "20", "--json",
                              "--plot", str(picture)])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output)
    assert picture.stat().st_size > 10_000
    assert 0 < summary["cep50_m"]["min"] < summary["cep50_m"]["median"]
    assert summary["cep50_m"]["median"] < summary["cep90_m"]["median"]
    res = runner.invoke(app, ["gdop", str(LAYOUT), "--plot", str(picture)])
    assert res.exit_code == 2 and "--force" in res.output
    res = runner.invoke(app, ["gdop", "bearings-only-2d"])
    assert res.exit_code == 2 and "no tdoa or fdoa" in res.output
    # 1e300 m printed 'CEP50: min inf m, median inf m, max inf m'; 0 was named half_width
    for option, words in (("--half-width", "--half-width: expected a distance within (0, "
                                           "1e+09] m"),
                          ("--height", "--height: expected a height within +-1e+09 m")):
        res = runner.invoke(app, ["gdop", str(LAYOUT), option, "1e300"])
        assert res.exit_code == 2 and words in " ".join(res.output.split()), res.output


# -- sensor positions known to a covariance (issue 30, item 4) -------------------------------

def test_bound_with_sensor_errors_is_the_schur_complement_of_the_joint_information():
    """Ho & Xu's layout (TDOA + FDOA): the bound equals the inverse of the Schur complement
    of the joint Fisher information over the source and every sensor position error, with the
    errors' prior information Q_b^-1 (Ho, Lu & Kovavisaruch 2007), written out here."""
    from tmakit.bounds.fim import crlb_with_sensor_errors
    from tmakit.observation import ObservationModel
    from tmakit.observation.noise import sensor_error_design
    from tmakit.reproduce import ho_xu2004

    scenario = ho_xu2004.scenario_at(0.1)
    meas = scenario.simulate(rng=0, noise=False)
    sigma_p = 0.5
    bound, known = crlb_with_sensor_errors(meas, scenario.motion, scenario.theta, sigma_p)
    obs = ObservationModel(meas, scenario.motion, scenario.measurement_options)
    j = obs.jacobian_grouped(scenario.theta, np.zeros(0))[0]
    h_b = sensor_error_design(obs, scenario.theta, np.zeros(0))
    r_inv = np.linalg.inv(obs.row_model.covariance())
    joint = np.block([[j.T @ r_inv @ j, j.T @ r_inv @ h_b],
                      [h_b.T @ r_inv @ j, h_b.T @ r_inv @ h_b + np.eye(h_b.shape[1]) / sigma_p**2]])
    want = np.linalg.inv(joint)[:6, :6]
    assert np.allclose(bound.covariance, want, rtol=1e-6)
    assert np.all(bound.std > known.std)
    # five distinct sensor positions, three axes each
    assert h_b.shape == (len(meas), 15)


def test_accounting_fit_reports_an_honest_covariance_and_the_ignoring_one_does_not():
    """Chan & Ho's ten sensors, sigma 10 m, sensor positions off by 30 m per axis, 60 seeded
    runs: the accounting fit's mean NEES per parameter within 0.6-1.5 (60 runs x 2 parameters:
    its standard error is about 0.13), the ignoring fit's above 8 (its covariance leaves the
    errors out); both fits coincide (TDOA, equal isotropic errors: R_eff is a multiple of R)."""
    import sys

    sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
    from sensor_errors_ho2007 import reported

    from tmakit.batch.ml import estimate_with_sensor_errors
    from tmakit.reproduce import chan_ho1994

    scenario = chan_ho1994.scenario_at(10.0)
    rng = np.random.default_rng(11)
    nees_a, nees_i = [], []
    for run in range(60):
        meas = reported(scenario.simulate(rng=100 + run), 30.0, rng)
        accounting, ignoring = estimate_with_sensor_errors(meas, scenario.motion, 30.0)
        assert np.allclose(accounting.estimate, ignoring.estimate, atol=1e-3)
        for fit, nees in ((accounting, nees_a), (ignoring, nees_i)):
            e = fit.estimate - scenario.theta
            nees.append(e @ np.linalg.solve(fit.covariance, e) / 2)
    assert 0.6 < np.mean(nees_a) < 1.5
    assert np.mean(nees_i) > 8
    assert "std against perfectly known positions" in accounting.message


def test_tma_crlb_and_estimate_take_the_sensor_position_sigma(tmp_path):
    from typer.testing import CliRunner

    from tmakit.cli import app
    from tmakit.reproduce import ho_xu2004

    path = tmp_path / "hoxu.csv"
    tk.write_measurements(ho_xu2004.scenario_at(0.1).simulate(rng=1), path)
    runner = CliRunner()
    res = runner.invoke(app, ["crlb", str(path), "--sensor-position-sigma", "1"])
    assert res.exit_code == 0, res.output
    assert "std against perfectly known positions" in " ".join(res.output.split())
    res = runner.invoke(app, ["estimate", str(path), "--sensor-position-sigma", "1"])
    assert res.exit_code == 0, res.output
    assert "ml-sensor-errors" in res.output
    res = runner.invoke(app, ["estimate", str(path), "--sensor-position-sigma", "-1"])
    assert res.exit_code == 2 and "expected a distance" in res.output


# -- known altitude on the WGS-84 ellipsoid (issue 30, item 3) --------------------------------

def airborne_layout(sigma_m: float = 3.0) -> tk.Scenario:
    """Four aircraft near 10 km, a ground emitter 200 km away (3.2 km below the ENU plane)."""
    from tmakit.core.geodesy import enu_to_geodetic, geodetic_to_enu
    from tmakit.motion import Stationary
    from tmakit.sensors import FixedSensor

    origin = (52.0, 4.0, 0.0)
    lat, lon, _ = enu_to_geodetic(180e3, 90e3, 0.0, origin)
    x, y, z = (float(v) for v in geodetic_to_enu(lat, lon, 0.0, origin))
    sensors = {k: FixedSensor(np.array(p)) for k, p in {
        "A1": [0.0, 0.0, 10e3], "A2": [60e3, 0.0, 10.5e3], "A3": [0.0, 60e3, 9.5e3],
        "A4": [60e3, 60e3, 10e3], "ground": [0.0, 0.0, 0.0]}.items()}
    times = np.arange(5.0)
    plans = [tk.MeasurementPlan("tdoa", k, times, sigma_m / SPEED_OF_LIGHT, ref_sensor="A1")
             for k in ("A2", "A3", "A4")]
    plans.append(tk.MeasurementPlan("altitude", "ground", times[:1], 10.0))
    return tk.Scenario("airborne", Stationary(3), {"x": x, "y": y, "z": z}, sensors, plans,
                       origin=origin)


def test_known_altitude_on_the_ellipsoid_reaches_the_bound_where_the_plane_is_biased():
    """ML and Chan & Ho with the altitude row reach the bound; the flat plane is off."""
    from tmakit.batch.ml import MaximumLikelihood

    scn = airborne_layout()
    bound = tk.crlb(scn)
    fits = MaximumLikelihood().fit_many(scn.simulate_many(list(range(200))), scn.motion)
    err = np.array([f.estimate - scn.theta for f in fits])
    assert all(f.status == "converged" for f in fits)
    nees = np.einsum("ij,jk,ik->i", err, np.linalg.inv(bound.covariance), err) / 3
    assert 0.8 < nees.mean() < 1.25  # chi2(600)/600 within ~3.5 sigma
    from tmakit.batch.methods import estimate_with

    closed = np.array([estimate_with("chan-ho", m, scn.motion).estimate - scn.theta
                       for m in scn.simulate_many(list(range(100)))])
    assert np.mean(np.sum(closed**2, axis=1)) < 1.2 * np.trace(bound.covariance)
    one = estimate_with("chan-ho", scn.simulate(rng=7), scn.motion)
    assert np.allclose(one.std, bound.std, rtol=0.05)  # its bound takes the altitude row
    meas = scn.simulate(rng=0)
    flat = tk.estimate(meas.take(np.flatnonzero(meas.kind != "altitude")), "static2d")
    assert np.hypot(*(flat.estimate - scn.theta[:2])) > 10 * np.hypot(*flat.std)
    columns = (meas.time, meas.sensor, meas.kind, meas.value_si, meas.sigma_si)
    with pytest.raises(ValueError, match="altitude needs the ENU origin"):
        tk.crlb(MeasurementSet.from_si(*columns, meas.sensor_state, meas.time_ref,
                                       meas.ref_sensor_state), scn.motion, scn.theta)
    moved = meas.sensor_state.copy()
    moved[meas.kind == "altitude", 0] = 5.0
    with pytest.raises(ValueError, match="ENU origin"):
        MeasurementSet.from_si(*columns, moved, meas.time_ref, meas.ref_sensor_state,
                               dict(meas.metadata))
