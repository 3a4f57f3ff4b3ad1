"""Adapters between tmakit and other tracking libraries (optional extras).

* :mod:`tmakit.interop.stonesoup` — measurement sets to and from Stone Soup detections,
  tmakit's measurement kinds as Stone Soup measurement models with analytic Jacobians, and
  tmakit's no-guess batch estimate as a Stone Soup initiator (``pip install "tmakit[stonesoup]"``).

Nothing here is imported by ``import tmakit``; each adapter imports its library when it is
itself imported.
"""

__all__: list[str] = []
