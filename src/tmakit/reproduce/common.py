"""Shared pieces of the reproductions: a report of sections and tables, and scenario variants."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

from ..scenario import Scenario


@dataclass
class Section:
    title: str
    header: list[str]
    rows: list[list[object]]
    note: str = ""


@dataclass
class Reproduction:
    """What a reproduction computed, as titled tables, plus its key numbers for tests."""

    name: str
    sections: list[Section] = field(default_factory=list)
    figures: dict[str, object] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        return {"name": self.name, "figures": self.figures,
                "sections": [{"title": s.title, "header": s.header, "rows": s.rows,
                              "note": s.note} for s in self.sections]}


def with_noise(scn: Scenario, **by_kind: dict[str, float]) -> Scenario:
    """A copy of ``scn`` whose measurement plans of the named kinds get new noise values,
    e.g. ``with_noise(scn, power={"snr_db": 20.0}, frequency={"sigma": 19.0})``."""
    new = copy.deepcopy(scn)
    for plan in new.plans:
        for key, value in by_kind.get(plan.kind, {}).items():
            setattr(plan, key, value)
    return new


def only_kinds(scn: Scenario, kinds: tuple[str, ...]) -> Scenario:
    """A copy of ``scn`` keeping only the plans of the given kinds."""
    new = copy.deepcopy(scn)
    new.plans = [p for p in new.plans if p.kind in kinds]
    return new


def rel_diff(ours: float, paper: float) -> float:
    return abs(ours - paper) / abs(paper)
