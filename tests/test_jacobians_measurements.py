"""Measurement models: analytic Jacobians against finite differences, vectorisation, conventions.

Finite differences.  Every variable has a scale: the horizontal range for a position component,
300 m/s for a velocity component, the carrier for the carrier, 0.1 Hz/s for the carrier drift,
10 dB for the power constant and 1 for the path-loss exponent.  The step is ``REL_STEP`` times
that scale and the central difference is Richardson-extrapolated (steps h and h/2), so the
truncation error is O((h/scale)^4) ~ 1e-12 and the rounding error about
``eps |value| / REL_STEP`` per unit of scale.

Comparison.  Both Jacobians are multiplied by the variable scales (so every column is "change
of the value per typical change of that variable", in the value's own unit) and must agree, row
by row, within ``RTOL`` times the largest scaled entry of the row plus a floor of
``ROUNDING_FLOOR`` times the rounding level ``eps |value| / REL_STEP``.  The relative state is
compared as one block; each nuisance parameter is compared on its own (their units differ and
the carrier column would otherwise swamp the drift column).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tmakit.core.frames import wrap_angle
from tmakit.core.units import SPEED_OF_LIGHT
from tmakit.measurements import (
    Altitude,
    AzimuthRate,
    Bearing,
    Elevation,
    Fdoa,
    Frequency,
    MeasurementModel,
    Power,
    Range,
    RangeDifference,
    RangeRate,
    Tdoa,
)

EPS = np.finfo(float).eps
REL_STEP = 1e-3
RTOL = 1e-6
ROUNDING_FLOOR = 20.0
VELOCITY_SCALE = 300.0  # m/s
DRIFT_SCALE = 0.1  # Hz/s
POWER_CONSTANT_SCALE = 10.0  # dB
EXPONENT_SCALE = 1.0

HYPOTHESIS = settings(max_examples=60, deadline=None)


# --------------------------------------------------------------------------------------------
# finite differences and the comparison
# --------------------------------------------------------------------------------------------


def numerical_jacobian(f, x: np.ndarray, scale: np.ndarray, angle: bool = False) -> np.ndarray:
    """d f / d x by Richardson-extrapolated central differences.

    ``f`` maps ``x`` of shape ``(..., m)`` to values of shape ``(...)`` row by row;
    ``scale`` (broadcastable to ``x``) sets the step ``REL_STEP * scale``.  With ``angle``
    the differences are wrapped to (-pi, pi].  Returns ``(..., m)``.
    """
    x = np.asarray(x, dtype=float)
    scale = np.broadcast_to(np.asarray(scale, dtype=float), x.shape)
    out = np.empty(x.shape)
    for j in range(x.shape[-1]):

        def central(h, j=j):
            step = np.zeros(x.shape)
            step[..., j] = h
            diff = f(x + step) - f(x - step)
            return (wrap_angle(diff) if angle else diff) / (2.0 * h)

        h = REL_STEP * scale[..., j]
        out[..., j] = (4.0 * central(h / 2.0) - central(h)) / 3.0
    return out


def assert_jacobian_close(analytic, numeric, scale, value_magnitude, what=""):
    """Compare Jacobians ``(..., m)`` after scaling their columns by ``scale``.

    The tolerance of a row is ``RTOL * max |scaled analytic row|`` plus
    ``ROUNDING_FLOOR * eps * |value| / REL_STEP`` (the rounding level of the differences).
    """
    analytic = np.asarray(analytic, dtype=float)
    numeric = np.asarray(numeric, dtype=float)
    assert analytic.shape == numeric.shape, (what, analytic.shape, numeric.shape)
    a = analytic * scale
    n = numeric * scale
    row_max = np.max(np.abs(a), axis=-1, keepdims=True)
    floor = ROUNDING_FLOOR * EPS * np.abs(np.asarray(value_magnitude))[..., None] / REL_STEP
    tol = np.broadcast_to(RTOL * row_max + floor, a.shape)
    err = np.abs(a - n)
    bad = ~(err <= tol)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise AssertionError(
            f"{what}: Jacobian mismatch at {idx}: analytic {analytic[idx]!r}, "
            f"numeric {numeric[idx]!r} (scaled error {err[idx]:.3e} > tolerance "
            f"{tol[idx]:.3e}); {int(bad.sum())} of {bad.size} entries differ"
        )


# --------------------------------------------------------------------------------------------
# geometries and measurement kinds
# --------------------------------------------------------------------------------------------


def signed_magnitude(lo: float, hi: float) -> st.SearchStrategy[float]:
    """A value with |value| log-uniform in [lo, hi] and either sign."""
    mag = st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0**e)
    return st.tuples(st.sampled_from([-1.0, 1.0]), mag).map(lambda sm: sm[0] * sm[1])


POSITION = signed_magnitude(100.0, 50e3)
VELOCITY = st.floats(-VELOCITY_SCALE, VELOCITY_SCALE)


def relative_state(dz: st.SearchStrategy[float]) -> st.SearchStrategy[tuple[float, ...]]:
    """[dx, dy, dz, dvx, dvy, dvz] with |dx|, |dy| in 100 m .. 50 km (horizontal range
    >= 141 m)."""
    return st.tuples(POSITION, POSITION, dz, VELOCITY, VELOCITY, VELOCITY)


GENERAL_DZ = st.one_of(st.just(0.0), POSITION)
MODERATE_DZ = st.floats(-5e3, 5e3)


@st.composite
def geometries(draw, dz=GENERAL_DZ, max_samples=4):
    """(rel, rel_ref, t): n samples of relative states, reference states and times."""
    n = draw(st.integers(1, max_samples))
    rows = st.lists(relative_state(dz), min_size=n, max_size=n)
    rel = np.array(draw(rows))
    rel_ref = np.array(draw(rows))
    t = np.array(draw(st.lists(st.floats(0.0, 1000.0), min_size=n, max_size=n)))
    return rel, rel_ref, t


CARRIER = st.floats(6.0, 10.0).map(lambda e: 10.0**e)
DRIFT = st.floats(-DRIFT_SCALE, DRIFT_SCALE)
POWER_CONSTANT = st.floats(-60.0, 10.0)
EXPONENT = st.floats(1.5, 4.0)


class Case:
    """A measurement model with its nuisance strategy and nuisance scales."""

    def __init__(self, name, model, nuisance=(), nuisance_scale=(), dz=GENERAL_DZ):
        self.name = name
        self.model: MeasurementModel = model
        self.nuisance = st.tuples(*nuisance)  # a tuple of strategies, one per parameter
        self.nuisance_scale = nuisance_scale
        self.dz = dz

    def __repr__(self):
        return self.name

    def nuisance_scales(self, nu: np.ndarray) -> np.ndarray:
        """Per-parameter scale: the typical size, or the value itself if larger."""
        return np.maximum(np.abs(nu), np.asarray(self.nuisance_scale, dtype=float))


CASES = [
    Case("bearing", Bearing()),
    Case("elevation", Elevation(), dz=MODERATE_DZ),
    Case("azimuth_rate", AzimuthRate()),
    Case("range", Range()),
    Case("range_rate", RangeRate()),
    Case("frequency", Frequency(drift=False), (CARRIER,), (1.0,)),
    Case("frequency_drift", Frequency(drift=True), (CARRIER, DRIFT), (1.0, DRIFT_SCALE)),
    Case("power_n2", Power(exponent=2.0), (POWER_CONSTANT,), (POWER_CONSTANT_SCALE,)),
    Case("power_free_n", Power(exponent=None), (POWER_CONSTANT, EXPONENT),
         (POWER_CONSTANT_SCALE, EXPONENT_SCALE)),
    Case("range_difference", RangeDifference()),
    Case("tdoa", Tdoa()),
    Case("fdoa_known_carrier", Fdoa(carrier=2.4e9)),
    Case("fdoa", Fdoa(), (CARRIER,), (1.0,)),
    Case("altitude", Altitude(origin=(52.0, 4.0, 30.0))),
]
CASE_IDS = [c.name for c in CASES]


def nuisance_arg(nu: np.ndarray):
    """Models without nuisance parameters get None, like callers give them."""
    return nu if nu.size else None


def state_scale(rel: np.ndarray) -> np.ndarray:
    """Scale of each relative-state component: horizontal range (positions), 300 m/s."""
    rho = np.hypot(rel[..., 0], rel[..., 1])[..., None]
    return np.concatenate([np.repeat(rho, 3, axis=-1),
                           np.full((*rel.shape[:-1], 3), VELOCITY_SCALE)], axis=-1)


def check_case_jacobians(case: Case, rel, rel_ref, t, nu, jac=None):
    """All analytic Jacobian blocks of ``case`` against finite differences."""
    model = case.model
    nu_arg = nuisance_arg(nu)
    if jac is None:
        jac = model.jacobian(rel, t, nu_arg, rel_ref)
    value = model.predict(rel, t, nu_arg, rel_ref)
    assert np.all(np.isfinite(value))

    num = numerical_jacobian(lambda x: model.predict(x, t, nu_arg, rel_ref), rel,
                             state_scale(rel), angle=model.is_angle)
    assert_jacobian_close(jac.rel, num, state_scale(rel), value, f"{case} d/d rel")

    if model.uses_reference:
        assert jac.rel_ref is not None
        num_ref = numerical_jacobian(lambda x: model.predict(rel, t, nu_arg, x), rel_ref,
                                     state_scale(rel_ref))
        assert_jacobian_close(jac.rel_ref, num_ref, state_scale(rel_ref), value,
                              f"{case} d/d rel_ref")
    else:
        assert jac.rel_ref is None

    k = len(model.nuisance_names)
    assert jac.nuisance.shape == (*value.shape, k)
    if k:
        # nuisance broadcasts to (n, k): perturbing row i of an (n, k) copy moves sample i only
        nu_rows = np.broadcast_to(nu, (*value.shape, k)).copy()
        num_nu = numerical_jacobian(lambda x: model.predict(rel, t, x, rel_ref), nu_rows,
                                    case.nuisance_scales(nu))
        # nuisance parameters have different units: compare each column on its own
        for j, name in enumerate(model.nuisance_names):
            assert_jacobian_close(jac.nuisance[..., j:j + 1], num_nu[..., j:j + 1],
                                  case.nuisance_scales(nu)[j], value, f"{case} d/d {name}")


# --------------------------------------------------------------------------------------------
# Jacobians against finite differences
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES, ids=CASE_IDS)
@HYPOTHESIS
@given(data=st.data())
def test_jacobian_matches_finite_differences(case: Case, data):
    rel, rel_ref, t = data.draw(geometries(dz=case.dz), label="geometry")
    nu = np.array(data.draw(case.nuisance, label="nuisance"), dtype=float)
    check_case_jacobians(case, rel, rel_ref, t, nu)


def _fixed_geometry():
    rel = np.array([[1200.0, -3500.0, 400.0, 35.0, -120.0, 3.0],
                    [-25e3, 8e3, 0.0, -250.0, 40.0, 0.0],
                    [300.0, 150.0, -2e3, 10.0, 290.0, -5.0]])
    rel_ref = np.array([[900.0, -3000.0, 300.0, 30.0, -100.0, 1.0],
                        [-20e3, 7e3, 0.0, -240.0, 30.0, 0.0],
                        [250.0, 180.0, -1.9e3, 12.0, 280.0, -4.0]])
    t = np.array([0.0, 125.0, 980.0])
    return rel, rel_ref, t


FIXED_NUISANCE = {
    "frequency": [2.4e9],
    "frequency_drift": [9.5e9, -0.07],
    "power_n2": [-35.0],
    "power_free_n": [-12.0, 3.1],
    "fdoa": [1.2e9],
}


@pytest.mark.parametrize("case", CASES, ids=CASE_IDS)
def test_comparison_detects_wrong_jacobians(case: Case):
    """The comparison must be able to fail: a sign flip, or one entry off by 0.1 %, of any
    block of any kind is detected, while the correct Jacobian passes."""
    rel, rel_ref, t = _fixed_geometry()
    nu = np.array(FIXED_NUISANCE.get(case.name, []), dtype=float)
    jac = case.model.jacobian(rel, t, nuisance_arg(nu), rel_ref)
    check_case_jacobians(case, rel, rel_ref, t, nu, jac)

    blocks = ["rel", "nuisance"] + (["rel_ref"] if case.model.uses_reference else [])
    for block in blocks:
        good = getattr(jac, block)
        if good.shape[-1] == 0:
            continue
        flipped = type(jac)(**{**vars(jac), block: -good})
        with pytest.raises(AssertionError, match="Jacobian mismatch"):
            check_case_jacobians(case, rel, rel_ref, t, nu, flipped)
        # the largest scaled entry of the last row, off by 0.1 %
        scale = (case.nuisance_scales(nu) if block == "nuisance"
                 else state_scale(rel if block == "rel" else rel_ref))
        scaled = np.abs(good * scale)
        j = int(np.argmax(scaled[-1]))
        nudged = good.copy()
        nudged[-1, j] *= 1.001
        off = type(jac)(**{**vars(jac), block: nudged})
        with pytest.raises(AssertionError, match="Jacobian mismatch"):
            check_case_jacobians(case, rel, rel_ref, t, nu, off)


def test_comparison_helper_flags_sign_error_directly():
    """The helper itself: a bearing Jacobian with its sign flipped fails, the right one
    passes."""
    rel = np.array([[3000.0, 4000.0, 0.0, 0.0, 0.0, 0.0]])
    model = Bearing()
    num = numerical_jacobian(lambda x: model.predict(x), rel, state_scale(rel))
    good = model.jacobian(rel).rel
    value = model.predict(rel)
    assert_jacobian_close(good, num, state_scale(rel), value)
    # d bearing / d (dx, dy) = (dy, -dx) / rho^2
    np.testing.assert_allclose(good[0, :2], [4000.0 / 25e6, -3000.0 / 25e6], rtol=1e-15)
    with pytest.raises(AssertionError, match="Jacobian mismatch"):
        assert_jacobian_close(-good, num, state_scale(rel), value)


# --------------------------------------------------------------------------------------------
# vectorisation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES, ids=CASE_IDS)
@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_batch_equals_per_sample(case: Case, data):
    model = case.model
    B = data.draw(st.integers(1, 3), label="B")
    n = data.draw(st.integers(1, 4), label="n")
    rel = np.empty((B, n, 6))
    rel_ref = np.empty((B, n, 6))
    t = np.array(data.draw(st.lists(st.floats(0.0, 1000.0), min_size=n, max_size=n)))
    for b in range(B):
        rows = st.lists(relative_state(case.dz), min_size=n, max_size=n)
        rel[b] = data.draw(rows)
        rel_ref[b] = data.draw(rows)
    k = len(model.nuisance_names)
    nu_b = np.array([data.draw(case.nuisance) for _ in range(B)], dtype=float).reshape(B, k)

    # one nuisance vector (k,) shared by the batch, and one per batch member (B, 1, k)
    for shared in (True, False):
        nu_arg = nuisance_arg(nu_b[0]) if shared else nuisance_arg(nu_b[:, None, :])
        value = model.predict(rel, t, nu_arg, rel_ref)
        jac = model.jacobian(rel, t, nu_arg, rel_ref)
        assert value.shape == (B, n)
        assert jac.rel.shape == (B, n, 6)
        assert jac.nuisance.shape == (B, n, k)
        if model.uses_reference:
            assert jac.rel_ref.shape == (B, n, 6)
        else:
            assert jac.rel_ref is None
        for b in range(B):
            nu_one = nuisance_arg(nu_b[0] if shared else nu_b[b])
            one = model.predict(rel[b], t, nu_one, rel_ref[b])
            jac_one = model.jacobian(rel[b], t, nu_one, rel_ref[b])
            np.testing.assert_allclose(value[b], one, rtol=1e-14, atol=0)
            np.testing.assert_allclose(jac.rel[b], jac_one.rel, rtol=1e-14, atol=1e-300)
            np.testing.assert_allclose(jac.nuisance[b], jac_one.nuisance, rtol=1e-14,
                                       atol=1e-300)
            if model.uses_reference:
                np.testing.assert_allclose(jac.rel_ref[b], jac_one.rel_ref, rtol=1e-14,
                                           atol=1e-300)
            for i in range(n):
                sl = slice(i, i + 1)
                single = model.predict(rel[b, sl], t[sl], nu_one, rel_ref[b, sl])
                jac_single = model.jacobian(rel[b, sl], t[sl], nu_one, rel_ref[b, sl])
                assert single.shape == (1,)
                np.testing.assert_allclose(value[b, i], single[0], rtol=1e-14, atol=0)
                np.testing.assert_allclose(jac.rel[b, i], jac_single.rel[0], rtol=1e-14,
                                           atol=1e-300)
                np.testing.assert_allclose(jac.nuisance[b, i], jac_single.nuisance[0],
                                           rtol=1e-14, atol=1e-300)


# --------------------------------------------------------------------------------------------
# conventions
# --------------------------------------------------------------------------------------------


def _state(dx, dy, dz=0.0, dvx=0.0, dvy=0.0, dvz=0.0):
    return np.array([[dx, dy, dz, dvx, dvy, dvz]])


def test_bearing_clockwise_from_north():
    b = Bearing()
    assert b.predict(_state(0.0, 5000.0))[0] == 0.0  # due North
    assert b.predict(_state(5000.0, 0.0))[0] == pytest.approx(np.pi / 2, abs=1e-15)  # East
    assert b.predict(_state(-5000.0, 0.0))[0] == pytest.approx(-np.pi / 2, abs=1e-15)  # West
    assert b.predict(_state(0.0, -5000.0))[0] == pytest.approx(np.pi, abs=1e-15)  # South
    assert b.predict(_state(3000.0, 3000.0))[0] == pytest.approx(np.pi / 4, abs=1e-15)  # NE
    # the sensor position does not matter, only target minus sensor
    assert Elevation().predict(_state(3000.0, 4000.0, 5000.0))[0] == pytest.approx(np.pi / 4)
    assert Elevation().predict(_state(3000.0, 4000.0, -5000.0))[0] == pytest.approx(-np.pi / 4)


def _richardson_time_derivative(f, t0: float, h: float) -> float:
    def central(h):
        return (f(t0 + h) - f(t0 - h)) / (2.0 * h)

    return (4.0 * central(h / 2.0) - central(h)) / 3.0


@HYPOTHESIS
@given(state=relative_state(GENERAL_DZ))
def test_azimuth_rate_is_time_derivative_of_bearing(state):
    """Along a constant-velocity relative trajectory rel(s) = p + v s, at s = 0."""
    s = np.array(state)
    p, v = s[:3], s[3:]

    def rel_at(s):
        return np.concatenate([p + v * s, v])[None, :]

    # steps over which the line of sight turns / the range changes by about 1e-3 (relative)
    rho, v_h = np.hypot(p[0], p[1]), max(np.hypot(v[0], v[1]), 1e-9)
    r, v_3 = np.linalg.norm(p), max(np.linalg.norm(v), 1e-9)
    h_angle, h_range = 1e-3 * rho / v_h, 1e-3 * r / v_3

    bearing = Bearing()
    b0 = bearing.predict(rel_at(0.0))[0]
    numeric = _richardson_time_derivative(
        lambda s: float(wrap_angle(bearing.predict(rel_at(s))[0] - b0)), 0.0, h_angle)
    rate = float(AzimuthRate().predict(rel_at(0.0))[0])
    # relative 1e-7 of the largest rate this speed allows, plus the rounding level of the
    # differences of bearings (|bearing| <= pi)
    assert abs(rate - numeric) <= 1e-7 * v_h / rho + 100 * EPS * np.pi / h_angle, (rate,
                                                                                  numeric)

    # and the range rate is the time derivative of the range
    rng = Range()
    r0 = rng.predict(rel_at(0.0))[0]
    numeric_rdot = _richardson_time_derivative(
        lambda s: float(rng.predict(rel_at(s))[0] - r0), 0.0, h_range)
    rdot = float(RangeRate().predict(rel_at(0.0))[0])
    assert abs(rdot - numeric_rdot) <= 1e-7 * v_3 + 100 * EPS * r / h_range, (rdot,
                                                                             numeric_rdot)


def test_azimuth_rate_sign():
    """A target passing from West to East north of the sensor: bearing increases."""
    rel = _state(-1000.0, 5000.0, dvx=20.0)
    assert AzimuthRate().predict(rel)[0] == pytest.approx(20.0 * 5000.0 / 26e6, rel=1e-14)


@HYPOTHESIS
@given(state=relative_state(GENERAL_DZ), speed=st.floats(0.1, 300.0),
       carrier=CARRIER, t=st.floats(0.0, 1000.0))
def test_doppler_and_range_rate_signs(state, speed, carrier, t):
    s = np.array(state)
    p = s[:3]
    los = p / np.linalg.norm(p)
    # any tangential velocity plus a radial component of `speed` outwards or inwards
    tangential = s[3:] - np.dot(s[3:], los) * los
    receding = np.concatenate([p, tangential + speed * los])[None, :]
    approaching = np.concatenate([p, tangential - speed * los])[None, :]

    rr = RangeRate()
    assert rr.predict(receding)[0] == pytest.approx(speed, rel=1e-9)
    assert rr.predict(approaching)[0] == pytest.approx(-speed, rel=1e-9)

    for model, nu in ((Frequency(), [carrier]), (Frequency(drift=True), [carrier, 0.0])):
        f_app = model.predict(approaching, [t], nu)[0]
        f_rec = model.predict(receding, [t], nu)[0]
        assert f_app > carrier > f_rec
        assert f_app - carrier == pytest.approx(carrier * speed / SPEED_OF_LIGHT, rel=1e-6)


def test_frequency_drift_and_power_values():
    rel = _state(3000.0, 4000.0)  # range 5 km, no motion
    f = Frequency(drift=True).predict(np.repeat(rel, 2, axis=0), [0.0, 100.0], [1e9, 0.05])
    np.testing.assert_allclose(f, [1e9, 1e9 + 5.0], rtol=1e-15)
    p2 = Power().predict(rel, None, [-20.0])[0]
    assert p2 == pytest.approx(-20.0 - 20.0 * np.log10(5000.0), rel=1e-14)
    p3 = Power(exponent=None).predict(rel, None, [-20.0, 3.0])[0]
    assert p3 == pytest.approx(-20.0 - 30.0 * np.log10(5000.0), rel=1e-14)
    rd = RangeDifference().predict(rel, None, None, _state(600.0, 800.0))[0]
    assert rd == pytest.approx(4000.0, rel=1e-14)


FUSED = [Bearing(), Elevation(), Range(), RangeRate(), Frequency(), Frequency(drift=True),
         AzimuthRate(), Power()]


@pytest.mark.parametrize("model", FUSED, ids=repr)
def test_row_gradients_equal_predict_and_jacobian(model):
    """The plain-float row_gradient (the filters' small updates), where a kind has it, gives
    predict and jacobian's rel part."""
    rng = np.random.default_rng(3)
    rel = np.c_[rng.uniform(-9e3, 9e3, (40, 3)), rng.uniform(-30, 30, (40, 3))]
    t = rng.uniform(0, 100, 40)
    nu = model.nuisance_vector({"carrier": 9.4e9, "carrier_drift": 0.3,
                                "power_constant_db": -30.0}) if model.nuisance_names else None
    want_v = model.predict(rel, t, nu)
    want_d = model.jacobian(rel, t, nu).rel
    scale = np.abs(want_d).max(axis=1, keepdims=True)
    if model.has_row_gradient:
        nus = () if nu is None else tuple(nu.tolist())
        rows = np.array([model.row_gradient(tuple(r), float(ti), nus)
                         for r, ti in zip(rel.tolist(), t, strict=True)])
        assert np.allclose(rows[:, 0], want_v, rtol=1e-14, atol=0)
        assert np.all(np.abs(rows[:, 1:] - want_d) <= 1e-14 * scale)
    else:
        with pytest.raises(NotImplementedError):
            model.row_gradient(tuple(rel[0]), 0.0, ())


def test_tdoa_and_fdoa_values_and_signs():
    """A tdoa is the arrival at the sensor minus that at the reference (s); an fdoa the
    received frequency there minus that at the reference, the Doppler model of the
    frequency kind, so an emitter closing on the sensor and not on the reference is heard
    higher there (positive fdoa)."""
    rel = np.array([[3000.0, 4000.0, 0.0, -30.0, -40.0, 0.0]])  # 5 km, closing at 50 m/s
    rel_ref = np.array([[6000.0, 8000.0, 0.0, 0.0, 0.0, 0.0]])  # 10 km, not moving
    assert Tdoa().predict(rel, None, None, rel_ref)[0] == pytest.approx(-5000.0 / SPEED_OF_LIGHT)
    carrier = 1e9
    want = (Frequency().predict(rel, None, [carrier])[0]
            - Frequency().predict(rel_ref, None, [carrier])[0])
    assert want > 0
    assert Fdoa(carrier=carrier).predict(rel, None, None, rel_ref)[0] == pytest.approx(want)
    assert Fdoa().predict(rel, None, [carrier], rel_ref)[0] == pytest.approx(want)
    with pytest.raises(ValueError, match="carrier"):
        Fdoa(carrier=-1.0)
    with pytest.raises(ValueError, match="shared, independent"):
        Tdoa(noise="sometimes")
