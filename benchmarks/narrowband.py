"""Issue 29 figure: narrowband frequency TMA, several tonals of one contact, each with its own f0.

A contact (constant course and speed, 3.6 m/s) passes the own ship (6 m/s, one turn of 90°
half way); it radiates two tonals, A at 150 Hz and B at 310 Hz, carried by
sound at 1500 m/s.  Every 30 s for an hour the own ship measures a bearing (1°) and the
frequency of each tonal (0.05 Hz).  ``--runs`` seeded runs (default 200) are fitted by
``tk.estimate`` (cv2d, no initial guess, each tonal's f0 eliminated) in four ways: bearings
and both tonals, both tonals without bearings, tonal A alone and tonal B alone (frequency only).
The motion's reference time is the closest approach, so ``x, y`` are the position there.

Printed per case: the RMSE of each f0 and of the position at closest approach over the runs,
divided by the CRLB (``tk.crlb`` at the truth, f0 unknown): within 1.2 is the figure.  Frequencies
alone leave a ghost (a second track that fits as well): where ``tk.estimate`` reports several
solutions, the one nearest the truth is scored, and the runs where it was not the first are
counted (never one picked silently: a ghost the fit did not report would be scored as it is).
The CRLB of the position with both tonals against each alone is printed beside.

    python benchmarks/narrowband.py [--runs 200]
"""

from __future__ import annotations

import argparse

import numpy as np

import tmakit as tk

C = 1500.0
F0 = {"A": 150.0, "B": 310.0}
DT, SPAN = 30.0, 3600.0
SIGMA_DEG, SIGMA_HZ = 1.0, 0.02
OPTIONS = {"frequency": {"propagation_speed": C}}


def geometry() -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """The own ship's states and cut times; the closest approach's time and the contact there."""
    t = np.arange(0.0, SPAN, DT)
    turn = SPAN / 2
    v1, v2 = np.array([6.0, 0.0]), np.array([0.0, 6.0])
    before = t < turn
    pos = np.where(before[:, None], v1 * t[:, None], v1 * turn + v2 * (t - turn)[:, None])
    own = np.zeros((t.size, 6))
    own[:, :2], own[:, 3:5] = pos, np.where(before[:, None], v1, v2)
    start, vel = np.array([6000.0, 8000.0]), np.array([-3.0, -2.0])  # the contact at t = 0
    k = int(np.argmin(np.hypot(*(start + vel * t[:, None] - pos).T)))
    return own, t, float(t[k]), np.concatenate([start + vel * t[k], vel])


def rows(own: np.ndarray, t: np.ndarray, tonals: str, bearings: bool) -> tk.MeasurementSet:
    """The noise-free rows' frame (values filled later): bearings and the tonals named."""
    kinds, labels, times, states = [], [], [], []
    for i, ti in enumerate(t):
        for kind, label in ([("bearing", "")] if bearings else []) + [
                ("frequency", lab) for lab in tonals]:
            kinds.append(kind)
            labels.append(label)
            times.append(ti)
            states.append(own[i])
    kinds_a = np.array(kinds)
    value = np.where(kinds_a == "bearing", 0.0, 100.0)
    sigma = np.where(kinds_a == "bearing", np.deg2rad(SIGMA_DEG), SIGMA_HZ)
    return tk.MeasurementSet.from_si(np.array(times), np.full(len(times), "own"), kinds_a,
                                     value, sigma, np.array(states), tonal=labels)


def nuisance_of(tonals: str) -> dict[str, float]:
    """The true f0 by nuisance name (``carrier`` for one tonal)."""
    if len(tonals) == 1:
        return {"carrier": F0[tonals]}
    return {f"carrier[{lab}]": F0[lab] for lab in tonals}


def study(frame: tk.MeasurementSet, motion: tk.MotionModel, theta: np.ndarray, tonals: str,
          runs: int, seed: int) -> dict[str, float]:
    """RMSE / CRLB of each f0 and of the position at closest approach over ``runs`` fits."""
    obs = tk.ObservationModel(frame, motion, OPTIONS)
    truth_nu = nuisance_of(tonals)
    clean = obs.predict(theta, obs.nuisance_vector(truth_nu))
    bound = tk.crlb(frame, motion, theta, nuisance=truth_nu, options=OPTIONS)
    rng = np.random.default_rng(seed)
    pos_err, f_err, failed, several, ghost = [], {n: [] for n in truth_nu}, 0, 0, 0
    for _ in range(runs):
        noisy = clean + rng.normal(size=clean.size) * frame.sigma_si
        meas = tk.MeasurementSet.from_si(frame.time, frame.sensor, frame.kind, noisy,
                                         frame.sigma_si, frame.sensor_state, tonal=frame.tonal)
        res = tk.estimate(meas, motion, options=OPTIONS)
        if res.status != "converged":
            failed += 1
            continue
        fits = [s.result for s in res.ranked_solutions()]  # the truth's: the nearest one
        near = min(fits, key=lambda r: float(np.sum((r.estimate[:2] - theta[:2]) ** 2)))
        several += len(fits) > 1
        ghost += near is not fits[0]
        pos_err.append(np.sum((near.estimate[:2] - theta[:2]) ** 2))
        for n in truth_nu:
            f_err[n].append((near.nuisance[n][0] - truth_nu[n]) ** 2)
    std = np.asarray(bound.std)
    crlb_pos = float(np.sqrt(std[0] ** 2 + std[1] ** 2))
    out = {"pos": float(np.sqrt(np.mean(pos_err))) / crlb_pos, "crlb_pos_m": crlb_pos,
           "failed": failed, "several": several, "ghost": ghost}
    for j, n in enumerate(truth_nu):
        out[n] = float(np.sqrt(np.mean(f_err[n]))) / float(std[4 + j])
        out[f"crlb {n}"] = float(std[4 + j])
    return out


def main() -> None:
    """Print the figure."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=29)
    args = parser.parse_args()
    own, t, t_cpa, theta = geometry()
    motion = tk.ConstantVelocity(2, ref_time=t_cpa)
    print(f"{args.runs} runs per case; RMSE / CRLB (figure: <= 1.2)")
    for name, tonals, bearings in (("bearings + tonals A, B", "AB", True),
                                   ("tonals A, B (frequency only)", "AB", False),
                                   ("tonal A alone (frequency only)", "A", False),
                                   ("tonal B alone (frequency only)", "B", False)):
        r = study(rows(own, t, tonals, bearings), motion, theta, tonals, args.runs, args.seed)
        f0 = ", ".join(f"f0 {n} {r[n]:.3f} (CRLB {r['crlb ' + n]:.4f} Hz)"
                       for n in nuisance_of(tonals))
        print(f"{name:32s} position at CPA {r['pos']:.3f} (CRLB {r['crlb_pos_m']:.1f} m); "
              f"{f0}; not converged {r['failed']}; several solutions reported "
              f"{r['several']} (the truth's not the first {r['ghost']})")


if __name__ == "__main__":
    main()
