"""``tma estimate``: the emitter's trajectory from a measurement file.

By maximum likelihood (``ml``, also for manoeuvring targets) or by one of the papers' methods.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from .common import (
    DriftOption,
    FreeExponentOption,
    JsonOption,
    MotionOption,
    OriginOption,
    RefTimeOption,
    fail,
    model_options,
    motion_or_fail,
    out,
    parse_assignments,
    parse_origin,
    read_or_fail,
)


# `tma estimate`: the docstring is its --help text, so no numpydoc sections (help= has them).
def estimate(
    file: Annotated[Path, typer.Argument(help="measurement file (.csv or .parquet)")],
    motion: MotionOption = None,
    ref_time: RefTimeOption = None,
    init: Annotated[str | None, typer.Option(
        help="optional starting point, e.g. x=3000,y=3000,vx=-20,vy=-10")] = None,
    method: Annotated[str, typer.Option(
        help="ml (default), or a paper's method: gu-direct, ratio, ratio-power, "
             "ratio-doppler, lecture-gn")] = "ml",
    drift: DriftOption = False,
    free_exponent: FreeExponentOption = False,
    origin: OriginOption = None,
    exact: Annotated[bool, typer.Option(
        "--exact", help="curvilinear:M: fit exactly M manoeuvres (default: 0 to M)")] = False,
    criterion: Annotated[str | None, typer.Option(
        help="curvilinear: how the number of manoeuvres is chosen, bic (default) or lrt")
    ] = None,
    alpha: Annotated[float | None, typer.Option(
        help="curvilinear, --criterion lrt: level of the likelihood-ratio tests "
             "(default 0.01)")] = None,
    accelerations: Annotated[str | None, typer.Option(
        help="curvilinear: select (default: hold at zero the accelerations the data do not "
             "need, by the same criterion) or all")] = None,
    as_json: JsonOption = False,
) -> None:
    """Estimate the emitter's trajectory from a measurement file (no initial guess needed).

    --motion curvilinear[:M] searches 0 to M manoeuvres (default M = 2) and chooses their
    number by BIC or likelihood-ratio tests, and holds at zero the accelerations the data do
    not need (tmakit.batch.curvilinear).
    """
    meas = read_or_fail(file, parse_origin(origin))
    start = parse_assignments(init, "--init") or None
    options = model_options(drift, free_exponent)
    # -- manoeuvring targets: tmakit.batch.curvilinear --------------------------------------
    name = motion if motion is not None else meas.metadata.get("motion")
    if name is not None and getattr(motion_or_fail(name, ref_time, meas), "manoeuvres",
                                                None) is not None:
        if method != "ml":
            raise fail(f"--method {method}: manoeuvring targets (--motion {name}) are "
                       "estimated by ml only")
        if ref_time is None and motion is None and "ref_time" in meas.metadata:
            ref_time = float(meas.metadata["ref_time"])
        result = estimate_manoeuvring(meas, name, start, options, ref_time, exact, criterion,
                                      alpha, accelerations)
        print_estimate(meas, result, as_json)
        return
    if exact or criterion is not None or alpha is not None or accelerations is not None:
        raise fail("--exact, --criterion, --alpha and --accelerations apply to --motion "
                   "curvilinear[:M] only")
    # -------------------------------------------------------------------------------------
    model = motion_or_fail(motion, ref_time, meas)
    try:
        if method == "ml":
            from ..batch import estimate as run

            result = run(meas, model, init=start, options=options)
        else:
            from ..batch.methods import estimate_with

            result = estimate_with(method, meas, model, init=start, options=options)
    except ValueError as e:
        raise fail(str(e)) from None
    print_estimate(meas, result, as_json)


def estimate_manoeuvring(meas: Any, name: str, start: dict[str, float] | None,
                         options: dict[str, Any], ref_time: float | None, exact: bool,
                         criterion: str | None, alpha: float | None,
                         accelerations: str | None) -> Any:
    """Compute the ML estimate of a manoeuvring target (``--motion curvilinear[:M]``).

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements.
    name : str
        ``curvilinear`` or ``curvilinear:M``.
    start : dict or None
        ``--init`` values by name (m, m/s, ...).
    options : dict
        Measurement-model options.
    ref_time : float or None
        Reference time of the motion parameters (s).
    exact, criterion, alpha, accelerations
        ``--exact``, ``--criterion`` (default bic), ``--alpha`` (default 0.01),
        ``--accelerations``.

    Returns
    -------
    tmakit.results.EstimateResult
        The estimate.

    Raises
    ------
    typer.Exit
        Status 2 on bad input.
    """
    from ..batch.curvilinear import estimate_for

    try:
        return estimate_for(meas, name, init=start, options=options, ref_time=ref_time,
                            exact=exact, criterion=criterion or "bic",
                            alpha=0.01 if alpha is None else alpha,
                            accelerations=accelerations)
    except ValueError as e:
        raise fail(str(e)) from None


def print_estimate(meas: Any, result: Any, as_json: bool) -> None:
    """Print an estimate (text or JSON); exit status 1 unless it converged.

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements (their metadata may give the ENU origin).
    result : tmakit.results.EstimateResult
        The estimate.
    as_json : bool
        Print JSON.

    Raises
    ------
    typer.Exit
        Status 1 when the estimate did not converge.
    """
    geo = geodetic_position(meas, result)
    if as_json:
        import json

        data = result.as_dict()
        if geo is not None:
            data["geodetic"] = geo
        out.print_json(json.dumps(data))
    else:
        out.print(result.summary(), highlight=False)
        if geo is not None:
            out.print(f"position at t = {geo['time']:g} s: lat {geo['lat']:.7f} deg, "
                      f"lon {geo['lon']:.7f} deg, alt {geo['alt']:.1f} m (WGS-84)",
                      highlight=False)
    if result.status != "converged":
        raise typer.Exit(1)


def geodetic_position(meas: Any, result: Any) -> dict[str, float] | None:
    """Return the estimated position at the motion model's reference time in WGS-84.

    Only when the file gives the ENU origin (``origin_lat``, ``origin_lon``, ``origin_alt``).

    Parameters
    ----------
    meas : tmakit.data.MeasurementSet
        The measurements.
    result : tmakit.results.EstimateResult
        The estimate.

    Returns
    -------
    dict or None
        ``{"time" (s), "lat" (deg), "lon" (deg), "alt" (m)}``, or None without an origin or
        a finite position.
    """
    meta = meas.metadata
    if not {"origin_lat", "origin_lon"} <= set(meta) or not result.estimate.size:
        return None
    import numpy as np

    from ..geodesy import enu_to_geodetic

    t = float(getattr(result.motion, "ref_time", meas.time.min()))
    state = result.motion.states(result.estimate, np.array([t]))[0]
    if not np.all(np.isfinite(state[:3])):
        return None
    origin = (float(meta["origin_lat"]), float(meta["origin_lon"]),
              float(meta.get("origin_alt", 0.0)))
    lat, lon, alt = enu_to_geodetic(state[0], state[1], state[2], origin)
    return {"time": t, "lat": float(lat), "lon": float(lon), "alt": float(alt)}
