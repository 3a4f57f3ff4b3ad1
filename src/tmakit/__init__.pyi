# The one list of tmakit's public names: each line says where a name is defined.
# tmakit/__init__.py reads this file (lazy_loader.attach_stub) and imports each name on first
# use; type checkers read it as the package's interface.  Grouped by what a user does, not
# sorted (ruff's I001 is off for this file).
# ruff: noqa: I001

# the measurement set and the models behind it
from .data import MeasurementSet as MeasurementSet
from .measurements import KINDS as KINDS
from .measurements import model_for as model_for
from .motion import ConstantVelocity as ConstantVelocity
from .motion import MotionModel as MotionModel
from .motion import PiecewiseCurvilinear as PiecewiseCurvilinear
from .motion import Stationary as Stationary
from .motion import motion_from_name as motion_from_name
from .observation import ObservationModel as ObservationModel

# sensors
from .sensors import FixedSensor as FixedSensor
from .sensors import Leg as Leg
from .sensors import LegsTrack as LegsTrack
from .sensors import RecordedTrack as RecordedTrack
from .sensors import SensorTrack as SensorTrack
from .sensors import WaypointTrack as WaypointTrack
from .sensors import PlatformState as PlatformState
from .sensors import PlatformKinematics as PlatformKinematics
from .sensors import PlatformTrack as PlatformTrack

# scenarios
from .scenario.model import MeasurementPlan as MeasurementPlan
from .scenario.model import Scenario as Scenario
from .scenario.model import simulate as simulate
from .scenario.files import load_scenario as load_scenario
from .scenario.files import read_scenario_file as read_scenario_file
from .scenario.files import scenario_from_dict as scenario_from_dict
from .scenario.files import builtin_scenarios as builtin_scenarios
from .scenario.files import ScenarioFileError as ScenarioFileError
from .planning.setup import load_planning as load_planning
from .planning.setup import PlanningSetup as PlanningSetup

# results: what each function below returns
from .results import EstimateResult as EstimateResult
from .results import Status as Status
from .results import Bound as Bound
from .results import Observability as Observability
from .results import Direction as Direction
from .results import Answer as Answer
from .results import Ellipse as Ellipse
from .results import SanityWarning as SanityWarning
from .results import track_answer as track_answer
from .results import measurement_warnings as measurement_warnings
from .results.nuisance import KnownNuisance as KnownNuisance
from .filters import Track as Track
from .bounds import PosteriorBound as PosteriorBound
from .bounds import PosteriorInformation as PosteriorInformation
from .bounds import CrbSequence as CrbSequence
from .batch.manoeuvre import ManoeuvreEstimate as ManoeuvreEstimate
from .montecarlo import MonteCarloResult as MonteCarloResult
from .montecarlo.planned import PlanRun as PlanRun
from .planning import Planner as Planner
from .planning import Recommendation as Recommendation

# estimators, bounds, applications
from .batch import estimate as estimate
from .batch.height import choose_height as choose_height
from .batch.height import HeightChoice as HeightChoice
from .batch.ambiguity import resolve_ambiguity as resolve_ambiguity
from .batch.ambiguity import AmbiguityResult as AmbiguityResult
from .results.own_legs import own_ship_legs as own_ship_legs
from .results.own_legs import LegsAndTurns as LegsAndTurns
from .bounds import crlb as crlb
from .bounds import posterior_crb as posterior_crb
from .tracking import track as track
from .filters.bearing_prior import BearingPrior as BearingPrior
from .montecarlo import monte_carlo as monte_carlo

# sensor path planning
from .montecarlo.planned import plan as plan
from .planning import recommend as recommend

# files and geodesy
from .io import read_measurements as read_measurements
from .io import write_measurements as write_measurements
from .io import MeasurementFileError as MeasurementFileError
from .io.track_files import write_track as write_track
from .core.geodesy import geodetic_to_enu as geodetic_to_enu
from .core.geodesy import enu_to_geodetic as enu_to_geodetic

__version__: str
