"""Scenarios: what happens, how it is observed, and the files that describe it.

* :mod:`.model` — :class:`Scenario`, :class:`MeasurementPlan` and :func:`simulate` (exported
  here, as is :func:`truth_states`).
* :mod:`.truth` — the true states a simulated set carries.
* :mod:`.files` — TOML scenario files and the built-in scenarios (``builtin/*.toml``) by name.
* :mod:`.planning_table` — the schema of a file's ``[planning]`` table (a steered sensor and
  its planner; :mod:`tmakit.planning.setup` builds it).
* :mod:`.times` — a file's sample times, bounded.
* :mod:`.catalog` — the built-in scenarios' names and titles (standard library only).

The package sits below the estimators: a bound takes a :class:`Scenario`.  Only applications
and the command line load a scenario by name or file (an import-linter contract forbids the
layers below them to import :mod:`.files` or :mod:`.catalog`, ``docs/architecture.md``).
The names exported here are listed in ``__init__.pyi`` and imported on first use, so the
catalogue (``tma scenarios``) loads no numerical code.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
