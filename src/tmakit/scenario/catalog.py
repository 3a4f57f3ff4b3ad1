"""The built-in scenarios that ship with tmakit, listed by name and title.

Only the standard library is used (``tomllib``, ``importlib.resources``): listing the
scenarios (``tma scenarios``) needs neither numpy nor pydantic.  Loading one is
:func:`tmakit.scenario.files.load_scenario`.
"""

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
        ``(name, title)`` sorted by name; the title is the file's ``title`` ("" if none).
    """
    out = []
    for name in builtin_scenario_names():
        text = (resources.files("tmakit.scenario") / "builtin" / f"{name}.toml").read_text("utf-8")
        out.append((name, str(tomllib.loads(text).get("title", ""))))
    return out
