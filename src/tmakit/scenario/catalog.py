"""The built-in scenarios that ship with tmakit, by name and title (standard library only)."""

from __future__ import annotations

import tomllib
from importlib import resources


def builtin_scenario_names() -> list[str]:
    """Names of the scenarios that ship with tmakit."""
    folder = resources.files("tmakit.scenario") / "builtin"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_scenarios() -> list[tuple[str, str]]:
    """``(name, one-line title)`` of every built-in scenario.

    Returns
    -------
    list of tuple of str
        Sorted by name; the title is "" if none.
    """
    out = []
    for name in builtin_scenario_names():
        text = (resources.files("tmakit.scenario") / "builtin" / f"{name}.toml").read_text("utf-8")
        out.append((name, str(tomllib.loads(text).get("title", ""))))
    return out
