"""The distinct starting points the grid gives, best first (:mod:`tmakit.batch.init`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["SHORTLIST", "Starts", "first_of_many", "starts_of"]


#: A shortlist: candidate indices, their costs, whether each is still available.
Shortlist = tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]


class Starts:
    """The mutually distinct candidates of one data set, best first, chosen when asked for.

    Greedily in order of cost, each candidate not within 5 % of each parameter's spread of one
    already chosen.

    Parameters
    ----------
    candidates : ndarray, shape (C, p)
        Motion parameters (SI).
    cost : ndarray, shape (C,)
        Their grid costs (non-finite: never chosen).
    scaled : ndarray, shape (p, C), optional
        The candidates over that spread, transposed; may be shared by data sets with the
        same candidates.
    shortlist : ndarray of int, optional
        The indices of the :data:`SHORTLIST` cheapest candidates in order of (cost, index)
        (made by :func:`starts_of` for many data sets at once), else made on first use.
    """

    def __init__(self, candidates: NDArray[np.float64], cost: NDArray[np.float64],
                 scaled: NDArray[np.float64] | None = None,
                 shortlist: NDArray[np.int64] | None = None) -> None:
        self.candidates = candidates
        self.scaled = _scaled(candidates) if scaled is None else scaled
        self.left = np.where(np.isfinite(cost), cost, np.inf)
        self.chosen: list[int] = []
        # The shortlist walked first (see _from_shortlist): indices, their scaled candidates
        # (p, K), whether each is near one chosen; None until made, False once left behind.
        #: The shortlist's candidates, costs and availability; None before it is made, False
        #: once the full set has taken over.
        self._short: Shortlist | bool | None
        self._short = None if shortlist is None else self._shortlist(shortlist)
        self._at = 0  # the shortlist's next position

    def _shortlist(self, idx: NDArray[np.int64]
                   ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
        """Give the shortlist state of candidates ``idx`` (in order)."""
        return idx, self.scaled[:, idx], np.zeros(idx.shape[0], dtype=bool)

    def first(self, m: int) -> NDArray[np.float64]:
        """Return the ``m`` best distinct candidates.

        Parameters
        ----------
        m : int
            How many.

        Returns
        -------
        ndarray, shape (<= m, p)
            Motion parameters (SI), best first; fewer when no more are finite.
        """
        if len(self.chosen) < m and self._short is not False:
            self._from_shortlist(m)
        while len(self.chosen) < m:
            i = int(np.argmin(self.left))
            if not np.isfinite(self.left[i]):
                break
            self._choose(i)
        return self.candidates[self.chosen[:m]]

    def _choose(self, i: int) -> None:
        """Choose candidate ``i``: no candidate near it is chosen later."""
        self.chosen.append(i)
        self._drop_near(i)

    def _drop_near(self, i: int) -> None:
        """Leave out every candidate near candidate ``i`` (within 5 % of each spread)."""
        near = np.max(np.abs(self.scaled - self.scaled[:, i:i + 1]), axis=0) <= 0.05
        self.left[near] = np.inf

    def _from_shortlist(self, m: int) -> None:
        """Choose as :meth:`first` does, among the cheapest candidates alone, while that is exact.

        The greedy choice takes candidates in order of (cost, index), each one not near one
        chosen before: the same choices are made walking the cheapest :data:`SHORTLIST` in
        that order (:func:`_walk_together`), up to the first whose cost ties the shortlist's
        last (a tie at the cut may have left out a candidate of lower index).  Then the full
        set takes over, the shortlist's choices applied to it.
        """
        if self._short is None:
            self._short = self._shortlist(_cheapest(self.left[None, :])[0])
        _walk_together([self], m)
        if len(self.chosen) < m:  # the full set takes over from here
            self._short = False
            for i in self.chosen:
                self._drop_near(i)


SHORTLIST = 64
"""Cheapest candidates among which :meth:`Starts.first` chooses before it scans them all."""


def _cheapest(left: NDArray[np.float64]) -> NDArray[np.int64]:
    """Give the :data:`SHORTLIST` cheapest columns of each row of ``left`` ``(B, C)``.

    In order of (cost, index); all of them when there are no more.
    """
    count = left.shape[1]
    if count > SHORTLIST:
        idx = np.argpartition(left, SHORTLIST - 1, axis=1)[:, :SHORTLIST]
    else:
        idx = np.broadcast_to(np.arange(count), left.shape)
    order = np.lexsort((idx, np.take_along_axis(left, idx, axis=1)), axis=-1)
    return np.take_along_axis(idx, order, axis=1)


def first_of_many(starts: list[Starts], m: int) -> list[NDArray[np.float64]]:
    """Give ``s.first(m)`` for every ``s`` of ``starts``, their shortlists walked together.

    The same choices as one by one (each data set's greedy walk, :meth:`Starts.first`),
    in a few array operations per choice for all data sets with a full shortlist.

    Parameters
    ----------
    starts : list of Starts
        The data sets' starts.
    m : int
        How many each.

    Returns
    -------
    list of ndarray
        ``(<= m, p)`` motion parameters (SI) per data set, best first.
    """
    group = [s for s in starts if len(s.chosen) < m and isinstance(s._short, tuple)
             and s._short[0].shape[0] == SHORTLIST]
    if len(group) > 1:
        _walk_together(group, m)
    return [s.first(m) for s in starts]


def _walk_together(group: list[Starts], m: int) -> None:
    """Walk the shortlists of ``group`` (all of one length) to ``m`` choices each, in place.

    Each data set's next choice is its first candidate at or after its position that is not
    near one chosen; the walk of a set stops at a candidate whose cost is not below the cut
    (the shortlist's last cost when it is a full :data:`SHORTLIST`, else none) or not finite.
    """
    shorts = [s._short for s in group]
    idx = np.stack([sh[0] for sh in shorts])  # type: ignore[index]
    scaled = np.stack([sh[1] for sh in shorts])  # type: ignore[index]  # (R, p, K)
    out = np.stack([sh[2] for sh in shorts])  # type: ignore[index]
    cost = np.stack([s.left[i] for s, i in zip(group, idx, strict=True)])
    at = np.array([s._at for s in group])
    need = np.array([m - len(s.chosen) for s in group])
    k = idx.shape[1]
    cut = cost[:, -1] if k == SHORTLIST else np.full(len(group), np.inf)
    pos, rows = np.arange(k), np.arange(len(group))
    live = need > 0
    while live.any():
        avail = ~out & (pos >= at[:, None])
        has = np.asarray(avail.any(axis=1))
        nxt = np.argmax(avail, axis=1)  # the first candidate not near one chosen
        c = cost[rows, nxt]
        ok = has & (c < cut) & np.isfinite(c)
        stop = live & ~ok  # a tie with the cut, or none left: the walk stops there
        at[stop] = np.where(has[stop], nxt[stop], k)
        live &= ok
        r = np.flatnonzero(live)
        if not r.size:
            break
        nr = nxt[r]
        out[r] |= np.max(np.abs(scaled[r] - scaled[r, :, nr][:, :, None]), axis=1) <= 0.05
        at[r] = nr + 1
        for i, j in zip(r.tolist(), idx[r, nr].tolist(), strict=True):
            group[i].chosen.append(j)
        need[r] -= 1
        live &= need > 0
    for i, s in enumerate(group):
        s._at = int(at[i])
        s._short[2][:] = out[i]  # type: ignore[index]


def _scaled(candidates: NDArray[np.float64]) -> NDArray[np.float64]:
    """Candidates over each parameter's spread, transposed ``(p, C)`` for fast distances."""
    scaled = np.array(candidates.T, order="C")  # a copy; reductions along rows: fast
    scaled /= np.maximum(np.abs(scaled).max(axis=1), 1.0)[:, None]
    return scaled


def starts_of(candidates: NDArray[np.float64], costs: NDArray[np.float64]) -> list[Starts]:
    """Return the :class:`Starts` of several data sets scored on the same candidates.

    They share the scaled candidates (made once).

    Parameters
    ----------
    candidates : ndarray, shape (C, p)
        Motion parameters (SI).
    costs : ndarray, shape (B, C)
        The grid costs of each data set (non-finite: never chosen).

    Returns
    -------
    list of Starts
        One per data set.
    """
    scaled = _scaled(candidates)
    left = np.where(np.isfinite(costs), costs, np.inf)
    short = _cheapest(left) if costs.shape[0] > 1 else [None] * costs.shape[0]
    return [Starts(candidates, cost, scaled, s) for cost, s in zip(costs, short, strict=True)]
