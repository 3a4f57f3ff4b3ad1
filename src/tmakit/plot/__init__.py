"""Pictures: measurements, tracks, planned paths and the solution of ``tma estimate --plot``.

* :mod:`.tracks` — :func:`plot_measurements`, :func:`plot_track`, :func:`plot_plan`.
* :mod:`.solution` — :func:`plot_solution`, the map and residuals of one estimate.
* :mod:`.gdop` — :func:`~.gdop.cep_map` and :func:`~.gdop.plot_cep_map`, CEP50/CEP90 of a
  sensor layout over a grid (``tma gdop``).
* :mod:`.page` — :func:`~tmakit.plot.page.write_solution_page`, the interactive solution page
  of ``tma estimate --html`` (Bokeh; imported on use, not here).
* :mod:`.frame` — what the pictures share: a lat/lon map at true scale with a scale bar, a UTC
  time axis.

matplotlib is imported inside the functions that draw.
"""

from .solution import plot_solution
from .tracks import plot_measurements, plot_plan, plot_track, truth_track

__all__ = ["plot_measurements", "plot_plan", "plot_solution", "plot_track", "truth_track"]
