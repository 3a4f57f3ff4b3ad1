"""The per-fit set-up made without passes over the rows equals what the passes gave.

Rows grouped by kind from the kind codes (ObservationModel), the angle facts from the kinds'
slices (VarProProblem), the affine rows' offset made by blocks of rows, broadcast columns
taken as slices, and the data part without nuisance not copied.
"""

from __future__ import annotations

import numpy as np
import pytest

import tmakit as tk
from tmakit.batch.solver import VarProProblem
from tmakit.core.arrays import take_rows
from tmakit.motion import ConstantVelocity
from tmakit.observation import ObservationModel
from tmakit.observation import affine_rows as ar
from tmakit.observation.rows import as_slice


def _sets() -> list[tuple[tk.MeasurementSet, object, dict]]:
    """Sets of one kind, of kinds in blocks, interleaved and shuffled, with their motion."""
    out = []
    for name in ("bearings-only-2d", "gu2007", "chen-sun-1", "hurtado2008"):
        scn = tk.load_scenario(name)
        meas = scn.simulate(np.random.default_rng(2))
        blocks = meas.take(np.argsort(meas.kind_code, kind="stable"))
        shuffled = meas.take(np.random.default_rng(3).permutation(len(meas)))
        for m in (meas, blocks, shuffled):
            out.append((m, scn.motion, scn.measurement_options))
    return out


@pytest.mark.parametrize("case", range(12))
def test_grouping_from_kind_codes_equals_the_kind_masks(case):
    meas, motion, options = _sets()[case]
    obs = ObservationModel(meas, motion, options)
    rows = {k: np.flatnonzero(meas.kind_mask(k)) for k in meas.kinds}
    order = np.concatenate([rows[k] for k in meas.kinds])
    assert list(obs.slices) == list(obs.models) == meas.kinds
    for k in meas.kinds:
        assert np.array_equal(obs.rows[k], rows[k])
        assert np.array_equal(order[obs.slices[k]], rows[k])
    assert np.array_equal(obs.order, order)
    assert obs.in_set_order == np.array_equal(order, np.arange(order.size))
    assert np.array_equal(obs.inverse, np.argsort(order))
    assert obs.grouped.equals(meas.take(order))
    # a subset groups its rows the same way
    idx = np.sort(np.random.default_rng(case).choice(len(meas), len(meas) // 2, replace=False))
    sub, fresh = obs.take(idx), ObservationModel(meas.take(idx), motion, options)
    assert sub.slices == fresh.slices and sub.in_set_order == fresh.in_set_order
    assert np.array_equal(sub.order, fresh.order)
    assert np.array_equal(sub.inverse, fresh.inverse)


def test_taking_no_rows_gives_the_model_of_an_empty_set():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(1))
    sub = ObservationModel(meas, scn.motion).take(np.zeros(0, dtype=np.intp))
    assert len(sub.meas) == 0 and sub.slices == {} and sub.order.size == 0


@pytest.mark.parametrize("case", range(12))
def test_angle_facts_from_the_kinds_slices_equal_the_mask(case):
    meas, motion, options = _sets()[case]
    problem = VarProProblem(ObservationModel(meas, motion, options))
    angle = problem.obs.angle_mask_grouped
    assert problem.has_angle == bool(angle.any())
    assert problem.all_angle == bool(angle.all())
    run = as_slice(np.flatnonzero(angle))
    assert problem._angle_rows == (run if isinstance(run, slice) else None)


@pytest.mark.parametrize("m", [5, ar._SENSOR_BLOCK, 2 * ar._SENSOR_BLOCK + 7])
def test_offset_by_blocks_of_rows_equals_one_subtraction(m):
    rng = np.random.default_rng(m)
    sensor = rng.normal(0.0, 1e3, (m, 6))
    sensor[::5] = 0.0  # signed zeros: 0 - 0 and 0 - (-0) as one subtraction gives them
    sensor[1::5] = -0.0
    terms, zero = ConstantVelocity(2, ref_time=3.0).component_terms(rng.uniform(0, 99, m))
    assert zero.shape == (6, m) and not zero.flags.writeable and not np.any(zero)
    own = rng.normal(0.0, 1e3, (6, m))
    for base in (zero, own.copy()):
        want = base - sensor.T
        head = ar.AffineRows(terms, base, 4, sensor)._offset_head(2)
        offset = ar.AffineRows(terms, base, 4, sensor).offset
        assert head.flags.c_contiguous and offset.flags.c_contiguous
        assert head.tobytes() == want[:2].tobytes() and offset.tobytes() == want.tobytes()
    rows = rng.choice(m, max(1, m // 3))
    lazy = ar.AffineRows(terms, zero, 4, sensor)
    given = lazy.take(rows, sensor=sensor[rows])
    taken = lazy.take(rows)
    assert given.offset.tobytes() == taken.offset.tobytes()
    coefs = [c for _, _, c in given.terms if c is not None]
    assert coefs[0] is coefs[1]  # the shared coefficient gathered once
    assert np.array_equal(coefs[0], terms[1][2][rows])


def test_broadcast_column_rows_are_a_read_only_broadcast():
    column = np.broadcast_to(np.array([1.0, 2.0]), (10, 2))
    for rows in (np.array([3, 1, 4]), np.arange(25) % 10):
        out = take_rows(column, rows)
        assert out.shape == (rows.size, 2) and out.strides[0] == 0
        assert not out.flags.writeable and np.array_equal(out, column[rows])


def test_data_part_without_nuisance_is_the_data_when_it_may_be():
    scn = tk.load_scenario("bearings-only-2d")
    meas = scn.simulate(np.random.default_rng(4))
    problem = VarProProblem(ObservationModel(meas, scn.motion))
    nu = np.zeros((1, 0))
    y = meas.value_si[None].copy()
    assert problem.data_part(y, nu) is y
    read_only = np.broadcast_to(meas.value_si, (1, len(meas)))
    part = problem.data_part(read_only, nu)
    assert part is not read_only and part.flags.writeable and np.array_equal(part, read_only)
