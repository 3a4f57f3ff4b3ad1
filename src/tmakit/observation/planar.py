"""The planar linearisation: prediction and Jacobian of one two-component kind under affine motion.

Under affine motion ``d h / d theta_i = sum_c (d h / d rel_c) coef[i, c]`` is written directly
over the components the kind uses; :class:`Linearisation` holds what either path makes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array
from .affine_rows import AffineRows

__all__ = [
    "Linearisation",
    "PlanarUnits",
    "gradient_of_rows",
    "planar_gradient_rows",
    "planar_kind",
    "planar_linearisation",
    "planar_units",
    "planar_values",
]


def planar_linearisation(obs: Any, theta: Array, weights: Array | None = None
                        ) -> Linearisation | None:
    """Give the linearisation of ``obs`` at one ``theta`` by the planar path, or None."""
    found = _planar_kind(obs, theta, "planar_gradient")
    if found is None:
        return None
    rel_map, model, theta = found
    rel = rel_map.single(theta, components=2)  # (2, m): dx, dy, component-major
    jac = np.empty((rel_map.p, rel_map.m))
    head = jac[:2]  # the derivatives by east and north, parked in rows 0, 1
    squared = model.planar_gradient(rel, head, weights)
    # (copied unless rows 0, 1 are the positions' own: else overwritten before read)
    _chain_terms(rel_map, head if rel_map.planar_positions else head.copy(), jac)
    batch = theta.shape[:-1]
    lin = Linearisation(obs, theta, None, rel_map.no_design(batch))
    lin.planar = (model, rel, weights)
    lin.planar_jacobian = jac.T.reshape(*batch, rel_map.m, rel_map.p)
    lin.planar_squared = squared
    lin.whitened = weights is not None
    return lin


def planar_values(obs: Any, theta: Array) -> Linearisation | None:
    """Give the predictions of ``obs`` at one ``theta`` alone by the planar path, or None."""
    found = _planar_kind(obs, theta, "planar_value")
    if found is None:
        return None
    rel_map, model, theta = found
    rel = rel_map.single(theta, components=2)
    batch = theta.shape[:-1]
    return Linearisation(obs, theta, model.planar_value(rel[0], rel[1]).reshape(*batch, rel_map.m),
                         np.zeros((*batch, rel_map.m, 0)))


def planar_gradient_rows(obs: Any, theta: Array, weights: Array
                        ) -> tuple[Array, Array] | None:
    """Give the predictions and the whitened derivatives by east and north, or None."""
    found = _planar_kind(obs, theta, "planar_gradient")
    if found is None:
        return None
    rel_map, model, theta = found
    rel = rel_map.single(theta, components=2)
    rows = np.empty((2, rel_map.m))
    model.planar_gradient(rel, rows, weights, negate=False)
    return model.planar_value(rel[0], rel[1]), rows


def gradient_of_rows(obs: Any, rows: Array, r: Array) -> Array:
    """Give ``J'r`` ``(p,)`` from :func:`planar_gradient_rows`' derivatives, the chain unwritten."""
    rel_map = obs._rel_map
    weighted: dict[int, Array] = {}
    out = np.zeros(rel_map.p)
    for i, c, coef in rel_map.terms:
        if c >= 2:
            continue
        if coef is None:
            factor = r
        else:
            found = weighted.get(id(coef))
            if found is None:
                found = weighted[id(coef)] = coef * r
            factor = found
        # every product of the north row negated: its sum exactly negated
        term = np.einsum("n,n->", rows[c], factor)
        out[i] += -term if c == 1 else term
    return out


class PlanarUnits:
    """Sines and cosines of one planar angle kind's predictions, many parameter vectors at once."""

    def __init__(self, head: Array, unit: Any) -> None:
        self.head = head
        self.unit = unit
        self.m = int(head.shape[2])  #: rows

    def __call__(self, theta: Array) -> Array:
        """Give ``sin h`` and ``cos h`` of the predictions at each parameter vector."""
        east_north = AffineRows.leading_states(theta, self.head)
        self.unit(east_north[0], east_north[1])
        return east_north


def planar_units(obs: Any, rows: NDArray[np.int64] | None = None) -> PlanarUnits | None:
    """Give :class:`PlanarUnits` of the rows ``rows`` of ``obs`` (grouped order), or None."""
    found = obs.planar_kind
    unit = None if found is None else getattr(found[1], "planar_unit", None)
    if unit is None:
        return None
    return PlanarUnits(found[0].leading_map(2, rows), unit)


def planar_kind(obs: Any) -> tuple[AffineRows, Any] | None:
    """Give the affine row map and the model of a set of one kind without nuisance, or None."""
    rel_map = obs._rel_map
    if (rel_map is None or obs.n_nuisance or obs._ref is not None
            or len(obs.models) != 1):
        return None
    return rel_map, next(iter(obs.models.values()))


def _planar_kind(obs: Any, theta: Array, method: str) -> tuple[Any, Any, Array] | None:
    """Give the affine row map, the one kind's model (with ``method``) and the checked theta."""
    if not (theta.ndim == 1 or (theta.ndim == 2 and theta.shape[0] == 1)):
        return None
    found = obs.planar_kind  # (the set's, made once)
    if found is None or theta.shape[-1] != found[0].p or not hasattr(found[1], method):
        return None
    return found[0], found[1], theta  # (float: its callers converted it; of the motion's length)


