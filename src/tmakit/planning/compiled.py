"""The planner's compiled kernels (``numba``), imported and loaded at their first call."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.arrays import Array

#: The products of ``1/r`` and the bearing rate ``q`` the kernels sum, in the order of
#: :data:`tmakit.planning.planar_information._PRODUCTS`.
PRODUCTS = ("ir2", "irq", "qq", "ir", "q")
#: Rows of the general kernel's output: ``E[c2]``, ``E[cs]``, then per product ``g``
#: ``E[g]``, ``E[g c2]``, ``E[g cs]``.
ROWS = 2 + 3 * len(PRODUCTS)


@functools.cache
def kernels() -> dict[str, Callable[..., Any]]:
    """Return the compiled kernels by name (importing ``numba`` the first time)."""
    from . import compiled_decision as nd
    from . import compiled_sums as nk

    return {"position": nk.position_sums, "general": nk.general_sums,
            "spd_inverse": nk.spd_inverse_stack, "assemble": nk.assemble_gamma,
            "fly": nd.fly, "decide_planar": nd.decide_planar}


def spd_inverse(information: Array) -> Array | None:
    """Return ``J^{-1}`` (..., n, n) of positive-definite information matrices."""
    info = np.ascontiguousarray(information, dtype=float)
    n = info.shape[-1]
    flat = info.reshape(-1, n, n)
    out = np.empty_like(flat)
    if not kernels()["spd_inverse"](flat, out):
        return None
    return out.reshape(info.shape)


def cloud_sums(names: list[str], cols: Array, weights: Array, sensors: Array) -> Array:
    """Return the weighted cloud sums (2 + 3 P, C) of the products ``names``."""
    c = sensors.shape[0]
    w = np.ascontiguousarray(weights, dtype=float)
    x = np.ascontiguousarray(cols[0])
    y = np.ascontiguousarray(cols[1])
    if names == ["ir2"]:
        out = np.empty((5, c))
        kernels()["position"](x, y, w, np.ascontiguousarray(sensors[:, 0]),
                              np.ascontiguousarray(sensors[:, 1]), out)
        return out
    full = np.empty((ROWS, c))
    kernels()["general"](x, y, np.ascontiguousarray(cols[2]), np.ascontiguousarray(cols[3]),
                         w, np.ascontiguousarray(sensors, dtype=float), full)
    rows = [0, 1]
    for name in names:
        k = 2 + 3 * PRODUCTS.index(name)
        rows += [k, k + 1, k + 2]
    return full[rows]


def planar_gamma(names: list[str], coefficients: Array, constants: Array, cols: Array,
                 weights: Array, sensors: Array) -> Array:
    """Return ``Gamma`` (C, 4, 4) of the planar closed form."""
    sums = cloud_sums(names, cols, weights, sensors)
    out = np.empty((sensors.shape[0], 4, 4))
    kernels()["assemble"](sums, coefficients, constants, out)
    return out


def fly(starts: Array, actions: Array, own_climb: bool, limits: Array, interval: float
        ) -> tuple[Array, Array]:
    """Fly every action from every start for one step (rows of ``compiled_decision``)."""
    size = starts.shape[0] * actions.shape[1]
    fields, flags = np.empty((20, size)), np.empty((4, size), dtype=np.bool_)
    kernels()["fly"](starts, actions, own_climb, limits, float(interval), fields, flags)
    return fields, flags
