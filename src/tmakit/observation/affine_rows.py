"""Relative states of an affine motion model at many rows, for one or many parameter vectors.

Component ``c`` at row ``j`` is ``offset[c, j] + sum_i theta_i coef[i, c, j]``: one vector from
the non-zero terms (:meth:`AffineRows.single`), a batch by one product (:attr:`AffineRows.matrix`).
"""

from __future__ import annotations

from collections.abc import Sequence
from operator import itemgetter

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import Array

_SENSOR_BLOCK = 4096  # rows of sensor states (192 kB) whose components are made together

#: One non-zero term: parameter index, state component, coefficient per row (None: all 1).
Term = tuple[int, int, Array | None]


class AffineRows:
    """``theta -> `` relative states ``(..., m, 6)`` at ``m`` rows (m, m/s)."""

    def __init__(self, terms: Sequence[Term], offset: Array, p: int,
                 sensor: Array | None = None) -> None:
        self.terms = sorted(terms, key=itemgetter(0))  # (by parameter, stable)
        self._base, self._sensor = offset, sensor
        self._offset = None if sensor is not None else np.ascontiguousarray(offset)
        self._head: Array | None = None  # the first components of the offset, made on use
        self.p = int(p)
        self.m = int(offset.shape[1])
        self._matrix: Array | None = None
        self._head_maps: dict[int, Array] = {}  # (see leading_map)
        self._no_design: dict[tuple[int, ...], Array] = {}  # (see no_design)
        #: Per state component, its terms ``(parameter, coefficient)`` in parameter order.
        self._by_component: list[list[tuple[int, Array | None]]] = [[] for _ in range(6)]
        #: Per parameter, its terms ``(component, coefficient)`` of east and north (components
        #: 0 and 1) in term order: the chain rule of the planar linearisation.
        self.planar_terms: list[list[tuple[int, Array | None]]] = [[] for _ in range(self.p)]
        for i, c, coef in self.terms:
            self._by_component[c].append((i, coef))
            if c < 2:
                self.planar_terms[i].append((c, coef))
        #: Whether parameters 0 and 1 are the east and north positions alone (``(c, c, 1)``):
        #: their Jacobian rows are then the derivatives by east and north themselves.
        self.planar_positions = self.p >= 2 and all(
            len(own) == 1 and own[0][0] == c and own[0][1] is None
            for c, own in enumerate(self.planar_terms[:2]))
        #: ``(a, b, coef)`` when east and north are ``theta[a + c] + theta[b + c] * coef``
        #: (constant velocity): both made by one product and one sum (see :meth:`single`).
        self._planar_stack = _planar_stack(self._by_component[:2])
        stack = self._planar_stack
        #: ``(b, coef)`` when parameters ``b, b + 1`` enter east and north as ``coef`` times
        #: them alone (the velocities): their Jacobian rows are made by one product.
        self.planar_scaled = None if stack is None or len(self.planar_terms[stack[1]]) != 1 \
            or len(self.planar_terms[stack[1] + 1]) != 1 else (stack[1], stack[2])
        #: The Jacobian rows the chain rule writes term by term: not the scaled pair, nor the
        #: positions' rows when they are the derivatives themselves (written in place).
        scaled = self.planar_scaled
        done = ({0, 1} if self.planar_positions else set()) | (
            set() if scaled is None else {scaled[0], scaled[0] + 1})
        self.planar_rows = [(i, own) for i, own in enumerate(self.planar_terms) if i not in done]

    def no_design(self, batch: tuple[int, ...]) -> Array:
        """Give the empty nuisance design ``(*batch, m, 0)`` of rows without nuisance."""
        found = self._no_design.get(batch)
        if found is None:
            found = self._no_design[batch] = np.zeros((*batch, self.m, 0))
        return found

    @property
    def matrix(self) -> Array:
        """The dense map ``(p, 6 m)``, component-major (made on first use)."""
        if self._matrix is None:
            dense = np.zeros((self.p, 6, self.m))
            for i, c, coef in self.terms:
                dense[i, c] = 1.0 if coef is None else coef
            self._matrix = dense.reshape(self.p, 6 * self.m)
        return self._matrix

    def leading_map(self, components: int, rows: NDArray[np.intp] | None = None) -> Array:
        """Give the map of the first ``components`` relative state components at some rows."""
        n_c = int(components)
        if rows is None and n_c in self._head_maps:
            return self._head_maps[n_c]
        m = self.m if rows is None else rows.shape[0]
        head = np.zeros((n_c, self.p + 1, m))
        for i, c, coef in self.terms:
            if c < n_c:
                head[c, i] = 1.0 if coef is None else coef if rows is None else coef[rows]
        if rows is None:
            head[:, self.p] = self._offset_head(n_c)
            self._head_maps[n_c] = head
            return head
        made = self._offset if self._offset is not None else self._head
        if made is not None and made.shape[0] >= n_c:
            head[:, self.p] = made[:n_c][:, rows]
        else:  # the rows of base - sensor (as _offset_head makes them)
            assert self._sensor is not None
            np.subtract(self._base[:n_c][:, rows], self._sensor[rows, :n_c].T,
                        out=head[:, self.p])
        return head

    @staticmethod
    def leading_states(theta: Array, head: Array) -> Array:
        """Give leading relative state components of many parameter vectors from their map."""
        p = head.shape[1] - 1
        with_one = np.empty((theta.shape[0], p + 1))
        with_one[:, :p] = theta
        with_one[:, p] = 1.0
        return np.matmul(with_one, head)  # (c, p + 1) @ (n_c, p + 1, m): one call

    @property
    def offset(self) -> Array:
        """The relative states at ``theta = 0``, ``(6, m)`` component-major (m, m/s)."""
        if self._offset is None:
            base, sensor = self._base, self._sensor
            assert sensor is not None  # (set without a sensor otherwise)
            # Written over the target's offset when it is this object's own: no second (6, m).
            own = base.flags.owndata and base.flags.writeable and base.flags.c_contiguous
            self._offset = _minus_sensor(base, sensor, 6, base if own else None)
        return self._offset

    def _offset_head(self, n_c: int) -> Array:
        """Give the first ``n_c`` components of :attr:`offset` (not making the whole of it)."""
        if self._offset is not None:
            return self._offset[:n_c]
        head = self._head
        if head is None or head.shape[0] < n_c:
            assert self._sensor is not None
            head = self._head = _minus_sensor(self._base, self._sensor, n_c)
        return head[:n_c]

    @property
    def flat_offset(self) -> Array:
        """The offset flattened ``(6 m,)`` (a view)."""
        return self.offset.reshape(6 * self.m)

    def single(self, theta: Array, components: int | None = None) -> Array:
        """Give the relative states of one parameter vector from the non-zero terms."""
        n_c = 6 if components is None else int(components)
        # Each component sums its terms in parameter order, then the offset: the order of
        # the dense product's sums (``theta @ matrix + offset``).  The first product is
        # written in place (``0 + a`` is ``a``, ``a + b`` is ``b + a``, the same bits): no
        # zeroed array and no temporary per term.
        out = np.empty((n_c, self.m))
        stack = self._planar_stack if n_c == 2 else None
        if stack is not None:  # east and north b * coef + a, one coef: both rows at once
            flat, a, b = theta.reshape(-1), stack[0], stack[1]
            np.multiply(stack[2], flat[b:b + 2, None], out=out)
            out += flat[a:a + 2, None]
        else:
            th = theta.reshape(-1).tolist()
            for c in range(n_c):
                self._component(th, c, out[c])
        out += self._offset_head(n_c) if n_c < 6 else self.offset
        if components is not None:
            return out
        return out.T if theta.ndim == 1 else out.T[None]

    def _component(self, th: list[float], c: int, row: Array) -> None:
        """Write the sum of component ``c``'s terms at parameters ``th`` into ``row``."""
        terms = self._by_component[c]
        if not terms:
            row.fill(0.0)
            return
        (i, coef), rest = terms[0], terms[1:]
        if coef is None and rest and rest[0][1] is not None:  # a + b*coef as b*coef + a
            (j, coef_j), rest = rest[0], rest[1:]
            assert coef_j is not None  # (the test above)
            np.multiply(coef_j, th[j], out=row)
            row += th[i]
        elif coef is None:
            row.fill(th[i])
        else:
            np.multiply(coef, th[i], out=row)
        for j, coef_j in rest:
            if coef_j is None:
                row += th[j]
            else:
                row += th[j] * coef_j

    def take(self, rows: NDArray[np.intp], sensor: Array | None = None) -> AffineRows:
        """Give the map of some rows."""
        taken: dict[int, Array] = {}  # a coefficient array shared by terms, gathered once
        terms = []
        for i, c, coef in self.terms:
            if coef is not None:
                if id(coef) not in taken:
                    taken[id(coef)] = coef[rows]
                coef = taken[id(coef)]
            terms.append((i, c, coef))
        if self._offset is None and self._sensor is not None:  # still lazy: both parts taken
            return AffineRows(terms, _take_columns(self._base, rows), self.p,
                              np.take(self._sensor, rows, axis=0) if sensor is None else sensor)
        return AffineRows(terms, np.take(self.offset, rows, axis=1), self.p)


