"""Reproductions of the papers tmakit is built from: ``tma reproduce NAME``."""

from __future__ import annotations

REPRODUCTIONS = {
    "gu2007": "tmakit.reproduce.gu2007",
    "doppler-lecture": "tmakit.reproduce.doppler_lecture",
}
"""Name -> module with a ``run(runs, seed, progress) -> Reproduction`` function."""
