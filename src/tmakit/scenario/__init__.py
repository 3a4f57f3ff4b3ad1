"""Scenarios: what happens, how it is observed, and the files that describe it.

:mod:`.model` (:class:`Scenario`, :func:`simulate`), :mod:`.truth`, :mod:`.files` (TOML and
the built-in scenarios), :mod:`.planning_table`, :mod:`.catalog`.  Names are
imported on first use (``__init__.pyi``), so ``tma scenarios`` loads no numerical code.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
