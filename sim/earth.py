"""The Earth's rotation, added to the truth analytically (MuJoCo's world does not rotate)."""

import math

import numpy as np

from fogcomp.units import EARTH_RATE  # rad/s, WGS-84

__all__ = ["EARTH_RATE", "earth_rate_world"]


def earth_rate_world(latitude: float, heading: float) -> np.ndarray:
    """Earth rate in the table's world frame (x = tilt axis, z = up), rad/s.

    latitude : rad.  heading : azimuth of the world x axis, from north toward east, rad.

    In the local level frame the Earth's rate has a north component Omega cos(lat) and an up
    component Omega sin(lat). With world x at azimuth psi and world y at psi - 90 deg (z up,
    right-handed), north = (cos psi, sin psi, 0) in world axes.
    """
    c = EARTH_RATE * math.cos(latitude)
    return np.array([c * math.cos(heading), c * math.sin(heading), EARTH_RATE * math.sin(latitude)])
