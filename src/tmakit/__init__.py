"""tmakit: passive emitter localisation and target motion analysis.

>>> import tmakit as tk
>>> scn = tk.load_scenario("gu2007")
>>> meas = scn.simulate(rng=1)          # a MeasurementSet
>>> res = tk.estimate(meas, scn.motion)  # no initial guess
>>> bound = tk.crlb(scn)                 # the Cramér–Rao bound at the truth

The public names are listed once, in ``__init__.pyi`` (where each is defined); each is
imported when first used, so ``import tmakit`` (and the ``tma`` command's ``--help``) loads
none of the numerical core.  The layers behind these names are described in
``docs/architecture.md``.
"""

import lazy_loader as _lazy

__version__ = "0.1.0"

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
