"""MSE against noise for a geolocation layout: maximum likelihood and closed form beside the CRLB.

The figure of Chan & Ho (1994) and Ho & Xu (2004): for each noise level, the mean squared
error of the source position (and velocity) over Monte Carlo runs, for tmakit's maximum
likelihood (no initial guess) and the paper's closed form, beside the trace of the CRLB's
position (velocity) block.  The *threshold* of an estimator is the lowest noise level of the
sweep at which its MSE exceeds the bound by more than its tolerance (1.1 for the maximum
likelihood, 1.2 for the closed form) and stays above it at every higher level of the sweep:
below it the estimator is efficient.

Beside each MSE / CRLB, the MSE over that of the *linearised* efficient estimator on the same
noise draws (the weighted least-squares step from the truth, whose mean squared error is the
CRLB exactly): the draws' own luck cancels in that ratio, so its standard error is a fraction
of the first's and it tells an estimator's own excess from Monte Carlo noise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..batch.hyperbolic import closed_form_many
from ..batch.ml import MaximumLikelihood
from ..bounds import crlb
from ..core.arrays import Array
from ..data import MeasurementSet
from ..observation import ObservationModel
from ..observation.noise import NoiseModel
from ..scenario import Scenario
from .common import Reproduction, Section

__all__ = ["CLOSED_TOLERANCE", "ML_TOLERANCE", "Sweep", "SweepReproduction", "plot",
           "reproduce", "sweep", "threshold"]

#: MSE / CRLB above which an estimator is past its threshold.
ML_TOLERANCE = 1.1
CLOSED_TOLERANCE = 1.2


@dataclass
class Sweep:
    """One layout's MSE against noise."""

    sigma_m: list[float]  # The noise levels: the std of one range difference (m)
    #: crlb, ml, closed: By block (``position`` m^2, ``velocity`` (m/s)^2): the CRLB trace and the
    #: two estimators' MSE at each level
    crlb: dict[str, list[float]] = field(default_factory=dict)
    ml: dict[str, list[float]] = field(default_factory=dict)
    closed: dict[str, list[float]] = field(default_factory=dict)
    #: ml_se, closed_se: the Monte Carlo standard error of each MSE (same units)
    ml_se: dict[str, list[float]] = field(default_factory=dict)
    closed_se: dict[str, list[float]] = field(default_factory=dict)
    #: ml_paired, closed_paired: each MSE over the linearised efficient estimator's on the same
    #: draws, and their standard errors (the ``_se`` keys)
    ml_paired: dict[str, list[float]] = field(default_factory=dict)
    closed_paired: dict[str, list[float]] = field(default_factory=dict)
    #: Runs per level whose maximum likelihood did not converge (counted in its MSE)
    failed: list[int] = field(default_factory=list)

    def ratio(self, which: str, block: str, of: str = "") -> list[float]:
        """Give an estimator's MSE (``of="_se"``: its standard error) over the CRLB's trace."""
        mse = getattr(self, which + of)[block]
        return [float(a / b) for a, b in zip(mse, self.crlb[block], strict=True)]


@dataclass
class SweepReproduction(Reproduction):
    """A reproduction's report with its sweep (for :func:`plot`) and title."""

    result: Sweep | None = None
    title: str = ""


def reproduce(name: str, title: str, scenario_at: Callable[[float], Scenario],
              sigma_m: Sequence[float], runs: int, seed: int) -> SweepReproduction:
    """Run a paper's sweep (:func:`sweep`) and give it as its report."""
    if runs < 1:
        raise ValueError(f"{name}: --runs must be 1 or more (Monte Carlo runs per level)")
    result = sweep(scenario_at, sigma_m, runs, seed)
    rep = SweepReproduction(name, result=result, title=title, print_figures=False)
    rep.sections, rep.figures = sweep_sections(result, title)
    rep.figures["runs"] = runs
    return rep


def plot(rep: SweepReproduction, path: str | Path) -> Path:
    """Draw a reproduction's MSE against noise beside the CRLB."""
    assert rep.result is not None
    plot_sweep(rep.result, rep.title, path)
    return Path(path)


def threshold(sigma: Sequence[float], ratio: Sequence[float], tolerance: float
              ) -> float | None:
    """Give the lowest noise level from which on MSE / CRLB exceeds ``tolerance``."""
    past = None
    for s, r in zip(sigma, ratio, strict=True):
        if r <= tolerance:
            past = None
        elif past is None:
            past = float(s)
    return past


