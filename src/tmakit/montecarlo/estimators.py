"""The estimators a Monte Carlo study can run, by name.

``"ml"`` is always there (:func:`tmakit.batch.estimate`, batched across runs by
:mod:`.runs`); the others are those of the registry :mod:`tmakit.batch.methods` (``METHODS``
and ``estimate_with``), when it is installed.
"""

from __future__ import annotations

import inspect
from importlib import import_module
from types import ModuleType
from typing import Any

__all__ = ["METHODS_MODULE", "available_estimators", "check_estimator", "estimator_registry"]

#: The module that registers the estimators other than ``ml``.
METHODS_MODULE = "tmakit.batch.methods"


def estimator_registry() -> ModuleType | None:
    """The estimator registry.

    Returns
    -------
    module or None
        :mod:`tmakit.batch.methods` (``METHODS``, ``estimate_with``), or ``None`` where it
        is not installed.
    """
    try:
        return import_module(METHODS_MODULE)
    except ModuleNotFoundError as e:
        if e.name != METHODS_MODULE:
            raise
        return None


def available_estimators() -> tuple[str, ...]:
    """Names accepted as ``estimator`` by :func:`tmakit.montecarlo.monte_carlo`.

    Returns
    -------
    tuple of str
        The keys of ``tmakit.batch.methods.METHODS`` (``ml`` first if missing there), or
        only ``"ml"`` where that registry is not installed.
    """
    reg = estimator_registry()
    if reg is None or not hasattr(reg, "METHODS"):
        return ("ml",)
    names = tuple(str(k) for k in reg.METHODS)
    return names if "ml" in names else ("ml", *names)


def _takes_known_nuisance(func: Any) -> bool:
    try:
        params = inspect.signature(func).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False
    return "known_nuisance" in params or any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


def check_estimator(estimator: str, known_nuisance: bool) -> None:
    """Refuse an estimator the study cannot run.

    Parameters
    ----------
    estimator : str
        A name of :func:`available_estimators`.
    known_nuisance : bool
        Whether the estimator is to be given the true nuisance values.

    Raises
    ------
    ValueError
        An unknown name, or known nuisance values for an estimator that cannot take them.
    """
    names = available_estimators()
    if not isinstance(estimator, str) or estimator not in names:
        raise ValueError(f"unknown estimator {estimator!r}; expected one of {', '.join(names)}")
    if known_nuisance and estimator != "ml":
        reg = estimator_registry()
        if reg is None or not _takes_known_nuisance(reg.estimate_with):
            raise ValueError(f"estimator {estimator!r} cannot be given known nuisance "
                             "parameters; use known_nuisance=False or estimator 'ml'")
