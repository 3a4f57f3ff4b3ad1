"""The sensor state at time_ref, looked up in bounded memory, equals the whole track's."""

from __future__ import annotations

import numpy as np
import pytest

from tmakit.io import checker
from tmakit.io.checker import SensorRecord
from tmakit.sensors import RecordedTrack


def sensor_rows(n, rng, repeat=True):
    """Times (some repeated), states of a sensor on a curved path (m, m/s)."""
    t = np.cumsum(rng.uniform(0.5, 2.0, n))
    if repeat:
        t[5::7] = t[4::7][: t[5::7].shape[0]]  # a time given twice (the first row counts)
    state = np.column_stack([100 * np.sin(t / 30), 80 * np.cos(t / 20), 0.1 * t,
                             np.cos(t / 30) * 10 / 3, -4 * np.sin(t / 20), np.full(n, 0.1)])
    return t, state


def whole_track_states(t, state, tr, has_velocity):
    """The states the whole track gives (one row per distinct time, the first)."""
    times, first = np.unique(t, return_index=True)
    out = np.full((tr.shape[0], 6), np.nan)
    at = np.clip(np.searchsorted(times, tr), 0, times.shape[0] - 1)
    found = times[at] == tr
    out[found] = state[first[at[found]]]
    track = RecordedTrack(times, state[first, :3], state[first, 3:] if has_velocity else None)
    out[~found] = track.states(tr[~found])
    if not has_velocity:
        out[~found, 3:] = 0.0
    return out


@pytest.mark.parametrize("has_velocity", [True, False], ids=["hermite", "spline"])
@pytest.mark.parametrize("shuffled", [False, True], ids=["in-order", "out-of-order"])
def test_the_bounded_lookup_equals_the_whole_tracks_bit_for_bit(has_velocity, shuffled,
                                                                 monkeypatch):
    monkeypatch.setattr(checker, "QUERY_ROWS", 16)  # many blocks of queries
    rng = np.random.default_rng(5)
    t, state = sensor_rows(300, rng)
    if shuffled:
        order = rng.permutation(t.shape[0])
        t, state = t[order], state[order]
    # times at rows, between rows, and outside the record
    tr = np.concatenate([t[rng.integers(0, 300, 60)],
                         rng.uniform(t.min(), t.max(), 200), [t.min() - 1, t.max() + 1]])
    n = tr.shape[0]
    ref = np.full((n + 5, 6), np.nan)
    rows = np.arange(5, n + 5)
    time_ref = np.concatenate([np.zeros(5), tr])
    missing = SensorRecord(t, state, None, has_velocity).fill(rows, time_ref, ref)
    assert missing.tolist() == [False] * (n - 2) + [True, True]
    want = whole_track_states(t, state, tr[:-2], has_velocity)
    assert np.array_equal(ref[5:-2], want)
    assert np.isnan(ref[:5]).all() and np.isnan(ref[-2:]).all()


def test_only_the_sensors_own_rows_are_used():
    rng = np.random.default_rng(7)
    t, state = sensor_rows(100, rng, repeat=False)
    other = state + 1e4  # another sensor's rows, interleaved
    t2 = np.repeat(t, 2)
    both = np.empty((200, 6))
    both[0::2], both[1::2] = state, other
    mine = np.arange(0, 200, 2)
    tr = rng.uniform(t[0], t[-1], 50)
    ref = np.full((50, 6), np.nan)
    missing = SensorRecord(t2, both, mine, True).fill(np.arange(50), tr, ref)
    assert not missing.any()
    assert np.array_equal(ref, whole_track_states(t, state, tr, True))