def _planar_stack(shapes: list[list[tuple[int, Array | None]]]) -> tuple[int, int, Array] | None:
    """Find ``(a, b, coef)`` with east and north ``theta[a + c] + theta[b + c] * coef``."""
    if not all(len(own) == 2 and own[0][1] is None for own in shapes):
        return None
    (a, _), (b, coef) = shapes[0]
    (a1, _), (b1, coef1) = shapes[1]
    if coef is None or coef1 is not coef or (a1, b1) != (a + 1, b + 1):
        return None
    return a, b, coef


def _minus_sensor(base: Array, sensor: Array, n_c: int, out: Array | None = None) -> Array:
    """Give ``base[:n_c] - sensor[:, :n_c].T`` component-major ``(n_c, m)`` (into ``out``)."""
    m = sensor.shape[0]
    out = np.empty((n_c, m)) if out is None else out
    for lo in range(0, m, _SENSOR_BLOCK):
        hi = lo + _SENSOR_BLOCK
        np.subtract(base[:n_c, lo:hi], sensor[lo:hi, :n_c].T, out=out[:n_c, lo:hi])
    return out


def _take_columns(base: Array, rows: NDArray[np.intp]) -> Array:
    """Give ``base[:, rows]``; a broadcast (one value everywhere) stays one."""
    if base.strides == (0, 0):
        return np.broadcast_to(base[:, :1], (base.shape[0], rows.shape[0]))
    return np.take(base, rows, axis=1)
