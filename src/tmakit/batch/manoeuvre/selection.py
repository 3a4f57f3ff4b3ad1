"""Model selection of the manoeuvre estimator.

The number of manoeuvres (BIC or sequential likelihood-ratio tests, :func:`select_order`) and
the accelerations the data need (backward elimination, :func:`sparsify`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...core import chi2 as chi2_dist
from ...core.arrays import Array
from .search import CRITERIA, ManoeuvreSearch, ManoeuvreSettings, OrderFit, lm_fit


@dataclass
class OrderSelection:
    """Chi2 and the criteria of every order tried, and the order chosen.

    Parameters
    ----------
    criterion : {"bic", "lrt"}
    alpha : float
        Level of the likelihood-ratio tests.
    n_measurements : int
        ``N``, the noise covariance's rank.
    orders : list of dict
        Per order: ``manoeuvres``, ``chi2``, ``unknowns``, ``bic``, ``lr_statistic``, ``p_value``
        (None for the first), ``converged``.
    chosen : int
        The number of manoeuvres chosen.

    References
    ----------
    Schwarz (1978) (BIC).
    """

    criterion: str
    alpha: float
    n_measurements: int
    orders: list[dict[str, float | int | None]]
    chosen: int

    def as_dict(self) -> dict[str, object]:
        """Give the selection as JSON-ready data.

        Returns
        -------
        dict of str to object
            The fields, non-finite numbers as None.
        """
        def clean(v: object) -> object:
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {"criterion": self.criterion, "alpha": self.alpha if self.criterion == "lrt"
                else None, "n_measurements": self.n_measurements, "chosen": self.chosen,
                "orders": [{k: clean(v) for k, v in o.items()} for o in self.orders]}

    def summary(self) -> str:
        """Tabulate the orders tried, the chosen one marked.

        Returns
        -------
        str
            The table, one line per order.
        """
        lines = [f"number of manoeuvres: {self.chosen} (criterion "
                 + ("BIC" if self.criterion == "bic" else
                    f"likelihood-ratio tests at alpha = {self.alpha:g}") + ")",
                 f"  {'M':>2}  {'chi2':>12}  {'unknowns':>8}  {'BIC':>12}  {'LR vs M-1':>10}"
                 f"  {'p-value':>9}"]
        for o in self.orders:
            lr = o["lr_statistic"]
            pv = o["p_value"]
            lines.append(f"  {o['manoeuvres']:>2}  {o['chi2']:12.3f}  {o['unknowns']:>8}  "
                         f"{o['bic']:12.3f}  "
                         + (f"{lr:10.3f}  {pv:9.3g}" if lr is not None else f"{'':>10}  "
                            f"{'':>9}")
                         + ("  <- chosen" if o["manoeuvres"] == self.chosen else ""))
        return "\n".join(lines)


def select_order(fits: list[OrderFit], n: int, criterion: str = "bic", alpha: float = 0.01
                 ) -> OrderSelection:
    """Choose the number of manoeuvres from fits of consecutive orders.

    Parameters
    ----------
    fits : list of OrderFit
        Orders ``0, 1, ...``.
    n : int
        ``N``, independent measurements.
    criterion : {"bic", "lrt"}
        ``"bic"`` minimises ``chi2 + k ln N``; ``"lrt"`` adds a manoeuvre while the
        likelihood-ratio test rejects at ``alpha``.
    alpha : float

    Returns
    -------
    OrderSelection

    Raises
    ------
    ValueError
        For an unknown criterion.

    References
    ----------
    Schwarz (1978) (BIC).
    """
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    orders: list[dict[str, float | int | None]] = []
    for i, f in enumerate(fits):
        lr = pv = None
        if i > 0 and fits[i - 1].manoeuvres == f.manoeuvres - 1:
            lr = max(fits[i - 1].chi2 - f.chi2, 0.0)
            dof = f.unknowns - fits[i - 1].unknowns
            # with accelerations selected, a manoeuvre can come with fewer unknowns than the
            # order below holds: any chi2 drop then favours it outright
            pv = float(chi2_dist.sf(lr, dof)) if dof > 0 else (0.0 if lr > 0 else 1.0)
        orders.append({"manoeuvres": f.manoeuvres, "chi2": f.chi2, "unknowns": f.unknowns,
                       "bic": f.chi2 + f.unknowns * math.log(n), "lr_statistic": lr,
                       "p_value": pv, "converged": f.converged})
    if criterion == "bic":
        bic = [f.chi2 + f.unknowns * math.log(n) if np.isfinite(f.chi2) else np.inf
               for f in fits]  # (the orders' "bic")
        chosen = fits[int(np.argmin(bic))].manoeuvres
    else:
        chosen = fits[0].manoeuvres
        for i in range(1, len(fits)):
            pv = orders[i]["p_value"]
            if pv is None or pv >= alpha:
                break
            chosen = fits[i].manoeuvres
    return OrderSelection(criterion, alpha, n, orders, chosen)


def fit_criterion(s: ManoeuvreSettings) -> str:
    """Say in words the rule that holds an acceleration at zero (for result messages)."""
    return ("BIC: holding one raised chi2 by less than ln N" if s.criterion == "bic" else
            f"holding one raised chi2 by less than the chi-square(1) quantile "
            f"{1 - s.alpha:g}")


def unknown_price(s: ManoeuvreSettings, n: int) -> float:
    """Give what one unknown must lower chi2 by to be kept, by the settings' criterion."""
    return math.log(n) if s.criterion == "bic" else float(chi2_dist.ppf(1.0 - s.alpha, 1))


