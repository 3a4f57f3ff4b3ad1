"""The cloud sums of :mod:`tmakit.planning.planar_information`, compiled (optional ``numba``).

:func:`~tmakit.planning.planar_information.planar_information` reduces ``Gamma`` over a cloud
of ``N`` members for ``C`` candidate sensors to weighted sums over the cloud of a few fields
(``c2``, ``cs`` and the products ``1/r^2``, ``q/r``, ``q^2``, ``1/r``, ``q`` times ``1``,
``c2``, ``cs``).  In NumPy each field is a ``(C, N)`` array written to memory and read back;
here one compiled loop per candidate runs over the cloud once and keeps every sum in a
register, in float64 (reassociated into SIMD lanes, so the sums may differ from NumPy's in the
last bits; ``tests/test_planning_kernel.py`` checks the two agree to 1e-12 relative).

``numba`` is an optional extra (``pip install tmakit[fast]``): without it, or with the
environment variable ``TMAKIT_NO_NUMBA`` set to a non-empty value other than ``0``, or after
``use_compiled(False)``, :func:`available` is False and the NumPy path is used.  ``numba`` is
imported, and the kernels compiled (cached on disk), at the first call only.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np

from ..arrays import Array

#: The products of ``1/r`` and the bearing rate ``q`` the kernels sum, in the order of
#: :data:`tmakit.planning.planar_information._PRODUCTS`.
PRODUCTS = ("ir2", "irq", "qq", "ir", "q")
#: Rows of the general kernel's output: ``E[c2]``, ``E[cs]``, then per product ``g``
#: ``E[g]``, ``E[g c2]``, ``E[g cs]``.
ROWS = 2 + 3 * len(PRODUCTS)

_STATE: dict[str, Any] = {"enabled": os.environ.get("TMAKIT_NO_NUMBA", "") in ("", "0"),
                          "kernels": None}


def use_compiled(enabled: bool) -> bool:
    """Switch the compiled kernels on or off (for comparisons); return the previous setting.

    Parameters
    ----------
    enabled : bool
        False: every call takes the NumPy path, even with ``numba`` installed.

    Returns
    -------
    bool
        The setting before the call.
    """
    before = bool(_STATE["enabled"])
    _STATE["enabled"] = bool(enabled)
    return before


def available() -> bool:
    """Tell whether the compiled kernels are switched on and ``numba`` can be imported.

    Returns
    -------
    bool
    """
    if not _STATE["enabled"]:
        return False
    if _STATE["kernels"] is None:
        try:
            _STATE["kernels"] = _compile()
        except ImportError:
            _STATE["kernels"] = False
    return _STATE["kernels"] is not False


def _compile() -> dict[str, Callable[..., None]]:
    """Import ``numba`` and define the kernels (compiled lazily at their first call)."""
    import numba

    # error_model="numpy": no zero-division check per element (which would keep the loops
    # scalar); reassociation lets the sums run in SIMD lanes.
    jit = numba.njit(cache=True, nogil=True, error_model="numpy",
                     fastmath={"reassoc", "contract", "nsz"})

    @jit
    def position_sums(x, y, w, sx, sy, out):  # noqa: ANN001
        """Write (5, C): E[c2], E[cs], E[1/r^2], E[c2/r^2], E[cs/r^2] (no velocity)."""
        for c in range(sx.shape[0]):
            a0 = a1 = a2 = a3 = a4 = 0.0
            px = sx[c]
            py = sy[c]
            for i in range(x.shape[0]):
                dx = x[i] - px
                dy = y[i] - py
                dx2 = dx * dx
                ir2 = 1.0 / (dx2 + dy * dy)
                c2 = dx2 * ir2
                cs = dx * dy * ir2
                wi = w[i]
                wg = wi * ir2
                a0 += wi * c2
                a1 += wi * cs
                a2 += wg
                a3 += wg * c2
                a4 += wg * cs
            out[0, c] = a0
            out[1, c] = a1
            out[2, c] = a2
            out[3, c] = a3
            out[4, c] = a4

    @jit
    def general_sums(x, y, vx, vy, w, s, out):  # noqa: ANN001
        """Write the sums (17, C): E[c2], E[cs], then E[g], E[g c2], E[g cs] for every product g."""
        for c in range(s.shape[0]):
            px, py, pvx, pvy = s[c, 0], s[c, 1], s[c, 3], s[c, 4]
            a0 = a1 = b0 = b1 = b2 = d0 = d1 = d2 = e0 = e1 = e2 = 0.0
            f0 = f1 = f2 = h0 = h1 = h2 = 0.0
            for i in range(x.shape[0]):
                dx = x[i] - px
                dy = y[i] - py
                dx2 = dx * dx
                ir2 = 1.0 / (dx2 + dy * dy)
                c2 = dx2 * ir2
                cs = dx * dy * ir2
                ir = np.sqrt(ir2)
                q = ((vx[i] - pvx) * dy - (vy[i] - pvy) * dx) * ir2
                wi = w[i]
                a0 += wi * c2
                a1 += wi * cs
                g = wi * ir2
                b0 += g
                b1 += g * c2
                b2 += g * cs
                g = wi * (ir * q)
                d0 += g
                d1 += g * c2
                d2 += g * cs
                g = wi * (q * q)
                e0 += g
                e1 += g * c2
                e2 += g * cs
                g = wi * ir
                f0 += g
                f1 += g * c2
                f2 += g * cs
                g = wi * q
                h0 += g
                h1 += g * c2
                h2 += g * cs
            sums = (a0, a1, b0, b1, b2, d0, d1, d2, e0, e1, e2, f0, f1, f2, h0, h1, h2)
            for k in range(17):
                out[k, c] = sums[k]

    return {"position": position_sums, "general": general_sums}


def cloud_sums(names: list[str], cols: Array, weights: Array, sensors: Array) -> Array:
    """Return the weighted cloud sums (2 + 3 P, C) of the products ``names``, compiled.

    Parameters
    ----------
    names : list of str
        The products needed (a subsequence of :data:`PRODUCTS`), ``P`` of them.
    cols : ndarray, shape (4, N)
        The cloud ``[x, y, vx, vy]`` by rows (m, m/s).
    weights : ndarray, shape (N,)
        Normalised weights.
    sensors : ndarray, shape (C, 6)
        Candidate sensor states (m, m/s).

    Returns
    -------
    ndarray, shape (2 + 3 P, C)
        Rows ``E[c2]``, ``E[cs]``, then per product ``g`` of ``names``: ``E[g]``,
        ``E[g c2]``, ``E[g cs]`` (SI).

    Raises
    ------
    RuntimeError
        If the kernels are not :func:`available`.
    """
    if not available():
        raise RuntimeError("the compiled planning kernels are not available (numba)")
    kernels = _STATE["kernels"]
    c = sensors.shape[0]
    w = np.ascontiguousarray(weights, dtype=float)
    x = np.ascontiguousarray(cols[0])
    y = np.ascontiguousarray(cols[1])
    if names == ["ir2"]:
        out = np.empty((5, c))
        kernels["position"](x, y, w, np.ascontiguousarray(sensors[:, 0]),
                            np.ascontiguousarray(sensors[:, 1]), out)
        return out
    full = np.empty((ROWS, c))
    kernels["general"](x, y, np.ascontiguousarray(cols[2]), np.ascontiguousarray(cols[3]), w,
                       np.ascontiguousarray(sensors, dtype=float), full)
    rows = [0, 1]
    for name in names:
        k = 2 + 3 * PRODUCTS.index(name)
        rows += [k, k + 1, k + 2]
    return full[rows]
