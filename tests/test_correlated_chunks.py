"""Range differences with correlated noise: groups of overlapping spans, fitted in chunks."""

from __future__ import annotations

import functools
import importlib
import json

import numpy as np
import pytest

import tmakit as tk
from tmakit.data import MeasurementSet
from tmakit.measurements.range_difference import range_difference_covariance
from tmakit.motion import motion_from_name
from tmakit.observation import ObservationModel
from tmakit.observation.noise import NoiseModel
from tmakit.observation.rows import overlapping_groups


@functools.cache
def shared_reference_set(seed=2):
    """chen-sun-1 with each three range differences in a row sharing one reference time."""
    m = tk.load_scenario("chen-sun-1").simulate(rng=seed)
    rd = np.flatnonzero(np.asarray(m.kind) == "range_difference")
    first = rd[(np.arange(rd.shape[0]) // 3) * 3]  # the group's first difference
    time_ref, ref_state = m.time_ref.copy(), m.ref_sensor_state.copy()
    time_ref[rd], ref_state[rd] = m.time_ref[first], m.ref_sensor_state[first]
    value = np.asarray(m.value, dtype=float).copy()
    draft = MeasurementSet(m.time, m.sensor, m.kind, value, m.sigma, m.sensor_state, time_ref,
                           ref_state, m.metadata)
    motion = motion_from_name(m.metadata["motion"])
    truth = json.loads(m.metadata["truth"])
    theta = np.array([truth[k] for k in motion.param_names])
    rng = np.random.default_rng(seed)
    value[rd] = (ObservationModel(draft, motion).predict(theta)[rd]
                 + rng.normal(0.0, np.asarray(m.sigma)[rd]))
    return MeasurementSet(m.time, m.sensor, m.kind, value, m.sigma, m.sensor_state, time_ref,
                          ref_state, m.metadata)


def test_groups_are_the_rows_whose_spans_overlap():
    time = np.array([1.0, 2.0, 3.0, 5.0, 6.0, 9.0, 4.0])
    time_ref = np.array([0.0, 0.0, 2.5, 3.0, 5.5, 8.0, 3.0])
    groups = [g.tolist() for g in overlapping_groups(np.arange(7), time, time_ref)]
    # (0,1] and (0,2] share (0,1]; (2.5,3] touches neither (3,5] nor (3,4] nor (0,2]
    assert groups == [[0, 1], [2], [3, 6], [4], [5]]
    assert [g.tolist() for g in overlapping_groups(np.arange(7), time, time_ref, False)] == [
        [0, 1], [3, 6]]


def test_the_noise_blocks_are_the_groups_and_whiten_as_the_dense_covariance():
    meas = shared_reference_set()
    noise = NoiseModel(meas)
    assert {len(rows) for rows, _ in noise.blocks} == {3}
    rd = np.flatnonzero(np.asarray(meas.kind) == "range_difference")
    dense = np.diag(meas.sigma_si**2)  # the one block of the sensor, as before the groups
    dense[np.ix_(rd, rd)] = range_difference_covariance(meas.time[rd], meas.time_ref[rd],
                                                        meas.sigma_si[rd])
    assert np.count_nonzero(dense - np.diag(np.diag(dense))) == 6 * len(noise.blocks)
    np.testing.assert_allclose(noise.covariance(), dense, rtol=1e-9, atol=1e-12 * dense.max())
    bounds = noise.chunk_bounds(10)
    assert bounds[0][0] == 0 and bounds[-1][1] == len(meas)
    for rows, _ in noise.blocks:  # no chunk splits a block
        assert sum(lo <= rows[0] < hi for lo, hi in bounds) == 1
        assert all(not (lo <= rows[0] < hi) or rows[-1] < hi for lo, hi in bounds)


def test_a_correlated_fit_summed_by_chunks_equals_the_whole_jacobians(monkeypatch):
    from tmakit.core import blas

    meas = shared_reference_set()
    whole = tk.estimate(meas, "cv3d")
    monkeypatch.setattr(blas, "CHUNKED_ROWS", 100)  # these few rows count as many
    monkeypatch.setattr(blas, "CHUNK_ROWS", 37)  # cuts fall inside blocks: moved past them
    assert any(hi - lo != 37 for lo, hi in NoiseModel(meas).chunk_bounds(37)[:-1])
    chunked = tk.estimate(meas, "cv3d")
    assert chunked.status == whole.status == "converged"
    assert chunked.iterations == whole.iterations
    assert np.all(np.abs(chunked.estimate - whole.estimate) <= 1e-9 * whole.std)
    np.testing.assert_allclose(chunked.std, whole.std, rtol=1e-9)
    assert chunked.chi2 == pytest.approx(whole.chi2, rel=1e-12)


def test_the_command_fits_a_large_set_grouped_by_kind_with_the_same_result(tmp_path,
                                                                          monkeypatch):
    from typer.testing import CliRunner

    from tmakit.cli import app
    from tmakit.core import blas
    from tmakit.io import write_measurements

    cli_estimate = importlib.import_module("tmakit.cli.estimate")  # the module, not the command

    meas = shared_reference_set()
    path = tmp_path / "rd.csv"
    write_measurements(meas, path)
    monkeypatch.setattr(blas, "CHUNKED_ROWS", 100)  # these few rows count as many
    monkeypatch.setattr(blas, "CHUNK_ROWS", 37)
    grouped = cli_estimate.grouped_by_kind(meas)
    codes = grouped.kind_code
    assert len(grouped) == len(meas) and np.all(codes[1:] >= codes[:-1])
    assert not np.array_equal(codes, meas.kind_code)  # the file's kinds alternate
    args = ["estimate", str(path), "--motion", "cv3d", "--json"]
    regrouped = CliRunner().invoke(app, args)
    monkeypatch.setattr(cli_estimate, "grouped_by_kind", lambda m: m)  # the file's order
    in_file_order = CliRunner().invoke(app, args)
    assert regrouped.exit_code == in_file_order.exit_code == 0, regrouped.output
    assert json.loads(regrouped.stdout) == json.loads(in_file_order.stdout)


def test_a_subset_of_correlated_rows_keeps_their_covariance():
    from tmakit.batch.init import subsample
    from tmakit.batch.varpro import VarProProblem

    meas = shared_reference_set()
    problem = VarProProblem(ObservationModel(meas, motion_from_name("cv3d")))
    assert problem.noise.correlated
    small, rows = subsample(problem, 150)  # for the grid and the presolve
    assert small is not problem and len(rows) < len(meas)
    sub = small.obs.grouped
    rd = np.flatnonzero(np.asarray(sub.kind) == "range_difference")
    dense = np.diag(sub.sigma_si**2)
    dense[np.ix_(rd, rd)] = range_difference_covariance(sub.time[rd], sub.time_ref[rd],
                                                        sub.sigma_si[rd])
    assert np.count_nonzero(dense - np.diag(np.diag(dense))) > 0  # still correlated
    np.testing.assert_allclose(small.noise.covariance(), dense, rtol=1e-9,
                               atol=1e-12 * dense.max())


def test_batched_whiteners_are_each_blocks_own_decomposition_bit_for_bit():
    """Blocks of one size are decomposed together; each equals its own eigh (of the block over
    its rows' sigmas), singular ones too."""
    rng = np.random.default_rng(1)
    blocks, m = [], 0
    for k in range(120):
        b = int(rng.integers(1, 6))
        t = np.sort(rng.uniform(0.0, 10.0, b)) + 20.0
        t_ref = t - rng.choice([0.5, 1.0, 2.5, 6.0], b)
        cov = range_difference_covariance(t, t_ref, rng.uniform(0.5, 2.0, b))
        if k % 11 == 0 and b >= 2:  # a repeated combination: a singular block
            v = rng.normal(size=(b, b - 1))
            cov = v @ v.T
        blocks.append((np.arange(m, m + b), cov))
        m += b
    sigma = np.concatenate([np.sqrt(np.diag(c)) for _, c in blocks])
    noise = NoiseModel.independent(sigma)
    noise._setup(sigma, blocks)
    expected, rank = {}, m
    for rows, cov in blocks:
        if np.count_nonzero(cov - np.diag(np.diag(cov))) == 0:
            continue
        inv = 1.0 / sigma[rows]  # decomposed over the rows' sigmas (scale-free)
        evals, evecs = np.linalg.eigh(cov * inv[:, None] * inv[None, :])
        keep = evals > 1e-10 * evals.max()
        w = np.zeros((rows.size, rows.size))
        w[: keep.sum()] = (evecs[:, keep] / np.sqrt(evals[keep])).T
        w *= inv[None, :]
        expected[int(rows[0])] = w
        rank -= int(rows.size - keep.sum())
    got = {int(rows[0]): w for rows, w in noise.blocks}
    assert got.keys() == expected.keys()
    assert all(np.array_equal(got[k], expected[k]) for k in expected)
    assert noise.rank == rank < m
