"""Sanity checks that speak: radian bearings are warned about, improbable fits are flagged.

Issue 12's figure: "Radian bearings: warned about in 100 % of 100 seeded files; improbable
chi-square: flagged whenever p < 0.001."

* **Radians.** For each seed ``s`` the bearings-only scenario is simulated with
  ``rng=default_rng([seed, s])``, turned by a random angle (so that the bearings cover every
  sector: :func:`rotated`), written to a CSV file, its bearing values rewritten in radians
  (the file still says degrees), and read back with :func:`tmakit.read_measurements`; the file
  is *warned about* when :func:`tmakit.results.measurement_warnings` returns a ``radians``
  warning.  The same files in degrees give the false-alarm count.
* **Improbable chi-square.** For each seed the scenario is simulated and its stated sigma
  divided by a factor ``f`` drawn first, uniformly from [1, 1.3] (so that some fits are improbable
  and some are not), and fitted by maximum likelihood; the fit is *flagged* when
  :meth:`EstimateResult.warnings` holds ``improbable-chi2``.  The script counts flags among
  fits with ``p < 0.001`` and among the others (which must be 0), and refits the flagged ones
  with the sigma rescaled from the residuals (``--scale-sigma``) to show chi2/dof back at 1.

Run::

    PYTHONPATH=src python benchmarks/sanity_checks.py --files 100 --seed 0
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.results import measurement_warnings, normalised_residuals, scale_sigma
from tmakit.results.checks import CHI2_P_LIMIT, chi2_probability


def rotated(meas: tk.MeasurementSet, angle: float) -> tk.MeasurementSet:
    """Return the same bearings-only geometry turned clockwise by ``angle`` about the origin.

    Bearings gain ``angle`` (wrapped to [0, 2 pi)); sensor positions and velocities turn
    with them, so the rotated set is exactly a simulation of the rotated scenario.

    Parameters
    ----------
    meas : MeasurementSet
        Bearing measurements.
    angle : float
        Rotation (rad, clockwise).

    Returns
    -------
    MeasurementSet
        The rotated set.
    """
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # clockwise in (E, N)
    st = meas.sensor_state
    state = np.concatenate([st[:, :3] @ rot.T, st[:, 3:] @ rot.T], axis=1)
    return tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind,
                                     np.mod(meas.value_si + angle, 2 * np.pi), meas.sigma_si,
                                     state, metadata={"scenario": "bearings-only-2d rotated"})


def radians_file(meas: tk.MeasurementSet, folder: Path, index: int) -> tuple[Path, Path]:
    """Write the set in degrees and a copy whose bearing values are in radians.

    Parameters
    ----------
    meas : MeasurementSet
        The simulated measurements.
    folder : Path
        Where to write.
    index : int
        The file's number.

    Returns
    -------
    tuple of Path
        The file in degrees and the one in radians (both say degrees).
    """
    good = folder / f"deg_{index}.csv"
    tk.write_measurements(meas, good)
    lines = good.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    cols = lines[header].split(",")
    k_kind, k_value = cols.index("kind"), cols.index("value")
    for i in range(header + 1, len(lines)):
        cells = lines[i].split(",")
        if cells[k_kind] == "bearing":
            cells[k_value] = repr(float(np.radians(float(cells[k_value]))))
        lines[i] = ",".join(cells)
    bad = folder / f"rad_{index}.csv"
    bad.write_text("\n".join(lines) + "\n")
    return good, bad


def radians_study(files: int, seed: int) -> tuple[int, int]:
    """Count the radian files warned about and the degree files warned about (false alarms).

    Parameters
    ----------
    files : int
        Number of seeded files.
    seed : int
        Base seed.

    Returns
    -------
    tuple of int
        ``(radian files warned, degree files warned)``.
    """
    scn = tk.load_scenario("bearings-only-2d")
    warned = false_alarms = 0
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(files):
            rng = np.random.default_rng([seed, i])
            meas = rotated(scn.simulate(rng=rng), float(rng.uniform(0.0, 2.0 * np.pi)))
            good, bad = radians_file(meas, Path(tmp), i)
            codes = [w.code for w in measurement_warnings(tk.read_measurements(bad))]
            warned += "radians" in codes
            codes = [w.code for w in measurement_warnings(tk.read_measurements(good))]
            false_alarms += "radians" in codes
    return warned, false_alarms


def chi2_study(files: int, seed: int) -> dict[str, int | float]:
    """Fit seeded files with understated sigma; count flags against ``p < 0.001``.

    Parameters
    ----------
    files : int
        Number of seeded files.
    seed : int
        Base seed.

    Returns
    -------
    dict
        ``improbable`` (fits with p < 0.001), ``flagged_improbable``, ``plausible``,
        ``flagged_plausible``, ``rescaled_chi2_dof_max`` (after ``scale_sigma``).
    """
    scn = tk.load_scenario("bearings-only-2d")
    counts: dict[str, int | float] = {"improbable": 0, "flagged_improbable": 0, "plausible": 0,
                                      "flagged_plausible": 0, "rescaled_chi2_dof_max": 0.0}
    for i in range(files):
        rng = np.random.default_rng([seed, 10_000 + i])
        f = float(rng.uniform(1.0, 1.3))
        meas = scn.simulate(rng=rng)
        meas = tk.MeasurementSet.from_si(meas.time, meas.sensor, meas.kind, meas.value_si,
                                         meas.sigma_si / f, meas.sensor_state,
                                         metadata=meas.metadata)
        res = tk.estimate(meas, scn.motion)
        p = chi2_probability(res.chi2, res.dof)
        flagged = any(w.code == "improbable-chi2" for w in res.warnings(meas))
        key = "improbable" if p is not None and p < CHI2_P_LIMIT else "plausible"
        counts[key] += 1
        counts[f"flagged_{key}"] += flagged
        if flagged:
            scaled, _ = scale_sigma(meas, normalised_residuals(res, meas), res.dof)
            again = tk.estimate(scaled, scn.motion)
            counts["rescaled_chi2_dof_max"] = max(float(counts["rescaled_chi2_dof_max"]),
                                                  again.chi2 / again.dof)
    return counts


def main() -> None:
    """Run both studies and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    warned, false_alarms = radians_study(args.files, args.seed)
    print(f"radian bearings: warned about in {warned} of {args.files} seeded files "
          f"({100 * warned / args.files:.0f} %); the same files in degrees: "
          f"{false_alarms} false alarms")
    c = chi2_study(args.files, args.seed)
    print(f"improbable chi2 (p < {CHI2_P_LIMIT:g}): flagged in {c['flagged_improbable']} of "
          f"{c['improbable']} fits; plausible fits (p >= {CHI2_P_LIMIT:g}) flagged: "
          f"{c['flagged_plausible']} of {c['plausible']}")
    print(f"after --scale-sigma on the flagged fits: chi2/dof at most "
          f"{c['rescaled_chi2_dof_max']:.3f}")


if __name__ == "__main__":
    main()
