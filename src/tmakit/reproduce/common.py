"""Shared pieces of the reproductions: a report of sections and tables, and scenario variants."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..scenario.model import Scenario


@dataclass
class Section:
    """One titled table of a reproduction's report."""

    title: str  # Section title
    header: list[str]  # Column headings (with units where they have them)
    rows: Sequence[Sequence[object]]  # The table's rows, one value per column
    note: str = ""  # A paragraph printed under the table


@dataclass
class Reproduction:
    """What a reproduction computed, as titled tables, plus its key numbers for tests."""

    name: str  # Reproduction name (``gu2007``, ``hoerst2010``, ...)
    sections: list[Section] = field(default_factory=list)  # The report's tables, in order
    #: Key numbers by name (units in the names, e.g. ``rms_m``), JSON-ready
    figures: dict[str, object] = field(default_factory=dict)
    #: For a figure that is a list, the name and unit of each entry (``("x", "m")``), for the
    #: printed report (not in the JSON)
    labels: dict[str, list[tuple[str, str]]] = field(default_factory=dict)
    #: Print the figures under the tables (False where the tables already show them; the JSON has
    #: them always)
    print_figures: bool = True

    def as_dict(self) -> dict[str, object]:
        """Give the reproduction as JSON-ready data."""
        return {"name": self.name, "figures": self.figures,
                "sections": [{"title": s.title, "header": s.header, "rows": s.rows,
                              "note": s.note} for s in self.sections]}


def with_noise(scn: Scenario, **by_kind: dict[str, float]) -> Scenario:
    """Copy a scenario, giving the measurement plans of the named kinds new noise values."""
    new = copy.deepcopy(scn)
    for plan in new.plans:
        for key, value in by_kind.get(plan.kind, {}).items():
            setattr(plan, key, value)
    return new


def only_kinds(scn: Scenario, kinds: tuple[str, ...]) -> Scenario:
    """Copy a scenario, keeping only the measurement plans of the given kinds."""
    new = copy.deepcopy(scn)
    new.plans = [p for p in new.plans if p.kind in kinds]
    return new
