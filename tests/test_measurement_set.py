"""MeasurementSet holds SI values converted once and integer codes for kind and sensor."""

from __future__ import annotations

import pickle
import re

import numpy as np
import pytest

from tmakit.data import KIND_NAMES, MeasurementSet
from tmakit.measurements import KINDS


def mixed_set() -> MeasurementSet:
    kinds = ["bearing", "power", "frequency", "bearing", "range_rate", "power"]
    sensors = ["b", "b", "a", "a", "a", "c"]
    n = len(kinds)
    return MeasurementSet([0, 1, 0, 1, 2, 0], sensors, kinds, [350.0, -60, 9e9, 10, 3, -70],
                          [1.0, 2, 5, 0.5, 0.1, 2], np.zeros((n, 6)))


def test_si_is_file_value_times_scale_plus_offset():
    ms = mixed_set()
    for i, k in enumerate(ms.kind):
        model = KINDS[str(k)]
        assert ms.value_si[i] == ms.value[i] * model.file_scale + model.file_offset
        assert ms.sigma_si[i] == ms.sigma[i] * model.file_scale


def test_codes_and_their_text_views():
    ms = mixed_set()
    assert ms.kinds == ["bearing", "range_rate", "frequency", "power"]
    assert ms.sensors == ["b", "a", "c"]
    assert [KIND_NAMES[c] for c in ms.kind_code] == ms.kind.tolist()
    assert [ms.sensor_names[c] for c in ms.sensor_code] == ms.sensor.tolist()
    assert np.array_equal(ms.kind == "power", ms.kind_mask("power"))
    assert not ms.kind_mask("range").any() and not ms.sensor_mask("zz").any()
    sub = ms.take(np.array([5, 2, 3]))
    assert sub.sensors == ["c", "a"] and sub.kinds == ["bearing", "frequency", "power"]
    assert sub.select(sensor="a").kind.tolist() == ["frequency", "bearing"]
    assert ms.sorted().sensor.tolist() == ["b", "b", "a", "a", "a", "c"]


def test_values_are_read_only_and_assignment_recomputes_si():
    ms = mixed_set()
    for arr in (ms.value, ms.sigma, ms.value_si, ms.sigma_si, ms.take([0, 1]).value):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
    ms.value = ms.value + 1.0
    assert ms.value_si[0] == pytest.approx(np.radians(351.0))
    ms.kind = ["range"] * len(ms)
    assert ms.kinds == ["range"] and ms.value_si[0] == ms.value[0]
    ms.sensor = ["z"] * len(ms)
    assert ms.sensors == ["z"]
    with pytest.raises(ValueError, match="column 'value' has 2 rows"):
        ms.value = [1.0, 2.0]


def test_unknown_kind_and_pickling():
    with pytest.raises(ValueError, match="unknown measurement kind"):
        MeasurementSet([0], ["a"], ["bearng"], [1], [1], np.zeros((1, 6)))
    ms = mixed_set()
    back = pickle.loads(pickle.dumps(ms))
    assert back.equals(ms) and not back.value.flags.writeable


def test_empty_set():
    ms = MeasurementSet([], [], [], [], [], np.zeros((0, 6)))
    assert ms.kinds == [] and ms.sensors == [] and len(ms.sorted()) == 0


def test_from_si_holds_si_exactly_and_derives_file_units():
    value_si = np.array([0.1, 1234.5, -7.0])
    sigma_si = np.array([0.01, 2.0, 0.5])
    ms = MeasurementSet.from_si([0, 1, 2], ["a", "a", "a"], ["bearing", "range", "power"],
                                value_si, sigma_si, np.zeros((3, 6)))
    assert np.array_equal(ms.value_si, value_si) and np.array_equal(ms.sigma_si, sigma_si)
    assert np.allclose(ms.value, [np.degrees(0.1), 1234.5, -7.0 + 30.0], rtol=1e-14)
    assert np.allclose(ms.sigma, [np.degrees(0.01), 2.0, 0.5], rtol=1e-14)
    assert np.array_equal(ms.take([2, 0]).value_si, value_si[[2, 0]])
    joined = MeasurementSet.concatenate([ms, ms.take([1])])
    assert np.array_equal(joined.value_si, value_si[[0, 1, 1, 2]])
    with pytest.raises(ValueError, match="value"):
        MeasurementSet.from_si([0], ["a"], ["range"], [1.0, 2.0], [1.0], np.zeros((1, 6)))


@pytest.mark.filterwarnings("ignore:overflow encountered")  # 1e307 rad in degrees
@pytest.mark.parametrize("column, bad, message", [
    ("value_si", np.nan, "row 2, column 'value': expected a finite number, found nan"),
    ("value_si", 1e307, "row 2, column 'value': expected a finite number, found inf"),
    ("sigma_si", 0.0, "row 2, column 'sigma': expected a noise standard deviation > 0"),
    ("sigma_si", -np.inf, "row 2, column 'sigma': expected a finite number, found -inf")])
def test_a_set_built_in_si_is_refused_with_the_file_unit_cell(column, bad, message):
    """A set built in SI is refused with the message of its cell in file units."""
    cols = {"value_si": np.array([0.1, 0.2, 0.3]), "sigma_si": np.full(3, 0.01)}
    MeasurementSet.from_si([0, 1, 2], ["a"] * 3, ["bearing"] * 3, cols["value_si"],
                           cols["sigma_si"], np.zeros((3, 6)))
    cols[column][1] = bad
    with pytest.raises(ValueError, match=re.escape(message)):
        MeasurementSet.from_si([0, 1, 2], ["a"] * 3, ["bearing"] * 3, cols["value_si"],
                               cols["sigma_si"], np.zeros((3, 6)))


def test_a_blank_sensor_id_is_refused_as_a_file_refuses_its_empty_cell():
    """A set with sensor '' was built (and written by tma import), then its file refused."""
    with pytest.raises(ValueError, match=re.escape(
            "row 2, column 'sensor': expected a sensor id (text), found ' '")):
        MeasurementSet.from_si([0, 1], ["a", " "], ["bearing"] * 2, [0.1, 0.2], [0.01, 0.01],
                               np.zeros((2, 6)))
