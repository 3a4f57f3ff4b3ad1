# The names tmakit.scenario exports, imported on first use (lazy_loader.attach_stub).
from .model import MeasurementPlan as MeasurementPlan
from .model import Scenario as Scenario
from .model import simulate as simulate
from .truth import truth_states as truth_states
