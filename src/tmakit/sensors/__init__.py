"""Sensors: recorded and scripted sensor tracks (where a sensor was), and steerable platforms."""

from .tracks import FixedSensor, Leg, LegsTrack, RecordedTrack, SensorTrack, WaypointTrack

__all__ = ["FixedSensor", "Leg", "LegsTrack", "RecordedTrack", "SensorTrack", "WaypointTrack"]
