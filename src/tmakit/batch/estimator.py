"""What every batch estimator is: settings in its constructor, :meth:`~BatchEstimator.fit`.

:class:`PaperMethod` is the common part of the papers' local iterations (Gu et al. (2007) §3-4,
the Doppler-tracking lecture notes): their own nuisance model, and tmakit's grid start.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..data import MeasurementSet
from ..motion import MotionModel
from ..results.estimate import EstimateResult
from .init import grid_start

#: A starting point: motion parameters by name, a vector in ``param_names`` order, or None.
Init = Mapping[str, float] | ArrayLike | None
#: The nuisance model per kind, e.g. ``{"frequency": {"drift": True}}``.
Options = Mapping[str, Mapping[str, object]] | None

GRID_START_NOTE = "started from tmakit's likelihood-grid point (the papers' methods are local)"


class BatchEstimator(ABC):
    """A batch estimator: settings in the constructor, :meth:`fit` on the data.

    Attributes
    ----------
    name : str
        Its key in :data:`tmakit.batch.METHODS` and ``result.method``.
    takes_known_nuisance : bool
        Whether it takes a ``known_nuisance`` setting.
    """

    name: ClassVar[str] = ""
    takes_known_nuisance: ClassVar[bool] = False

    @abstractmethod
    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Estimate the motion parameters from the measurements.

        Parameters
        ----------
        meas : MeasurementSet
        motion : MotionModel

        Returns
        -------
        EstimateResult
        """


def theta_from_init(motion: MotionModel, init: Mapping[str, float] | ArrayLike, prefix: str = "",
                    named_only: bool = False) -> NDArray[np.float64]:
    """Give a start ``(p,)`` from names (``named_only``: others ignored) or a vector, checked."""
    if isinstance(init, Mapping):
        return motion.theta({k: v for k, v in init.items() if k in motion.param_names}
                            if named_only else init)
    theta = np.asarray(init, dtype=float).reshape(-1)
    if theta.shape != (motion.n_params,):
        raise ValueError(f"{prefix}init must give {motion.n_params} values "
                         f"({', '.join(motion.param_names)})")
    return theta


def refuse_manoeuvre_options(given: Mapping[str, object], motion: object) -> None:
    """Refuse settings of the manoeuvre search for a motion without manoeuvres."""
    if given:
        raise TypeError(f"estimate() got options for manoeuvring targets "
                        f"({', '.join(given)}) with motion {getattr(motion, 'name', motion)!r}")


def check_paper_options(method: str, options: Options) -> None:
    """Refuse nuisance models the papers do not have: carrier drift, path-loss exponent ≠ 2."""
    opts = dict(options or {})
    if opts.get("frequency", {}).get("drift", False):
        raise ValueError(f"{method}: the paper's model has no carrier drift; use method 'ml' "
                         "for drift")
    exponent = opts.get("power", {}).get("exponent", 2.0)
    if exponent is None or float(exponent) != 2.0:  # type: ignore[arg-type]
        raise ValueError(f"{method}: the paper's model has the path-loss exponent 2; use "
                         "method 'ml' for another or an unknown exponent")


def kinds_tuple(kinds: str | Sequence[str] | None) -> tuple[str, ...] | None:
    """Convert ``kinds`` to a tuple (a single name as a 1-tuple), or None."""
    if kinds is None:
        return None
    return (kinds,) if isinstance(kinds, str) else tuple(kinds)


@dataclass(frozen=True, eq=False)
class PaperMethod(BatchEstimator):
    """A local method of the papers, started from ``init`` or from tmakit's grid point.

    Parameters
    ----------
    init : Mapping[str, float] or array_like, optional
        The start, SI; default :func:`tmakit.batch.init.grid_start` on the method's kinds.
    options : Mapping, optional
        Only the papers' own model (no drift, exponent 2).

    Raises
    ------
    ValueError
        When ``options`` asks for another nuisance model.
    """

    init: Init = None
    options: Options = None

    start_kinds: ClassVar[tuple[str, ...]] = ()  # the kinds its grid start is scored on

    def __post_init__(self) -> None:
        """Refuse a nuisance model the papers do not have."""
        check_paper_options(self.name, self.options)

    @property
    def kinds_wanted(self) -> tuple[str, ...] | None:
        """The kinds asked for (None: every kind the method can use)."""
        return None

    @abstractmethod
    def iterate(self, meas: MeasurementSet, motion: MotionModel, init: Init
                ) -> EstimateResult:
        """Run the paper's iteration from ``init``.

        Parameters
        ----------
        meas : MeasurementSet
        motion : MotionModel
            2-D or 3-D constant velocity.
        init : Mapping[str, float] or array_like
            The start (None raises ``ValueError``).

        Returns
        -------
        EstimateResult
        """

    def start_rows(self, meas: MeasurementSet) -> MeasurementSet:
        """Return the rows of the kinds the method uses (all when none), to score the start on.

        Parameters
        ----------
        meas : MeasurementSet

        Returns
        -------
        MeasurementSet
        """
        kinds = [k for k in self.start_kinds if k in meas.kinds]
        wanted = self.kinds_wanted
        if wanted is not None:
            kinds = [k for k in kinds if k in wanted]
        return meas.take(np.isin(meas.kind, kinds)) if kinds else meas

    def fit(self, meas: MeasurementSet, motion: MotionModel) -> EstimateResult:
        """Run the paper's iteration from ``init``, or from tmakit's grid point without one."""
        if self.init is not None:
            return self.iterate(meas, motion, self.init)
        start = grid_start(self.start_rows(meas), motion)
        result = self.iterate(meas, motion, start)
        result.extra["start"] = "grid"
        result.extra["start_point"] = [float(v) for v in np.asarray(start, dtype=float)]
        result.message = (f"{GRID_START_NOTE}; {result.message}" if result.message
                          else GRID_START_NOTE)
        return result
