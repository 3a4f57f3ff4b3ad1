"""Kinds write their values and derivatives in place the same as predict and jacobian.

The solvers' linearisation of a kind without nuisance or reference samples, and the filters'
of any kind without reference samples, call ``values_and_derivatives_into`` on its rows'
slices; its values must be those of ``predict`` and ``jacobian`` bit for bit (a manoeuvre
fit's choices rest on them), in either memory layout of the relative states.
"""

from __future__ import annotations

import numpy as np
import pytest

from tmakit.measurements import KINDS, Frequency

PLAIN = [k for k, cls in KINDS.items() if not cls.uses_reference]
MODELS = [KINDS[k](**({"origin": (52.0, 4.0, 10.0)} if k == "altitude" else {})) for k in PLAIN]
NUISANCE = {"carrier": 9.4e9, "carrier_drift": 0.3, "power_constant_db": -30.0}


def _rel(rng: np.random.Generator, component_major: bool) -> np.ndarray:
    rel = rng.normal(0.0, 3000.0, (3, 50, 6))
    rel[..., 3:] = rng.normal(0.0, 20.0, (3, 50, 3))
    if component_major:
        rel = np.ascontiguousarray(rel.swapaxes(-1, -2)).swapaxes(-1, -2)
    return rel


@pytest.mark.parametrize("component_major", [False, True])
@pytest.mark.parametrize("model", [*MODELS, Frequency(drift=True)], ids=repr)
def test_values_and_derivatives_into_are_predict_and_jacobian(model, component_major):
    rel = _rel(np.random.default_rng(7), component_major)
    t = np.linspace(0.0, 100.0, 50)
    nu = model.nuisance_vector(NUISANCE) if model.nuisance_names else None
    values = np.empty(rel.shape[:-1])
    d_rel = np.zeros((*rel.shape[:-2], 6, rel.shape[-2])).swapaxes(-1, -2)
    model.values_and_derivatives_into(rel, t, values, d_rel, nu)
    np.testing.assert_array_equal(values, model.predict(rel, t, nu, None))
    np.testing.assert_array_equal(d_rel, model.jacobian(rel, t, nu, None).rel)


def test_the_kinds_checked_include_the_overrides():
    assert {"bearing", "azimuth_rate", "frequency"} <= set(PLAIN)
