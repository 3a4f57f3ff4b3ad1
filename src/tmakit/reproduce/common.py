"""Shared pieces of the reproductions: a report of sections and tables, and scenario variants."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..scenario.model import Scenario


@dataclass
class Section:
    """One titled table of a reproduction's report.

    Parameters
    ----------
    title : str
        Section title.
    header : list of str
        Column headings (with units where they have them).
    rows : list of list
        The table's rows, one value per column.
    note : str, optional
        A paragraph printed under the table.
    """

    title: str
    header: list[str]
    rows: Sequence[Sequence[object]]
    note: str = ""


@dataclass
class Reproduction:
    """What a reproduction computed, as titled tables, plus its key numbers for tests.

    Parameters
    ----------
    name : str
        Reproduction name (``gu2007``, ``hoerst2010``, ...).
    sections : list of Section, optional
        The report's tables, in order.
    figures : dict, optional
        Key numbers by name (units in the names, e.g. ``rms_m``), JSON-ready.
    labels : dict, optional
        For a figure that is a list, the name and unit of each entry (``("x", "m")``), for
        the printed report (not in the JSON).
    print_figures : bool, optional
        Print the figures under the tables (False where the tables already show them; the
        JSON has them always).
    """

    name: str
    sections: list[Section] = field(default_factory=list)
    figures: dict[str, object] = field(default_factory=dict)
    labels: dict[str, list[tuple[str, str]]] = field(default_factory=dict)
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


def rel_diff(ours: float, paper: float) -> float:
    """Give the relative difference ``|ours - paper| / |paper|``."""
    return abs(ours - paper) / abs(paper)
