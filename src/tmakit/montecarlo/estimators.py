"""The estimators a Monte Carlo study can run, by name.

They are the method registry :data:`tmakit.batch.methods.METHODS`; ``"ml"`` is batched across runs
by :mod:`.runs`, the others are called run by run through
:func:`tmakit.batch.methods.estimate_with`.
"""

from __future__ import annotations

from ..batch.methods import METHODS

__all__ = ["available_estimators", "check_estimator"]


def available_estimators() -> tuple[str, ...]:
    """Names accepted as ``estimator`` by :func:`tmakit.montecarlo.monte_carlo`.

    Returns
    -------
    tuple of str
        The keys of :data:`tmakit.batch.methods.METHODS`.
    """
    return tuple(METHODS)


def check_estimator(estimator: str, known_nuisance: bool) -> None:
    """Refuse an estimator the study cannot run."""
    names = available_estimators()
    if not isinstance(estimator, str) or estimator not in names:
        raise ValueError(f"unknown estimator {estimator!r}; expected one of {', '.join(names)}")
    if known_nuisance and not METHODS[estimator].takes_known_nuisance:
        raise ValueError(f"estimator {estimator!r} cannot be given known nuisance "
                         "parameters; use known_nuisance=False or estimator 'ml'")
