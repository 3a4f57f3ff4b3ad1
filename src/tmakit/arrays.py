"""Array types for annotations, defined once for the whole package.

``Array`` is a float64 NumPy array of any shape; the shapes and units of each argument are in
the docstring of the function that takes it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["Array"]

#: A float64 array (shapes and units are given where it is used).
Array = NDArray[np.float64]
