"""The ``tma`` command: its commands registered, and help that names values (``--seed N``)."""

from __future__ import annotations

import gc
import sys
from typing import Annotated, Any

import typer
from typer.core import TyperCommand

from .common import note_given
from .crlb import crlb, gdop
from .estimate import estimate, report
from .guard import WRITE_ERRORS, guarded, install_sigterm, set_debug, write_failed
from .scenarios import demo, examples, import_, scenarios, show, simulate
from .studies import montecarlo, plan, reproduce
from .track import track

# What the value of an option is, by the option's parameter name. An option not listed here is
# named by its parameter name in capitals (``--motion MOTION``), the way argparse does it.
VALUE_NAMES = {
    "origin": "LAT,LON,ALT", "output": "FILE", "plot": "FILE", "mapping": "FILE",
    "json_file": "FILE", "file": "FILE", "files": "FILE", "folder": "DIR", "out_dir": "DIR",
    "seed": "N", "runs": "N", "chunk": "N", "particles": "N", "steps": "N", "rows": "N",
    "ellipses": "N", "init_window": "N", "dim": "2|3", "ref_time": "T", "at": "T",
    "prior_time": "T", "start": "T", "stop": "T", "duration": "S", "bearing_sigma": "DEG",
    "start_std": "M", "alpha": "P", "q": "Q", "init": "NAME=VALUE,...",
    "truth": "NAME=VALUE,...", "prior": "NAME=VALUE,...", "prior_std": "NAME=VALUE,...",
    "map_text": "COLUMN=ROLE,...", "measure": "COLUMN=KIND:UNIT:SIGMA", "dask": "ADDRESS",
    "filter_name": "FILTER", "units": "si|nautical", "criterion": "bic|lrt",
    "accelerations": "select|all", "max_runs": "N", "ownship": "NAME", "contact": "NAME",
    "sensor": "NAME",
}


def value_name(param: Any) -> str:
    """Name the value a parameter takes, for help: ``FILE``, ``N``, ``LAT,LON,ALT``."""
    if param.metavar:
        return param.metavar
    name = param.name or ""
    return VALUE_NAMES.get(name, name.upper())


def option_label(option: Any) -> str:
    """Label an option for help: ``-o, --output FILE`` or ``--drift / --no-drift``."""
    names = ", ".join(sorted(option.opts, key=len))
    if option.secondary_opts:
        names += " / " + ", ".join(option.secondary_opts)
    if option.is_flag or option.count:
        return names
    many = "..." if option.multiple else ""
    return f"{names} {value_name(option)}{many}"


def argument_label(argument: Any, usage: bool) -> str:
    """Label an argument as the help shows it: ``FILE``, ``FILE...``; ``[DIR]`` when optional."""
    label = value_name(argument) + ("..." if argument.nargs != 1 else "")
    return f"[{label}]" if usage and not argument.required else label


