"""The deterministic outputs pinned before the architecture rebuild (issue 10).

Each entry is ``(name, setup, command)``: ``setup`` are ``tma`` commands run first in the same
folder (they write input files), ``command`` is the ``tma`` command whose ``--json`` output is
pinned.  ``python tests/pinned/make_pinned.py`` rewrites ``expected.json``; it is run only when
a result is meant to change, and the change is then explained in the commit.
"""

SIMULATE_GU = ["simulate", "gu2007", "--seed", "1", "-o", "gu.csv"]
SIMULATE_BO = ["simulate", "bearings-only-2d", "--seed", "3", "-o", "bo.csv"]
SIMULATE_HO = ["simulate", "hoerst2010", "--seed", "2", "-o", "ho.csv"]
SIMULATE_CS = ["simulate", "chen-sun-1", "--seed", "4", "-o", "cs.csv"]

PINNED = [
    ("reproduce-gu2007", [], ["reproduce", "gu2007", "--json"]),
    ("reproduce-hoerst2010", [], ["reproduce", "hoerst2010", "--json"]),
    ("reproduce-doppler-lecture", [], ["reproduce", "doppler-lecture", "--json"]),
    ("crlb-gu2007", [], ["crlb", "gu2007", "--json"]),
    ("crlb-gu2007-known-at", [], ["crlb", "gu2007", "--known-nuisance", "--at", "60", "--json"]),
    ("crlb-chen-sun-1", [], ["crlb", "chen-sun-1", "--json"]),
    ("crlb-bearings-only-2d", [], ["crlb", "bearings-only-2d", "--json"]),
    ("crlb-hoerst2010", [], ["crlb", "hoerst2010", "--json"]),
    ("estimate-gu2007", [SIMULATE_GU], ["estimate", "gu.csv", "--motion", "cv2d", "--json"]),
    ("estimate-gu2007-drift", [SIMULATE_GU],
     ["estimate", "gu.csv", "--motion", "cv2d", "--drift", "--json"]),
    ("estimate-gu2007-ratio", [SIMULATE_GU],
     ["estimate", "gu.csv", "--motion", "cv2d", "--method", "ratio",
      "--init", "x=4900,y=1200,vx=0,vy=0", "--json"]),
    ("estimate-bo", [SIMULATE_BO], ["estimate", "bo.csv", "--motion", "cv2d", "--json"]),
    ("estimate-chen-sun-1", [SIMULATE_CS], ["estimate", "cs.csv", "--motion", "cv3d", "--json"]),
    ("estimate-hoerst2010-m2", [SIMULATE_HO],
     ["estimate", "ho.csv", "--motion", "curvilinear:2", "--json"]),
    ("track-bo-ekf", [SIMULATE_BO], ["track", "bo.csv", "--filter", "ekf", "--json"]),
    ("track-bo-ukf", [SIMULATE_BO], ["track", "bo.csv", "--filter", "ukf", "--json"]),
    ("track-bo-mgekf", [SIMULATE_BO], ["track", "bo.csv", "--filter", "mgekf", "--json"]),
    ("track-bo-pf", [SIMULATE_BO],
     ["track", "bo.csv", "--filter", "pf", "--particles", "2000", "--seed", "7", "--json"]),
    ("track-gu2007-ekf", [SIMULATE_GU], ["track", "gu.csv", "--filter", "ekf", "--json"]),
    ("track-cs-ekf", [SIMULATE_CS], ["track", "cs.csv", "--filter", "ekf", "--json"]),
]
