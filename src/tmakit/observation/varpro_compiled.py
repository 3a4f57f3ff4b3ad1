"""Compiled batch evaluation of the point kinds under affine motion (optional ``numba``).

The NumPy evaluation of :class:`tmakit.batch.varpro.VarProProblem` makes the relative states,
each kind's predictions and derivatives, the design, the whitened Jacobian and its
projection as arrays of the batch's size ``(B, n, ...)``: a dozen passes over memory per
evaluation.  For rows of the point kinds (bearing, elevation, range, range rate, frequency
without drift, power with a known exponent) under an affine motion model (constant velocity,
stationary), with independent noise and at most one nuisance parameter per kind, one compiled
call (:func:`tmakit.observation.varpro_numba.varpro_batch`) gives the residuals, the
eliminated nuisance, the cost and ``J'J``, ``J'r`` of the projected Jacobian, row by row, the
Jacobian never written.  It agrees with the NumPy path to rounding
(``tests/test_varpro_kernel.py``).

When it is used:

* never with ``TMAKIT_NO_NUMBA`` set, after ``use_compiled(False)`` or inside
  ``compiled_batches(False)``;
* always where it applies inside ``compiled_batches(True)`` (loading ``numba`` if needed):
  the Monte Carlo chunks of a large study ask for it, so that every executor (this process,
  a pool, a Dask cluster) evaluates the same way;
* otherwise when ``numba`` is already loaded and the batch has at least
  :data:`KERNEL_ELEMENTS` rows in all (one fit of a small file keeps the NumPy path's bits,
  and never waits for ``numba`` to load).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from ..arrays import Array, BoolArray, IntArray
from ..measurements.bearing import Bearing
from ..measurements.elevation import Elevation
from ..measurements.frequency import Frequency
from ..measurements.power import Power
from ..measurements.range import Range
from ..measurements.range_rate import RangeRate
from ..optional_kernels import OptionalKernels

__all__ = ["KERNELS", "KERNEL_ELEMENTS", "BatchPlan", "compiled_batches", "evaluate_batch",
           "plan_for", "use_compiled", "wanted"]

KERNEL_ELEMENTS = 20_000
"""Rows times parameter vectors from which the kernel is used when ``numba`` is loaded
already (outside :func:`compiled_batches`)."""


def _compile() -> dict[str, Callable[..., object]]:
    """Import ``numba`` and the kernel and compile it on tiny inputs (cached on disk)."""
    from . import varpro_numba as vn

    n, p, k = 6, 4, 1
    blocks = np.array([[i, i + 1, i, 0 if i >= 4 else -1] for i in range(6)], dtype=np.int64)
    vn.varpro_batch(np.array([[1.0e3, 2.0e3, 1.0, 1.0]]), np.zeros((1, n)), np.zeros((1, k)),
                    blocks, np.array([0, 0, 0, 0, 3e8, 2.0]), np.ones(n),
                    np.arange(n) < 2, np.ones(n), np.ones((6, n)),
                    np.array([0, 1, 2, 3], np.int64), np.array([0, 1, 0, 1], np.int64),
                    np.ones((4, n)), np.array([True, True, False, False]), True, True,
                    np.empty((1, n)), np.empty((1, k)), np.empty(1), np.empty((1, p, p)),
                    np.empty((1, p)))
    return {"batch": vn.varpro_batch}


#: The module's kernel (:mod:`tmakit.optional_kernels`).
KERNELS = OptionalKernels("batch evaluation", _compile)
use_compiled = KERNELS.use_compiled
_wanted: list[bool | None] = [None]  # see compiled_batches


@contextmanager
def compiled_batches(wanted: bool | None) -> Iterator[None]:
    """Ask for the kernel (True), forbid it (False) or leave the choice (None) for a while.

    Parameters
    ----------
    wanted : bool or None
        True: used wherever it applies (``numba`` loaded if it must be); False: never;
        None: the default rule (see the module).

    Yields
    ------
    None
    """
    before = _wanted[0]
    _wanted[0] = wanted
    try:
        yield
    finally:
        _wanted[0] = before


_CODES: dict[type, int] = {Bearing: 0, Elevation: 1, Range: 2, RangeRate: 3, Frequency: 4,
                           Power: 5}


class BatchPlan:
    """The per-row arrays the kernel reads, made once per problem.

    Parameters
    ----------
    blocks, block_param : ndarray
        Per kind ``(K, 4)`` int: its rows' slice ``lo, hi`` (grouped order), kind code and
        nuisance column (-1: none); ``(K,)`` its parameter (speed of propagation, m/s, or
        path-loss exponent).
    const, angle, w : ndarray
        ``(n,)`` constant design entry, angle flag, inverse sigma.
    offset : ndarray
        ``(6, n)`` relative states at ``theta = 0`` (m, m/s).
    t_par, t_comp, t_coef, t_one : ndarray
        The affine map's non-zero terms: parameter, state component, ``(T, n)`` coefficient
        (s or 1) and whether it is one on every row.
    """

    def __init__(self, blocks: IntArray, block_param: Array, const: Array, angle: BoolArray,
                 w: Array, offset: Array, t_par: IntArray, t_comp: IntArray, t_coef: Array,
                 t_one: BoolArray) -> None:
        self.blocks, self.block_param = blocks, block_param
        self.const, self.angle, self.w, self.offset = const, angle, w, offset
        self.t_par, self.t_comp, self.t_coef, self.t_one = t_par, t_comp, t_coef, t_one


def plan_for(obs: Any, inv_sigma: Array | None, const_design: Array) -> BatchPlan | None:
    """Give the kernel's plan of an observation model, or None where the kernel does not apply.

    Parameters
    ----------
    obs : ObservationModel
        The model (grouped rows).
    inv_sigma : ndarray or None
        ``(n,)`` inverse standard deviations of independent rows; None (correlated noise):
        the kernel does not apply.
    const_design : ndarray
        ``(n, k)`` the constant part of the nuisance design (grouped rows).

    Returns
    -------
    BatchPlan or None
    """
    rel_map = obs._rel_map
    if inv_sigma is None or rel_map is None or obs._ref is not None:
        return None
    n = len(obs.meas)
    blocks, params = [], []
    const = np.zeros(n)
    for kind, model in obs.models.items():
        sl, ns = obs.slices[kind], obs.nuisance_slices[kind]
        code = _CODES.get(type(model))
        width = ns.stop - ns.start
        with_nuisance = isinstance(model, Frequency | Power)
        if code is None or width != int(with_nuisance):
            return None  # (a drift, or an unknown exponent: two columns in one kind)
        param = (model.c if isinstance(model, Frequency)
                 else model.exponent if isinstance(model, Power) else 0.0)
        col = ns.start if width else -1
        if width:
            const[sl] = const_design[sl, col]
        blocks.append((sl.start, sl.stop, code, col))
        params.append(param)
    terms = rel_map.terms
    t_coef = np.ones((len(terms), n))
    for t, (_, _, coef) in enumerate(terms):
        if coef is not None:
            t_coef[t] = coef
    return BatchPlan(np.array(blocks, dtype=np.int64).reshape(-1, 4), np.array(params, float),
                     const, np.asarray(obs.angle_mask_grouped, dtype=bool),
                     np.ascontiguousarray(inv_sigma, dtype=float),
                     np.ascontiguousarray(rel_map.offset, dtype=float),
                     np.array([i for i, _, _ in terms], dtype=np.int64),
                     np.array([c for _, c, _ in terms], dtype=np.int64), t_coef,
                     np.array([coef is None for _, _, coef in terms], dtype=bool))


def wanted(elements: int) -> bool:
    """Tell whether the kernel is to be used on a batch of ``elements`` rows in all.

    Parameters
    ----------
    elements : int
        Parameter vectors times rows.

    Returns
    -------
    bool
    """
    if not KERNELS.enabled or _wanted[0] is False:
        return False
    if _wanted[0] is None and not (elements >= KERNEL_ELEMENTS and "numba" in sys.modules):
        return False
    return KERNELS.available()


def evaluate_batch(plan: BatchPlan, theta: Array, u: Array, nu_star: Array, eliminate: bool,
                   derivatives: bool) -> tuple[Array, Array, Array, Array, Array] | None:
    """Evaluate a batch by the kernel: residuals, nuisance, cost, ``J'J`` and ``J'r``.

    Parameters
    ----------
    plan : BatchPlan
        :func:`plan_for` of the problem.
    theta, u, nu_star : ndarray
        ``(B, p)`` motion parameters, ``(B, n)`` data part, ``(B, k)`` reference nuisance (SI).
    eliminate, derivatives : bool
        Whether the nuisance is eliminated, and whether the normal equations are formed.

    Returns
    -------
    tuple of ndarray or None
        ``(B, n)`` whitened projected residuals, ``(B, k)`` nuisance, ``(B,)`` half chi2
        (NaN where a point has no prediction), ``(B, p, p)`` ``J'J`` and ``(B, p)`` ``J'r``
        (undefined without ``derivatives``); None when an angle residual is more than a turn
        out (the NumPy path wraps it).
    """
    b, n = u.shape
    p, k = theta.shape[1], nu_star.shape[1]
    r, nu, cost = np.empty((b, n)), np.empty((b, k)), np.empty(b)
    jtj, jtr = np.empty((b, p, p)), np.empty((b, p))
    bad = KERNELS["batch"](np.ascontiguousarray(theta), np.ascontiguousarray(u),
                           np.ascontiguousarray(nu_star), plan.blocks, plan.block_param,
                           plan.const, plan.angle, plan.w, plan.offset, plan.t_par,
                           plan.t_comp, plan.t_coef, plan.t_one, eliminate, derivatives,
                           r, nu, cost, jtj, jtr)
    return None if bad else (r, nu, cost, jtj, jtr)