def _blocks(dim: int, moving: bool) -> dict[str, slice]:
    return ({"position": slice(0, dim), "velocity": slice(dim, 2 * dim)} if moving
            else {"position": slice(0, dim)})


def sweep(scenario_at: Callable[[float], Scenario], sigma_m: Sequence[float], runs: int,
          seed: int, progress: Callable[[int], None] | None = None) -> Sweep:
    """Run the MSE-against-noise study of a layout."""
    out = Sweep([float(s) for s in sigma_m])
    ml = MaximumLikelihood()
    for k, sigma in enumerate(out.sigma_m):
        scn = scenario_at(sigma)
        motion = scn.motion
        blocks = _blocks(motion.dim, motion.n_params > motion.dim)
        bound = crlb(scn)
        seeds = [seed + k * runs + i for i in range(runs)]
        sets = scn.simulate_many(seeds)
        fits = ml.fit_many(sets, motion)
        ml_err = np.array([(f.estimate if not isinstance(f, Exception) else
                            np.full(motion.n_params, np.nan)) - scn.theta for f in fits])
        out.failed.append(sum(isinstance(f, Exception) or f.status != "converged"
                              for f in fits))
        ys = np.stack([m.value_si for m in sets])
        closed = closed_form_many(sets[0], ys, motion, scn.measurement_options)
        closed_err = (np.full(ml_err.shape, np.nan) if closed is None else closed) - scn.theta
        lin_err = linearised_errors(scn, sets[0], ys)
        for name, sl in blocks.items():
            out.crlb.setdefault(name, []).append(float(np.trace(bound.covariance[sl, sl])))
            for which, err in (("ml", ml_err), ("closed", closed_err)):
                mse, se = _mse(err[:, sl])
                getattr(out, which).setdefault(name, []).append(mse)
                getattr(out, which + "_se").setdefault(name, []).append(se)
                ratio, ratio_se = _paired(err[:, sl], lin_err[:, sl])
                getattr(out, which + "_paired").setdefault(name, []).append(ratio)
                getattr(out, which + "_paired").setdefault(name + "_se", []).append(ratio_se)
        if progress is not None:
            progress(k + 1)
    return out


def linearised_errors(scn: Scenario, meas: MeasurementSet, ys: Array) -> Array:
    """Give the error ``(B, p)`` of the linearised efficient estimator on each data set.

    The weighted least-squares step from the truth on ``ys (B, n)`` (the set's row order): its
    mean squared error is the CRLB.
    """
    obs = ObservationModel(meas, scn.motion, scn.measurement_options)
    noise = NoiseModel(obs.grouped, obs.models)
    nu = obs.nuisance_vector(scn.nuisance)
    j_theta, j_nu = obs.jacobian_grouped(scn.theta, nu)
    design = noise.whiten(np.concatenate([j_theta, np.broadcast_to(
        j_nu, (j_theta.shape[0], j_nu.shape[-1]))], axis=1), axis=0)
    resid = noise.whiten(ys[:, obs.order] - obs.predict_grouped(scn.theta, nu))
    return np.asarray((resid @ np.linalg.pinv(design).T)[:, :scn.motion.n_params])


def _paired(err: Array, lin: Array) -> tuple[float, float]:
    """Give ``MSE(err) / MSE(lin)`` over the same runs and its standard error (delta method)."""
    a, b = np.sum(np.square(err), axis=1), np.sum(np.square(lin), axis=1)
    if not np.all(np.isfinite(a)) or a.size < 2:
        return float("inf"), float("inf")
    ratio = float(np.mean(a) / np.mean(b))
    return ratio, float(np.std(a - ratio * b, ddof=1) / np.sqrt(a.size) / np.mean(b))


def _mse(err: Array) -> tuple[float, float]:
    """Mean over runs of the squared error summed over the block, and its standard error."""
    sq = np.sum(np.square(err), axis=1)
    if not np.all(np.isfinite(sq)):  # a run failed
        return float("inf"), float("inf")
    se = np.std(sq, ddof=1) / np.sqrt(sq.size) if sq.size > 1 else np.nan
    return float(np.mean(sq)), float(se)


