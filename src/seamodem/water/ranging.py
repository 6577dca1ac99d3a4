"""Travel time → range with a sound-speed profile: what the receiver and the navigation filter use.

A frame's primary measurement is its time of flight. With a profile and the
depths of both ends, the direct eigenray whose travel time is that time of
flight fixes the horizontal range R between them (a
:class:`~seamodem.water.table.TravelTimeTable` over the depths the vehicle
visits), and the straight-line (slant) distance √(R² + Δz²), the range a
constant-c receiver would report if it knew the right c.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .profile import SoundSpeedProfile
from .rays import RayTracer
from .table import TravelTimeTable

__all__ = ["ProfileRanging"]

#: spacing of the table's range nodes [m]: fine where rays are steep, coarser beyond
_NEAR_STEP_M, _FAR_STEP_M, _NEAR_M = 0.5, 5.0, 200.0
#: spacing of the table's depth rows [m] (Hermite in depth with the exact vertical slowness: < 1 µm at 50 m)
_DEPTH_STEP_M = 1.0


class ProfileRanging:
    """Horizontal and slant ranges from travel times, for a beacon at one depth and a vehicle at many.

    Parameters
    ----------
    profile : SoundSpeedProfile
        The water's c(z).
    beacon_depth_m : float
        The beacon's depth [m].
    vehicle_depths_m : array_like
        Depths the vehicle visits [m] (the table spans them).
    max_range_m : float
        Largest horizontal range the table covers [m].
    water_depth_m : float, optional
        The bottom [m]; None: no bottom (only the direct path is used anyway).

    Examples
    --------
    >>> ranging = ProfileRanging(SoundSpeedProfile.isovelocity(1500.0), 10.0, [4.0], max_range_m=500.0)
    >>> round(float(ranging.horizontal_range(np.hypot(300.0, 6.0) / 1500.0, 4.0)), 6)
    300.0
    """

    def __init__(self, profile: SoundSpeedProfile, beacon_depth_m: float, vehicle_depths_m, *,
                 max_range_m: float, water_depth_m: float | None = None):
        depths = np.asarray(vehicle_depths_m, dtype=float).reshape(-1)
        depths = depths[np.isfinite(depths)]
        if depths.size == 0:
            raise ConfigError("vehicle depth", "no finite vehicle depth to range at")
        if not max_range_m > 0:
            raise ConfigError("max_range_m", f"must be positive, got {max_range_m!r}")
        lo, hi = float(depths.min()), float(depths.max())
        rows = np.array([lo]) if hi - lo < 1e-9 else np.append(np.arange(lo, hi, _DEPTH_STEP_M), hi)
        ranges = np.union1d(np.arange(_NEAR_STEP_M, _NEAR_M, _NEAR_STEP_M),
                            np.arange(_NEAR_M, max_range_m + 2 * _FAR_STEP_M, _FAR_STEP_M))
        self.profile = profile
        self.beacon_depth_m = float(beacon_depth_m)
        self.tracer = RayTracer(profile, water_depth_m=water_depth_m)
        self.table = TravelTimeTable(self.tracer, self.beacon_depth_m, rows, ranges, max_vertices=1)

    def horizontal_range(self, tof_s, vehicle_depth_m) -> np.ndarray:
        """Horizontal range [m] of the direct ray taking ``tof_s`` [s] to ``vehicle_depth_m`` [m] (NaN: no such ray)."""
        return self.table.horizontal_range(vehicle_depth_m, tof_s)

    def slant_range(self, tof_s, vehicle_depth_m) -> np.ndarray:
        """Straight-line distance [m] between the ends of that ray: √(R² + Δz²)."""
        dz = np.asarray(vehicle_depth_m, dtype=float) - self.beacon_depth_m
        return np.hypot(self.horizontal_range(tof_s, vehicle_depth_m), dz)

    def range_per_second(self, tof_s, vehicle_depth_m) -> np.ndarray:
        """∂R/∂t [m/s] of the horizontal range: 1 / p, to carry a travel-time σ over to range."""
        r = self.horizontal_range(tof_s, vehicle_depth_m)
        p = self.table.travel_time(vehicle_depth_m, r + 1e-3) - self.table.travel_time(vehicle_depth_m, r - 1e-3)
        return 2e-3 / p

    @classmethod
    def for_records(cls, profile: SoundSpeedProfile, beacon_depth_m: float, vehicle_depths_m, tof_s, *,
                    water_depth_m: float | None = None) -> "ProfileRanging":
        """A ranging whose table covers these travel times (at the profile's fastest speed, plus 5 %)."""
        tof = np.asarray(tof_s, dtype=float)
        longest = float(np.nanmax(tof)) if np.any(np.isfinite(tof)) else 1.0
        return cls(profile, beacon_depth_m, vehicle_depths_m, max_range_m=1.05 * longest * float(profile.c_mps.max()),
                   water_depth_m=water_depth_m)
