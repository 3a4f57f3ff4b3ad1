"""A sensor's path cut into straight legs, and in words: what bearings-only range needs.

Bearings (and any angle) from a sensor that holds course and speed are the same for every
target trajectory scaled about the sensor's own path: range is not observable until the sensor
manoeuvres (Nardone & Aidala 1981; Fogel & Gavish 1988).  :func:`straight_legs` finds the legs
of a sensor in the data (a new leg where its course or speed changes), and :func:`range_words`
says, naming those legs, why range is unseen and which manoeuvre would give it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..data import MeasurementSet

LEG_TURN_DEG = 5.0
"""A course change (deg) beyond which a new leg starts."""

LEG_SPEED_CHANGE = 0.1
"""A relative speed change beyond which a new leg starts (with at least 0.5 m/s)."""


@dataclass(frozen=True)
class Leg:
    """One straight leg of a sensor.

    Parameters
    ----------
    start, stop : float
        Its first and last times (s).
    course_deg : float
        Its course (degrees true).
    speed : float
        Its mean speed (m/s).
    """

    start: float
    stop: float
    course_deg: float
    speed: float

    def words(self) -> str:
        """Return the leg in words.

        Returns
        -------
        str
            ``t = START .. STOP s, course C° at S m/s`` (or ``stationary``).
        """
        if self.speed < 0.05:
            return f"t = {self.start:g} .. {self.stop:g} s, stationary"
        return (f"t = {self.start:g} .. {self.stop:g} s, course {self.course_deg:.0f}° at "
                f"{self.speed:.3g} m/s")


def straight_legs(time: NDArray[np.float64], state: NDArray[np.float64]) -> list[Leg]:
    """Cut a sensor's path into straight legs (constant course and speed).

    Parameters
    ----------
    time : ndarray, shape (n,)
        Times (s), not decreasing.
    state : ndarray, shape (n, 6)
        The sensor's ENU states (m, m/s) at those times.

    Returns
    -------
    list of Leg
        In time order; a new leg starts where the course turns by more than
        :data:`LEG_TURN_DEG` or the speed changes by more than :data:`LEG_SPEED_CHANGE` of
        the leg's first speed.
    """
    v = np.asarray(state, dtype=float)[:, 3:5]
    speed = np.hypot(v[:, 0], v[:, 1])
    course = np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360.0
    legs, first = [], 0
    for k in range(1, len(time) + 1):
        if k < len(time):
            turn = abs((course[k] - course[first] + 180.0) % 360.0 - 180.0)
            moving = max(speed[k], speed[first]) >= 0.05
            change = abs(speed[k] - speed[first]) > max(0.5, LEG_SPEED_CHANGE * speed[first])
            if not ((moving and turn > LEG_TURN_DEG) or change):
                continue
        legs.append(Leg(float(time[first]), float(time[k - 1]), float(course[first]),
                        float(np.mean(speed[first:k]))))
        first = k
    return legs


def sensor_legs(meas: MeasurementSet, sensor: str) -> list[Leg]:
    """Return the straight legs of one sensor of a measurement set.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements (their sensor states).
    sensor : str
        The sensor's name.

    Returns
    -------
    list of Leg
        Its legs over its rows' times (:func:`straight_legs`).
    """
    rows = meas.sensor == sensor
    return straight_legs(meas.time[rows], meas.sensor_state[rows])


def range_words(meas: MeasurementSet, sensor: str, manoeuvring_model: bool = False) -> str:
    """Say why range is not observable from a sensor's angles, and which manoeuvre would help.

    Parameters
    ----------
    meas : MeasurementSet
        The measurements (angles only).
    sensor : str
        The sensor they come from.
    manoeuvring_model : bool
        The motion model lets the target manoeuvre: say that its manoeuvres are no source of
        range.

    Returns
    -------
    str
        The sentence.
    """
    legs = sensor_legs(meas, sensor)
    spans = "; ".join(leg.words() for leg in legs)
    if all(leg.speed < 0.05 for leg in legs):
        how = (f"sensor {sensor} did not move during these bearings ({spans}), so the "
               "bearings fit the target at any range; only a moving sensor that changes course "
               "can give range")
    else:
        how = (f"the own ship {sensor} did not manoeuvre during these bearings (one straight leg: "
               f"{spans}), so the bearings fit the target at any range, and its speed along the "
               "line of sight with it. A turn of 30° or more (or a change of speed) for a second "
               "leg about as long as the first lets range be determined")
    if manoeuvring_model:
        how += ("; the manoeuvres the motion model allows the target are no information about "
                "range: a fit that puts one in would choose a range by the shape assumed")
    return f"range is not observable: {how}"