def sweep_sections(result: Sweep, title: str) -> tuple[list[Section], dict[str, object]]:
    """Give a sweep as the report's tables and its key figures."""
    sections: list[Section] = []
    figures: dict[str, object] = {"sigma_m": result.sigma_m, "ml_failed": result.failed}
    for block in result.crlb:
        unit = "m^2" if block == "position" else "(m/s)^2"
        r_ml, r_cf = result.ratio("ml", block), result.ratio("closed", block)
        se_ml, se_cf = result.ratio("ml", block, "_se"), result.ratio("closed", block, "_se")
        p_ml, p_cf = result.ml_paired[block], result.closed_paired[block]
        pe_ml, pe_cf = result.ml_paired[block + "_se"], result.closed_paired[block + "_se"]
        rows = [[_g(s), round(float(20 * np.log10(s)), 1), _g(c), _g(a), _g(b),
                 f"{ra:.3f} ± {ea:.3f}", f"{pa:.3f} ± {qa:.3f}", f"{rb:.3f} ± {eb:.3f}",
                 f"{pb:.3f} ± {qb:.3f}"]
                for s, c, a, b, ra, ea, pa, qa, rb, eb, pb, qb in zip(
            result.sigma_m, result.crlb[block], result.ml[block], result.closed[block], r_ml,
            se_ml, p_ml, pe_ml, r_cf, se_cf, p_cf, pe_cf, strict=True)]
        t_ml = threshold(result.sigma_m, r_ml, ML_TOLERANCE)
        t_cf = threshold(result.sigma_m, r_cf, CLOSED_TOLERANCE)
        note = ("threshold (the noise level from which on MSE/CRLB stays past the "
                f"tolerance): ML (> "
                f"{ML_TOLERANCE}) {_level(t_ml)}; closed form (> {CLOSED_TOLERANCE}) "
                f"{_level(t_cf)}")
        sections.append(Section(
            f"{title}: {block} MSE against noise",
            ["sigma (m)", "sigma^2 (dB)", f"CRLB ({unit})", f"ML MSE ({unit})",
             f"closed MSE ({unit})", "ML/CRLB", "ML/lin.", "closed/CRLB", "closed/lin."],
            rows,
            note + f"; ML runs not converged per level: {result.failed}; ±SE: the ratio's "
            "Monte Carlo standard error; /lin.: MSE over the linearised efficient estimator's "
            "on the same draws (the draws' luck cancels: above 1 by more than its SE is the "
            "estimator's own excess)"))
        figures[f"{block}_ml_ratio"] = r_ml
        figures[f"{block}_closed_ratio"] = r_cf
        figures[f"{block}_ml_ratio_se"] = se_ml
        figures[f"{block}_closed_ratio_se"] = se_cf
        figures[f"{block}_ml_over_linearised"] = p_ml
        figures[f"{block}_ml_over_linearised_se"] = pe_ml
        figures[f"{block}_closed_over_linearised"] = p_cf
        figures[f"{block}_closed_over_linearised_se"] = pe_cf
        figures[f"{block}_ml_threshold_m"] = t_ml
        figures[f"{block}_closed_threshold_m"] = t_cf
    return sections, figures


def _g(value: float) -> float:
    """Round to four significant digits (a printed table)."""
    return float(f"{value:.4g}")


def _level(value: float | None) -> str:
    return "none within the sweep" if value is None else f"sigma = {value:g} m"


def plot_sweep(result: Sweep, title: str, path: str | Path) -> None:
    """Draw MSE against noise (log-log), both estimators beside the CRLB, one panel a block."""
    from matplotlib.figure import Figure

    blocks = list(result.crlb)
    fig = Figure(figsize=(5.5 * len(blocks), 4.2))
    axes = fig.subplots(1, len(blocks), squeeze=False)
    db = 20 * np.log10(result.sigma_m)
    for ax, block in zip(axes[0], blocks, strict=True):
        ax.semilogy(db, result.crlb[block], "k-", label="CRLB")
        ax.semilogy(db, result.ml[block], "o", label="ML (tmakit)")
        ax.semilogy(db, result.closed[block], "x", label="closed form")
        ax.set_xlabel("10 log10 sigma^2 (range difference, m^2)")
        ax.set_ylabel(f"{block} MSE ({'m^2' if block == 'position' else '(m/s)^2'})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
