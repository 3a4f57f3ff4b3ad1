"""The docs name only modules, files and objects that exist (they moved in the rebuild)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])
PATH = re.compile(r"`((?:src/|tests/|benchmarks/)?(?:tmakit/)?[a-z_]+(?:/[a-z_]+)*\.py)`")
DOTTED = re.compile(r"`(tmakit(?:\.[A-Za-z_][A-Za-z0-9_]*)+)`")


def exists(rel: str) -> bool:
    """A path as the docs write it: from the repository, from src/, or from src/tmakit/."""
    return any((base / rel).exists() for base in (ROOT, ROOT / "src", ROOT / "src" / "tmakit",
                                                 ROOT / "benchmarks"))


def resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_named_files_and_objects_exist(doc):
    text = doc.read_text(encoding="utf-8")
    missing = [p for p in PATH.findall(text) if not exists(p)]
    missing += [d for d in DOTTED.findall(text) if not resolves(d)]
    assert missing == [], f"{doc.name} names what does not exist: {sorted(set(missing))}"
