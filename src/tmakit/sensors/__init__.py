"""Sensors: recorded and scripted sensor tracks (where a sensor was), and steerable platforms."""

from .platform import (
    HURTADO_NEHORAI_2008,
    PLATFORM_CONFIGURATIONS,
    PlatformConfiguration,
    PlatformKinematics,
    PlatformTrack,
    Step,
    platform_configuration,
)
from .platform_state import Actions, PlatformState, propagate_constant_turn
from .tracks import FixedSensor, Leg, LegsTrack, RecordedTrack, SensorTrack, WaypointTrack

__all__ = [
    "HURTADO_NEHORAI_2008",
    "PLATFORM_CONFIGURATIONS",
    "Actions",
    "FixedSensor",
    "Leg",
    "LegsTrack",
    "PlatformConfiguration",
    "PlatformKinematics",
    "PlatformState",
    "PlatformTrack",
    "RecordedTrack",
    "SensorTrack",
    "Step",
    "WaypointTrack",
    "platform_configuration",
    "propagate_constant_turn",
]
