"""How far to trust an estimate: ``ok``, ``warning`` or ``none`` (not converged), with reasons."""

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
        ``ok``, ``warning`` or ``none``.
    reasons : list of SanityWarning
        The status (for ``none``) and every warning.
    """

    level: str
    reasons: list[SanityWarning] = field(default_factory=list)

    @property
    def answer(self) -> bool:
        """Whether the estimate is an answer (level ``ok`` or ``warning``)."""
        return self.level != TRUST_NONE

    def as_dict(self) -> dict[str, object]:
        """Return ``{"trust": level, "trust_reasons": [{"code", "message"}, ...]}``.

        Returns
        -------
        dict
        """
        return {"trust": self.level, "trust_reasons": [r.as_dict() for r in self.reasons]}


def trust_of(result: object, warnings: Sequence[SanityWarning]) -> Trust:
    """Return the trust of an estimate (or of a bound: converged) from its status and warnings.

    Parameters
    ----------
    result, warnings : EstimateResult or Bound, sequence of SanityWarning

    Returns
    -------
    Trust
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
    """Return the trust of a Cramér-Rao bound: a warning per unobservable direction.

    Parameters
    ----------
    bound, warnings : Bound, sequence of SanityWarning
        The bound and the measurements' warnings.

    Returns
    -------
    Trust
    """
    directions = bound.observability.directions  # type: ignore[attr-defined]
    unseen = [SanityWarning("unobservable", "no estimator can determine this from these "
                                            f"measurements (infinite bound): {d.sentence}")
              for d in directions]
    return trust_of(bound, [*unseen, *warnings])