def may_hold(free: NDArray[np.bool_], i: int, m: int) -> bool:
    """Whether acceleration ``i`` may be held at zero (not leaving two straight legs side by side).

    Parameters
    ----------
    free : ndarray of bool
        The internal parameters fitted now.
    i : int
        Internal index ``4 + 2 * segment + {0: a_t, 1: a_n}``.
    m : int
        The number of manoeuvres.

    Returns
    -------
    bool
    """
    mask = free.copy()
    mask[i] = False
    seg = (i - 4) // 2
    both_held = [not mask[4 + 2 * s] and not mask[5 + 2 * s] for s in range(m + 1)]
    return not any(both_held[s] and both_held[seg] for s in (seg - 1, seg + 1) if 0 <= s <= m)


def hold_starts(search: ManoeuvreSearch, theta: Array, i: int, m: int) -> Array:
    """Make starts for a fit with acceleration ``i`` held at zero."""
    s = search.s
    base = theta.copy()
    base[i] = 0.0
    out = [base]
    seg = (i - 4) // 2
    k0 = 6 + 2 * m
    for k in (seg - 1, seg):  # change-over times t_seg (index seg - 1) and t_{seg+1}
        if not 0 <= k < m:
            continue
        lo = theta[k0 + k - 1] if k else search.t0
        hi = theta[k0 + k + 1] if k + 1 < m else search.t_end
        for d in (-1.0, 1.0):
            t = theta[k0 + k] + d * s.grid_step
            if lo + s.min_segment / 2 < t < hi - s.min_segment / 2:
                q = base.copy()
                q[k0 + k] = t
                out.append(q)
    return np.array(out)


def _best_hold(search: ManoeuvreSearch, current: OrderFit, free: NDArray[np.bool_],
               price: float) -> tuple[float, int, Array, Array] | None:
    """Find the acceleration whose hold raises chi2 least."""
    m = current.manoeuvres
    pr = search.problem(m)
    best: tuple[float, int, Array, Array] | None = None
    for i in range(4, 6 + 2 * m):
        if not free[i] or not may_hold(free, i, m):
            continue
        mask = free.copy()
        mask[i] = False
        starts = hold_starts(search, current.theta, i, m)
        # ranking holds needs chi2 to ~0.04; a start that cannot come within the price of the
        # current fit is dropped early
        sol = lm_fit(pr, starts, mask, 30, rtol=0.0, atol=0.02, max_reject=8, stall=1e-2,
                     prune=price / 2.0, best=current.chi2 / 2.0)
        j = int(np.argmin(np.where(np.isfinite(sol.cost), sol.cost, np.inf)))
        if best is None or 2.0 * sol.cost[j] < best[0]:
            best = (float(2.0 * sol.cost[j]), i, sol.theta[j], sol.nuisance[j])
    return best


def sparsify(search: ManoeuvreSearch, fit: OrderFit) -> OrderFit:
    """Hold at zero the accelerations the data do not need (``accelerations="select"``).

    Backward elimination: the hold that raises chi2 least is kept while the rise is below the
    price of one unknown (``ln N`` for BIC, Schwarz (1978); the chi-square(1) quantile for the
    test; two together below twice it, :data:`LOOK_AHEAD`); the change-over times are then
    profiled again (docs/estimation.md).
    """
    m = fit.manoeuvres
    if not np.isfinite(fit.chi2):
        return fit
    s = search.s
    n = search.problem(m).noise.rank
    price = unknown_price(s, n)
    free = fit.free_mask().copy()
    current, held = fit, False
    ahead: list[OrderFit] = []
    while True:
        chain = _hold_chain(search, current, free, price)
        if not chain:
            break
        rise = chain[-1].chi2 - current.chi2
        if not rise < price * len(chain):
            ahead = chain  # the sparser patterns the data do not pay for: candidates
            break
        current, free, held = chain[-1], chain[-1].free_mask().copy(), True
    if not held:
        fit.alternatives = [*fit.alternatives, *_refit(search, ahead)]
        return fit
    out = search.fit_from(m, current.theta[None], free)
    out.iterations += fit.iterations
    if s.polish_rounds and m:
        out = search.polish(out, reach=2.0 * s.grid_step)
    out.profile_times, out.profile_chi2 = fit.profile_times, fit.profile_chi2
    out.alternatives = [*out.alternatives, *_refit(search, ahead)]
    return out


LOOK_AHEAD = 2  # holds tried together by sparsify when one alone does not pay for itself


def _hold_chain(search: ManoeuvreSearch, current: OrderFit, free: NDArray[np.bool_],
                price: float) -> list[OrderFit]:
    """Hold the cheapest acceleration, then (while the holds do not pay) the next, greedily."""
    m = current.manoeuvres
    chain: list[OrderFit] = []
    mask = free.copy()
    at = current
    for _ in range(LOOK_AHEAD):
        best = _best_hold(search, at, mask, price)
        if best is None:
            break
        mask = mask.copy()
        mask[best[1]] = False
        at = OrderFit(m, best[2], best[3], best[0], search.unknowns(m, mask), False,
                      at.iterations, at.starts, free=mask.copy())
        chain.append(at)
        if at.chi2 - current.chi2 < price * len(chain):
            break
    return chain


def _refit(search: ManoeuvreSearch, fits: list[OrderFit]) -> list[OrderFit]:
    """Refit to convergence the sparser patterns the elimination looked at and left."""
    out = []
    for f in fits:
        r = search.fit_from(f.manoeuvres, f.theta[None], f.free_mask())
        if r.converged and np.isfinite(r.chi2):
            out.append(r)
    return out
