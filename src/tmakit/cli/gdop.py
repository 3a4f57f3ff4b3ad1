"""``tma gdop``: CEP50 and CEP90 of a stationary emitter over a grid, for a sensor layout."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .common import JsonOption, check_outputs, fail, load_scenario_or_fail, out, write_picture


# `tma gdop`: the docstring is its --help text, so no numpydoc sections (help= has them).
def gdop(
    layout: Annotated[str, typer.Argument(
        help="scenario name or TOML file: its sensors and tdoa/fdoa measurements")],
    plot: Annotated[Path | None, typer.Option(
        help="draw CEP50 and CEP90 over the grid (PNG, PDF, SVG)")] = None,
    points: Annotated[int, typer.Option(help="grid points per side")] = 100,
    half_width: Annotated[float | None, typer.Option(
        help="half the grid's side (m); default twice the sensors' spread")] = None,
    height: Annotated[float, typer.Option(help="the emitter's known ENU height (m)")] = 0.0,
    as_json: JsonOption = False,
    force: Annotated[bool, typer.Option(help="overwrite an existing --plot file")] = False,
) -> None:
    """Geolocation accuracy map: CEP50/CEP90 of a stationary emitter over a grid.

    The circle about the true position holding the best unbiased estimate (the CRLB) with
    probability 50 % and 90 %, from the layout's TDOA and FDOA rows (noise shared through
    each reference sensor), the emitter's height known.
    """
    import numpy as np

    from ..plot.gdop import cep_map, plot_cep_map

    if points < 2 or points > 2000:
        raise fail(f"--points {points}: expected 2 to 2000 per side")
    scenario = load_scenario_or_fail(layout)
    (plot,) = check_outputs([("--plot", plot, "picture")], force)
    try:
        result = cep_map(scenario, points, half_width, height)
    except ValueError as e:
        raise fail(f"{layout}: {e}") from None
    finite50 = result.cep50[np.isfinite(result.cep50)]
    finite90 = result.cep90[np.isfinite(result.cep90)]
    summary = {
        "layout": scenario.name, "points": points,
        "east_m": [float(result.east[0]), float(result.east[-1])],
        "north_m": [float(result.north[0]), float(result.north[-1])],
        "cep50_m": _stats(finite50), "cep90_m": _stats(finite90),
        "unobservable_points": int(result.cep50.size - finite50.size),
        "ignored_kinds": result.ignored,
    }
    if plot is not None:
        write_picture(plot, force, lambda tmp: plot_cep_map(result, tmp, scenario.name))
    if as_json:
        import json

        out.print_json(json.dumps(summary))
        return
    out.print(f"{scenario.name}: {points} x {points} emitter positions, east "
              f"{result.east[0]:.0f}..{result.east[-1]:.0f} m, north {result.north[0]:.0f}.."
              f"{result.north[-1]:.0f} m, height {height:g} m (known)", highlight=False)
    for name, stats in (("CEP50", summary["cep50_m"]), ("CEP90", summary["cep90_m"])):
        out.print(f"{name}: min {stats['min']:.4g} m, median {stats['median']:.4g} m, "
                  f"max {stats['max']:.4g} m", highlight=False)
    if summary["unobservable_points"]:
        out.print(f"{summary['unobservable_points']} points unobservable (no finite bound)",
                  highlight=False)
    if result.ignored:
        out.print(f"not in the map: the {', '.join(result.ignored)} measurements (the map "
                  "takes tdoa and fdoa)", highlight=False)
    if plot is not None:
        out.print(f"wrote {plot}", highlight=False)


def _stats(values: object) -> dict[str, float]:
    import numpy as np

    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"min": float("inf"), "median": float("inf"), "max": float("inf")}
    return {"min": float(v.min()), "median": float(np.median(v)), "max": float(v.max())}