class PlainCommand(TyperCommand):
    """A typer command whose help names values (``--seed N``) instead of types (``<int>``)."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        """Parse the arguments, noting them as given (:func:`tmakit.cli.common.stray_value`)."""
        note_given(args, {name: bool(p.multiple) for p in self.params
                          if p.param_type_name == "option"
                          and not (getattr(p, "is_flag", False) or getattr(p, "count", False))
                          for name in p.opts})
        return super().parse_args(ctx, args)

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        """Usage line pieces: ``[OPTIONS]`` then the arguments by name."""
        pieces = [self.options_metavar] if self.options_metavar else []
        return pieces + [argument_label(p, usage=True) for p in self.get_params(ctx)
                         if p.param_type_name == "argument"]

    def format_options(self, ctx: Any, formatter: Any) -> None:
        """Write the ``Arguments`` and ``Options`` sections with values named, not typed."""
        sections: dict[str, list[tuple[str, str]]] = {"Arguments": [], "Options": []}
        for param in self.get_params(ctx):
            record: Any = param.get_help_record(ctx)
            if record is None:
                continue
            if param.param_type_name == "argument":
                sections["Arguments"].append((argument_label(param, usage=False), record[1]))
            elif param.param_type_name == "option":
                sections["Options"].append((option_label(param), record[1]))
        for title, rows in sections.items():
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)


# Plain (click) help, -h as well as --help: no rich markup (a help text's "a:b:" is not an
# emoji), and typer's rich help loads rich's Markdown renderer and its parser, which took
# longer than all of numpy's import (benchmarks/run_all.py --only startup).
def _typer_app() -> typer.Typer:
    return typer.Typer(
        add_completion=False, no_args_is_help=True, rich_markup_mode=None,
        context_settings={"help_option_names": ["-h", "--help"]},
        help="tmakit: passive emitter localisation and target motion analysis.")


app = _typer_app()


def _print_version(value: bool) -> None:
    """Print ``tma <version>`` and stop (``--version``)."""
    if value:
        from .. import __version__

        typer.echo(f"tma (tmakit) {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: Annotated[bool, typer.Option(
        "--version", callback=_print_version, is_eager=True,
        help="print the version and exit")] = False,
          debug: Annotated[bool, typer.Option(
        "--debug", help="show tracebacks and numerical warnings (for bug reports)")] = False,
          ) -> None:
    """Passive emitter localisation and target motion analysis (tmakit)."""
    set_debug(debug)


# Registered in this order: ``tma --help`` lists the commands in it.  Each is guarded: no
# traceback reaches the user (tmakit.cli.guard).  A command's docstring is its --help text
# (no numpydoc sections: each option's help= has them).
for _command in (scenarios, simulate, show, crlb, estimate, report, reproduce, montecarlo,
                 track, plan, gdop, demo):
    app.command(cls=PlainCommand)(guarded(_command))
app.command(name="import", cls=PlainCommand)(guarded(import_))
app.command(cls=PlainCommand)(guarded(examples))


def listing_app() -> typer.Typer:
    """Give ``tma``'s app with each command stubbed (no parameters): the same listing, faster.

    Returns
    -------
    typer.Typer
        The listing app (for ``tma``, ``tma -h`` and ``tma --help`` alone).
    """
    listing = _typer_app()
    listing.callback()(_root)
    for info in app.registered_commands:
        command = info.callback
        assert command is not None  # (every command registered above has its function)

        def stub() -> None:
            """Stand in for a command in the listing (never run)."""  # (replaced below)

        stub.__name__, stub.__doc__ = command.__name__, command.__doc__
        listing.command(name=info.name, cls=PlainCommand)(stub)
    return listing


def main() -> None:
    """Entry point of the ``tma`` console script."""
    install_sigterm()
    try:
        _run()
    except OSError as exc:  # help or usage text that could not be written (a full disk)
        if exc.errno not in WRITE_ERRORS:
            raise
        raise SystemExit(write_failed(exc, " ".join(sys.argv[1:2]))) from None
    finally:
        _leave_objects_to_exit()


def _leave_objects_to_exit() -> None:
    """Collect the garbage, then exempt the live objects from the exit's collections."""
    # Python's exit takes apart every object left in a reference cycle, one by one (numba's
    # types and templates alone are ~10^5); the end of the process frees them at no cost.
    # The garbage is collected first, so its finalizers run as they would have.
    gc.collect()
    gc.freeze()


def _run() -> None:
    """Run the command line (the listing and ``tma scenarios`` without typer's full app)."""
    if sys.argv[1:] in ([], ["-h"], ["--help"]):
        listing_app()()  # (the listing alone: no command's parameters built)
    if sys.argv[1:] == ["scenarios"]:
        # Typer (>= 0.2x) imports pydantic to coerce any command's parameters, even --help;
        # the plain listing has none, so it is run directly (same output and exit, no
        # pydantic).
        try:
            guarded(scenarios)()  # (no traceback here either: tmakit.cli.guard)
        except typer.Exit as e:
            raise SystemExit(e.exit_code) from None
        raise SystemExit(0)
    app()


__all__ = ["app", "listing_app", "main"]
