"""How far to trust an estimate: ``ok``, ``warning`` or ``none``, with the reasons.

Derived in one place (:func:`trust_of`) from the result's status and its warnings, so that
every warning any check adds (:func:`tmakit.results.checks.fit_warnings` and whatever extends
it) moves the trust without further code:

* ``none`` — no answer: the status is not ``converged`` (``unobservable``, ``did not
  converge``, ``diverged``).  No number is an answer; ``tma`` exits with status 4;
* ``warning`` — an answer with at least one warning (an improbable or too-small chi-square,
  angles that look like radians, far positions, ...): read the reasons before using it;
* ``ok`` — converged without a warning.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from .checks import SanityWarning

TRUST_OK = "ok"
TRUST_WARNING = "warning"
TRUST_NONE = "none"


@dataclass(frozen=True)
class Trust:
    """How far an estimate can be trusted, and why.

    Parameters
    ----------
    level : str
        :data:`TRUST_OK`, :data:`TRUST_WARNING` or :data:`TRUST_NONE`.
    reasons : list of SanityWarning
        Why not ``ok``: the status (code ``unobservable``, ``did not converge`` or
        ``diverged``, with the result's message and the unobservable directions in words) for
        ``none``, and every warning.
    """

    level: str
    reasons: list[SanityWarning] = field(default_factory=list)

    @property
    def answer(self) -> bool:
        """Whether the estimate is an answer (level ``ok`` or ``warning``)."""
        return self.level != TRUST_NONE

    def as_dict(self) -> dict[str, object]:
        """Return the JSON form.

        Returns
        -------
        dict
            ``{"trust": level, "trust_reasons": [{"code": ..., "message": ...}, ...]}``.
        """
        return {"trust": self.level, "trust_reasons": [r.as_dict() for r in self.reasons]}


def trust_of(result: object, warnings: Sequence[SanityWarning]) -> Trust:
    """Return the trust of an estimate from its status and warnings (the one rule).

    Parameters
    ----------
    result : EstimateResult or Bound
        The estimate (its ``status``, ``message`` and ``bound``'s unobservable directions), or
        a bound (no status: as converged; :func:`bound_trust` gives its reasons).
    warnings : sequence of SanityWarning
        Its warnings (:meth:`EstimateResult.warnings <tmakit.results.EstimateResult.warnings>`
        or more).

    Returns
    -------
    Trust
        ``none`` unless converged; else ``warning`` with any warning, else ``ok``.
    """
    # a bound (``tma crlb``) has no solve, so no status: it stands as computed
    status = str(getattr(result, "status", "converged"))
    reasons = list(warnings)
    if status != "converged":
        words = [str(result.message)] if result.message else []  # type: ignore[attr-defined]
        bound = result.bound  # type: ignore[attr-defined]
        if bound is not None:
            words += [d.sentence for d in bound.observability.directions]
        why = f"no answer: the estimate is {status}" + (f": {'; '.join(words)}" if words
                                                        else "")
        return Trust(TRUST_NONE, [SanityWarning(status, why), *reasons])
    return Trust(TRUST_WARNING if reasons else TRUST_OK, reasons)


def bound_trust(bound: object, warnings: Sequence[SanityWarning] = ()) -> Trust:
    """Return the trust of a Cramér-Rao bound (``tma crlb``), by :func:`trust_of`.

    Parameters
    ----------
    bound : Bound
        The bound (its unobservable directions).
    warnings : sequence of SanityWarning
        The measurements' warnings (:func:`tmakit.results.checks.measurement_warnings`).

    Returns
    -------
    Trust
        ``warning`` when a direction is unobservable (each one a reason, in words: the bound
        is infinite along it) or with any warning, else ``ok``.
    """
    directions = bound.observability.directions  # type: ignore[attr-defined]
    unseen = [SanityWarning("unobservable", "no estimator can determine this from these "
                                            f"measurements (infinite bound): {d.sentence}")
              for d in directions]
    return trust_of(bound, [*unseen, *warnings])
