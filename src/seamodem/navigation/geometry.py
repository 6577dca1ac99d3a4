"""Geometry: slant to horizontal ranges, geodetic to local east-north coordinates."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["slant_to_horizontal", "geodetic_to_local", "local_to_geodetic", "EARTH_RADIUS_M"]

#: Equatorial radius of WGS-84 [m], the value paper 001 uses (eq 50–52).
EARTH_RADIUS_M = 6378137.0


def slant_to_horizontal(slant_m, depth_vehicle_m, depth_beacon_m) -> np.ndarray:
    """Horizontal range from a slant range and the two known depths [m].

    Notes
    -----
    d_2D = √(d_3D² − (z_R − z_B)²) (paper 004 eq 10; paper 001 eq 53 inverted).
    A slant range shorter than the depth difference (noise near the vertical)
    gives 0, the closest consistent horizontal range.
    """
    slant = np.asarray(slant_m, dtype=float)
    dz = np.asarray(depth_vehicle_m, dtype=float) - np.asarray(depth_beacon_m, dtype=float)
    return np.sqrt(np.maximum(slant**2 - dz**2, 0.0))


def geodetic_to_local(lat_deg, lon_deg, origin_lat_deg: float, origin_lon_deg: float):
    """East and north offsets [m] of (lat, lon) from an origin, local tangent plane.

    Notes
    -----
    Equirectangular projection on a sphere of radius :data:`EARTH_RADIUS_M`, as in
    paper 001 eq 50–52: east = R·Δλ·cos φ₀, north = R·Δφ. Over the few kilometres of
    a single-beacon mission the error is below 1 mm per 100 m of offset.
    """
    for name, value in (("origin_lat_deg", origin_lat_deg), ("origin_lon_deg", origin_lon_deg)):
        if not np.isfinite(value):
            raise ConfigError(name, f"must be finite, got {value!r}")
    if not -90 < origin_lat_deg < 90:
        raise ConfigError("origin_lat_deg", f"must be in (-90, 90) degrees, got {origin_lat_deg!r}")
    lat0 = np.radians(origin_lat_deg)
    east = EARTH_RADIUS_M * np.radians(np.asarray(lon_deg, dtype=float) - origin_lon_deg) * np.cos(lat0)
    north = EARTH_RADIUS_M * np.radians(np.asarray(lat_deg, dtype=float) - origin_lat_deg)
    return east, north


def local_to_geodetic(east_m, north_m, origin_lat_deg: float, origin_lon_deg: float):
    """Inverse of :func:`geodetic_to_local`: (lat, lon) [deg]."""
    lat0 = np.radians(origin_lat_deg)
    lat = origin_lat_deg + np.degrees(np.asarray(north_m, dtype=float) / EARTH_RADIUS_M)
    lon = origin_lon_deg + np.degrees(np.asarray(east_m, dtype=float) / (EARTH_RADIUS_M * np.cos(lat0)))
    return lat, lon
