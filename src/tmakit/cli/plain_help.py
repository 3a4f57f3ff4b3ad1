"""Plain ``-h`` help for every ``tma`` command: each valued option shows the value it takes.

Typer labels a valued option with its Python type (``--seed <int>``) and a required argument as
``{file}``; :class:`PlainCommand` names each value by what it is (``--seed N``, ``FILE``).
"""

from __future__ import annotations

from typing import Any

from typer.core import TyperCommand

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