def _jacobian_again(obs: Any, theta: Array, weights: Array | None) -> Array:
    """Make the planar Jacobian at ``theta`` again (the first one was handed over)."""
    lin = planar_linearisation(obs, theta, weights)
    assert lin is not None and lin.planar_jacobian is not None  # (it was planar before)
    return lin.planar_jacobian


def _chain_terms(rel_map: AffineRows, g: Array, jac: Array) -> None:
    """Write ``jac[i] = sum_c g[c] coef[i, c]`` over the terms of components 0 and 1."""
    scaled = rel_map.planar_scaled  # (the velocities' pair: one product, the same bits)
    if scaled is not None:
        np.multiply(g, scaled[1], out=jac[scaled[0]:scaled[0] + 2])
    for i, own in rel_map.planar_rows:
        row = jac[i]
        if not own:
            row.fill(0.0)
            continue
        (c, coef), rest = own[0], own[1:]
        if coef is None:
            row[...] = g[c]
        else:
            np.multiply(g[c], coef, out=row)
        for c, coef in rest:
            if coef is None:
                row += g[c]
            else:
                row += g[c] * coef


class Linearisation:
    """An :class:`ObservationModel`'s predictions linearised: ``h0 + (A_const + A_var) @ nu``."""

    #: The planar path's kind model, relative east and north ``(2, m)`` and weights, from
    #: which :attr:`h0` and :attr:`relative` are made on first use (a bound needs the
    #: derivatives alone), or None.
    planar: tuple[Any, Array, Array | None] | None = None
    d_h0: Array | None = None
    d_h0_ref: Array | None = None
    _relative: Array | None = None
    #: The Jacobian ``(..., n, p)`` made by the planar path (:mod:`.planar`), or None, handed
    #: over on the first call of :meth:`jacobian` (the caller may scale it), then made again.
    planar_jacobian: Array | None = None
    #: The planar path's squared east-north distances ``(m,)`` to the sensors, m^2.
    planar_squared: Array | None = None
    _planar_given = False
    #: Whether the planar Jacobian is already whitened (made with the noise's weights).
    whitened = False

    def __init__(self, obs: Any, theta: Array, h0: Array | None, a_var: Array) -> None:
        # (the attributes above are set on the instance where they differ)
        self.obs = obs
        self.theta = theta
        self._h0 = h0
        self.a_var = a_var
        self.d_a: list[tuple[str, Array | None, Array | None]] = []

    @property
    def h0(self) -> Array:
        """The predictions at zero nuisance ``(..., n)``, SI."""
        if self._h0 is None:
            assert self.planar is not None  # (made without h0 by the planar path)
            model, rel, _ = self.planar
            self._h0 = model.planar_value(rel[0], rel[1]).reshape(*self.theta.shape[:-1],
                                                                   rel.shape[1])
        return self._h0

    @property
    def relative(self) -> Array | None:
        """The relative states ``(..., n, c)`` it was made from, or None (planar: east, north)."""
        if self._relative is None and self.planar is not None:
            rel = self.planar[1]
            self._relative = rel.T.reshape(*self.theta.shape[:-1], rel.shape[1], 2)
        return self._relative

    @relative.setter
    def relative(self, value: Array | None) -> None:
        self._relative = value

    def jacobian(self, nuisance: Array, with_h0: bool = True) -> Array:
        """Return ``d predictions / d theta`` ``(..., n, p)`` at nuisance values."""
        if self.planar_jacobian is not None:  # no nuisance: the Jacobian itself, a new array once
            if not with_h0:
                return np.zeros_like(self.planar_jacobian)
            if self._planar_given and self.planar is not None:
                return _jacobian_again(self.obs, self.theta, self.planar[2])
            self._planar_given = True
            return self.planar_jacobian
        if self.d_h0 is None:
            raise ValueError("this linearisation was made without derivatives")
        obs = self.obs
        if with_h0 and not self.d_a and self.d_h0_ref is None:
            # Nothing is added to d h0: the chain rule reads it (writes a new array).
            return obs.motion.chain(self.d_h0, self.theta, obs._time)
        nu = np.asarray(nuisance, dtype=float)
        d = self.d_h0.copy(order="K") if with_h0 else np.zeros_like(self.d_h0)
        d_ref = None
        if self.d_h0_ref is not None:
            d_ref = (self.d_h0_ref.copy(order="K") if with_h0
                     else np.zeros_like(self.d_h0_ref))
        for kind, da, da_ref in self.d_a:
            sl, ns = obs.slices[kind], obs.nuisance_slices[kind]
            for j in range(ns.stop - ns.start):
                w = nu[..., ns.start + j, None, None]
                if da is not None:
                    d[..., sl, :] += da[..., j, :] * w
                if da_ref is not None and d_ref is not None:
                    d_ref[..., obs.row_model.reference_rows(kind), :] += da_ref[..., j, :] * w
        motion = obs.motion
        jac = motion.chain(d, self.theta, obs._time)
        if d_ref is not None:
            sl = obs._ref
            jac[..., sl, :] += motion.chain(d_ref, self.theta, obs.grouped.time_ref[sl])
        return jac
