"""Reproductions of the papers tmakit is built from: ``tma reproduce NAME``."""

from __future__ import annotations

REPRODUCTIONS = {
    "gu2007": "tmakit.reproduce.gu2007",
    "doppler-lecture": "tmakit.reproduce.doppler_lecture",
    "hoerst2010": "tmakit.reproduce.hoerst2010",
    "chen-sun": "tmakit.reproduce.chen_sun",
    "hurtado2008": "tmakit.reproduce.hurtado2008",
    "chan-ho1994": "tmakit.reproduce.chan_ho1994",
    "ho-xu2004": "tmakit.reproduce.ho_xu2004",
}
"""Name -> module with a ``run(runs, seed, progress) -> Reproduction`` function (and, if it
draws the paper's figure, ``plot(reproduction, path)``)."""
