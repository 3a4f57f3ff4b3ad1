"""Sensors: sensor tracks, steerable platforms, and the radar of Hurtado & Nehorai (2008).

Recorded and scripted tracks say where a sensor was; :mod:`tmakit.sensors.radar` models what
the paper's radar measures.
"""

from .platform import (
    HURTADO_NEHORAI_2008,
    PLATFORM_CONFIGURATIONS,
    Actions,
    PlatformConfiguration,
    PlatformKinematics,
    PlatformState,
    PlatformTrack,
    Step,
    platform_configuration,
)
from .radar import HURTADO_NEHORAI_2008_RADAR, RadarModel
from .tracks import FixedSensor, Leg, LegsTrack, RecordedTrack, SensorTrack, WaypointTrack

__all__ = [
    "HURTADO_NEHORAI_2008",
    "HURTADO_NEHORAI_2008_RADAR",
    "PLATFORM_CONFIGURATIONS",
    "Actions",
    "FixedSensor",
    "Leg",
    "LegsTrack",
    "PlatformConfiguration",
    "PlatformKinematics",
    "PlatformState",
    "PlatformTrack",
    "RadarModel",
    "RecordedTrack",
    "SensorTrack",
    "Step",
    "WaypointTrack",
    "platform_configuration",
]
