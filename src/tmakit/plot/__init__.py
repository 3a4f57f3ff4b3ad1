"""Pictures: measurements, tracks, planned paths and the solution of ``tma estimate --plot``."""

from .solution import plot_solution
from .tracks import plot_measurements, plot_plan, plot_track

__all__ = ["plot_measurements", "plot_plan", "plot_solution", "plot_track"]
