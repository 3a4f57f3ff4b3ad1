"""How a solve went: the one vocabulary of every batch estimate's ``status``."""

from __future__ import annotations

from typing import Final, Literal, get_args

from .bound import Bound

__all__ = ["CONVERGED", "DIVERGED", "NOT_CONVERGED", "STATUSES", "UNOBSERVABLE", "Status"]

#: A batch estimate's status.
Status = Literal["converged", "did not converge", "unobservable", "diverged"]
CONVERGED: Final = "converged"
NOT_CONVERGED: Final = "did not converge"
UNOBSERVABLE: Final = "unobservable"
DIVERGED: Final = "diverged"
#: Every status, in that order.
STATUSES: tuple[Status, ...] = get_args(Status)


def fit_status(converged: bool, bound: Bound, unknowns: int) -> tuple[Status, str]:
    """Return the status of a fit and the sentence that explains it."""
    if not bound.observability.full_rank:
        return UNOBSERVABLE, (f"the data determine only {bound.rank} of the {unknowns} "
                              "unknowns; parameters marked unobservable are not estimates")
    if not converged:
        return NOT_CONVERGED, ("the iteration limit was reached before the convergence tests "
                               "were met")
    return CONVERGED, ""
