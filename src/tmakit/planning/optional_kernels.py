"""Optional compiled kernels (``numba``): loaded at first use, with a switch and a fallback.

The planner's compiled hot loops (:mod:`tmakit.planning.compiled`) keep one
:class:`OptionalKernels`: the last user, until the planner has one implementation.  The kernels are
imported and compiled (cached on disk by ``numba``) at the first :meth:`~OptionalKernels.
available`; without ``numba``, with the environment variable ``TMAKIT_NO_NUMBA`` set to a
non-empty value other than ``0``, or after ``use_compiled(False)``, ``available()`` is False and
the caller takes its NumPy path.  ``numba`` installed but unable to compile here (an
incompatible NumPy, no cache folder) is said once, as a ``RuntimeWarning``, and NumPy is used.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable

__all__ = ["OptionalKernels"]

Kernels = dict[str, Callable[..., object]]


class OptionalKernels:
    """The compiled kernels of one module, or ``False`` once they cannot be had.

    Parameters
    ----------
    what : str
        What the kernels are for, in the warning (``"planning"``, ``"curvilinear"``).
    compile : callable
        Imports ``numba`` and the kernels, compiles them on tiny inputs and returns them by
        name; raises ImportError without ``numba``.
    """

    def __init__(self, what: str, compile: Callable[[], Kernels]) -> None:
        self.what = what
        self.compile = compile
        self.enabled = os.environ.get("TMAKIT_NO_NUMBA", "") in ("", "0")
        #: None until the first :meth:`available`, then the kernels by name or False.
        self.kernels: Kernels | bool | None = None

    def use_compiled(self, enabled: bool) -> bool:
        """Switch the compiled kernels on or off (for comparisons); return the previous setting.

        Parameters
        ----------
        enabled : bool
            False: every call takes the NumPy path, even with ``numba`` installed.

        Returns
        -------
        bool
            The setting before the call.
        """
        before = self.enabled
        self.enabled = bool(enabled)
        return before

    def available(self) -> bool:
        """Tell whether the kernels are switched on and could be compiled (compiling them once).

        Returns
        -------
        bool
        """
        if not self.enabled:
            return False
        if self.kernels is None:
            try:
                self.kernels = self.compile()
            except ImportError:
                self.kernels = False
            except Exception as err:   # numba present but unusable here: say so, use NumPy
                warnings.warn(f"tmakit's compiled {self.what} kernels failed ({err!r}); using "
                              "the NumPy path", RuntimeWarning, stacklevel=3)
                self.kernels = False
        return self.kernels is not False

    def __getitem__(self, name: str) -> Callable[..., object]:
        """Give the compiled kernel ``name`` (only after :meth:`available` returned True).

        Parameters
        ----------
        name : str
            The kernel's name.

        Returns
        -------
        callable
        """
        if not isinstance(self.kernels, dict):
            raise RuntimeError(f"tmakit's compiled {self.what} kernels are not available")
        return self.kernels[name]
