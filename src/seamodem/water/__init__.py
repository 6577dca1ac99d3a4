"""The water: sound-speed profiles (CTD casts, TEOS-10, Mackenzie) and rays traced through them.

Used by the channel simulator (paths that bend), the receiver (range along
the ray) and navigation (travel time → horizontal range).
"""

from .cast import FORMULAS, profile_from_ctd, read_profile
from .profile import SoundSpeedProfile
from .rays import Eigenray, RayTracer
from .table import TravelTimeTable
from .speed import depth_from_pressure, pressure_from_depth, sound_speed_mackenzie, sound_speed_teos10

__all__ = [
    "SoundSpeedProfile",
    "RayTracer",
    "Eigenray",
    "TravelTimeTable",
    "read_profile",
    "profile_from_ctd",
    "FORMULAS",
    "sound_speed_mackenzie",
    "sound_speed_teos10",
    "pressure_from_depth",
    "depth_from_pressure",
]
