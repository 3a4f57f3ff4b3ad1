"""The ``tma`` command.

    tma scenarios                                  list the built-in scenarios
    tma simulate SCENARIO [--seed N] [--no-noise] -o FILE [--force]
    tma show FILE [--plot out.png] [--origin LAT,LON,ALT] [--force]
    tma demo [--out-dir DIR] [--seed N] [--force]
    tma crlb FILE --motion cv2d --truth x=..,y=.. [--known-nuisance] [--json]
    tma crlb SCENARIO [--known-nuisance] [--at T] [--json]
    tma estimate FILE [--motion cv2d] [--init x=..,y=..] [--method ml] [--json]
    tma reproduce gu2007|doppler-lecture|hoerst2010|chen-sun [--runs N] [--seed S] [--plot FILE]
    tma montecarlo SCENARIO [--runs N] [--seed S] [--estimator ml] [--dask ADDR] [-o FILE]
    tma track FILE [--filter ekf|ukf|mgekf|pf] [--q Q] [--json] [-o track.csv] [--plot out.png]
    tma plan SCENARIO.toml [-o path.csv] [--plot figs.png] [--runs N] [--seed S] [--json]

Every command refuses to overwrite an existing output unless ``--force`` is given, and
reports bad input as ``error: ...`` naming the file, row and field, with exit status 2.
Exit statuses: 0 success, 1 honest non-success (unobservable, diverged, not converged), 2 bad
input, 3 internal error (traceback in a log file, or on the terminal with ``tma --debug``),
130 interrupted, 143 terminated (see :mod:`tmakit.cli.guard`).
"""

from __future__ import annotations

import typer

from .crlb import crlb
from .estimate import estimate
from .guard import guarded, install_sigterm, set_debug
from .montecarlo import montecarlo
from .plan import plan
from .reproduce import reproduce
from .scenarios import demo, scenarios, show, simulate
from .track import track

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="tmakit: passive emitter localisation and target motion analysis.")



@app.callback()
def _options(debug: bool = typer.Option(
        False, "--debug", help="show tracebacks and numerical warnings (for bug reports)"),
             ) -> None:
    """Passive emitter localisation and target motion analysis."""
    set_debug(debug)


# Registered in this order: ``tma --help`` lists the commands in it.  Each is guarded: no
# traceback reaches the user (tmakit.cli.guard).
for _command in (scenarios, simulate, show, crlb, estimate, reproduce, montecarlo, track,
                 plan, demo):
    app.command()(guarded(_command))


def main() -> None:
    """Entry point of the ``tma`` console script."""
    install_sigterm()
    app()


__all__ = ["app", "main"]
