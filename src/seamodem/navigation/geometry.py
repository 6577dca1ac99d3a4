"""Geometry: slant to horizontal ranges, geodetic (WGS-84) to local east-north coordinates."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import ConfigError

__all__ = [
    "slant_to_horizontal",
    "geodetic_to_local",
    "local_to_geodetic",
    "check_lat_lon",
    "CoordinateWarning",
    "EARTH_RADIUS_M",
    "WGS84_A_M",
    "WGS84_F",
    "SWAP_DISTANCE_M",
]

#: Equatorial radius of WGS-84 [m], the value paper 001 uses (eq 50–52).
EARTH_RADIUS_M = 6378137.0
#: WGS-84 semi-major axis [m] and flattening (NIMA TR8350.2).
WGS84_A_M = 6378137.0
WGS84_F = 1.0 / 298.257223563
#: Two points of one mission farther apart than this [m] are suspect (see :func:`check_lat_lon`).
SWAP_DISTANCE_M = 50e3


class CoordinateWarning(UserWarning):
    """A latitude/longitude pair that is valid but looks mistyped (e.g. given as lon,lat)."""


def slant_to_horizontal(slant_m, depth_vehicle_m, depth_beacon_m) -> np.ndarray:
    """Horizontal range from a slant range and the two known depths [m].

    Parameters
    ----------
    slant_m : float or array_like
        Slant (3-D) range d_3D [m].
    depth_vehicle_m, depth_beacon_m : float or array_like
        Depths z_R and z_B [m], both with the same sign convention.

    Returns
    -------
    numpy.ndarray
        Horizontal range d_2D ≥ 0 [m]; the inputs' broadcast shape.

    Notes
    -----
    d_2D = √(d_3D² − (z_R − z_B)²) (paper 004 eq 10; paper 001 eq 53 inverted).
    A slant range shorter than the depth difference (noise near the vertical)
    gives 0, the closest consistent horizontal range.
    """
    slant = np.asarray(slant_m, dtype=float)
    dz = np.asarray(depth_vehicle_m, dtype=float) - np.asarray(depth_beacon_m, dtype=float)
    return np.sqrt(np.maximum(slant**2 - dz**2, 0.0))


def _check_origin(origin_lat_deg, origin_lon_deg) -> None:
    for name, value in (("origin_lat_deg", origin_lat_deg), ("origin_lon_deg", origin_lon_deg)):
        if not np.isfinite(value):
            raise ConfigError(name, f"must be finite, got {value!r}")
    if not -90 < origin_lat_deg < 90:
        raise ConfigError("origin_lat_deg", f"must be in (-90, 90) degrees, got {origin_lat_deg!r}")
    if not -180 <= origin_lon_deg <= 180:
        raise ConfigError("origin_lon_deg", f"must be in [-180, 180] degrees, got {origin_lon_deg!r}")


def geodetic_to_local(lat_deg, lon_deg, origin_lat_deg: float, origin_lon_deg: float, *, height_m=0.0,
                      origin_height_m: float = 0.0):
    """East and north offsets [m] of (lat, lon) from an origin, on the WGS-84 ellipsoid.

    Parameters
    ----------
    lat_deg, lon_deg : float or array_like
        Geodetic latitude and longitude of the points [deg].
    origin_lat_deg, origin_lon_deg : float
        Geodetic latitude and longitude of the local frame's origin [deg].
    height_m, origin_height_m : float or array_like
        Heights above the ellipsoid of the points and of the origin [m]; 0 (sea
        level on the ellipsoid) unless given.

    Returns
    -------
    east_m, north_m : float or ndarray
        Coordinates in the local east-north-up frame tangent to the ellipsoid at
        the origin [m]; the up coordinate is dropped.

    Raises
    ------
    ConfigError
        Non-finite origin, origin latitude outside (−90, 90) or longitude outside
        [−180, 180] degrees.

    Notes
    -----
    Exact geodetic → ECEF → ENU transformation on WGS-84 (``pymap3d.geodetic2enu``),
    no small-offset approximation: the error is the float64 rounding of the
    Earth-centred coordinates, below 10 nm. Paper 001 (eq 50–52) uses an
    equirectangular sphere of radius a = 6378137 m instead, which ignores that
    the ellipsoid's meridian radius of curvature M and prime-vertical radius N
    differ from a: its north–south scale is off by +0.67 % at the equator to
    −0.34 % at the poles, its east–west scale by 0 to −0.34 %. At Brest (48.4° N)
    that is +0.11 % north and −0.19 % east, 0.5 m and 0.8 m at 450 m from the
    origin: far above the receiver's centimetre ranges.

    Examples
    --------
    >>> east, north = geodetic_to_local(48.001, -4.0, 48.0, -4.0)
    >>> round(float(north), 3), round(float(abs(east)), 6)
    (111.19, 0.0)
    """
    _check_origin(origin_lat_deg, origin_lon_deg)
    from pymap3d import geodetic2enu  # 40 ms to import: paid only by geodetic runs

    east, north, _ = geodetic2enu(np.asarray(lat_deg, dtype=float), np.asarray(lon_deg, dtype=float),
                                  np.asarray(height_m, dtype=float), origin_lat_deg, origin_lon_deg,
                                  origin_height_m)
    return np.asarray(east)[()], np.asarray(north)[()]


def local_to_geodetic(east_m, north_m, origin_lat_deg: float, origin_lon_deg: float, *, height_m=0.0,
                      origin_height_m: float = 0.0):
    """Inverse of :func:`geodetic_to_local`: (lat, lon) [deg] of local (east, north) [m].

    Parameters
    ----------
    east_m, north_m : float or array_like
        Local east and north coordinates [m].
    origin_lat_deg, origin_lon_deg : float
        Geodetic latitude and longitude of the local frame's origin [deg].
    height_m, origin_height_m : float or array_like
        Height above the ellipsoid of the points and of the origin [m] (0 unless given).

    Returns
    -------
    lat_deg, lon_deg : float or ndarray
        Geodetic latitude and longitude on WGS-84 [deg].

    Notes
    -----
    The point sought is the one at ellipsoidal height ``height_m`` whose east and
    north coordinates are the ones given; its up coordinate (−d²/2R, −8 m at
    10 km) is unknown. It is found by fixed-point iteration on up: u ← u −
    (h(u) − height_m), the derivative dh/du being cos(d/R) ≈ 1, so each step
    divides the error by about (d/R)² and three steps reach float64 precision
    over any mission. Using up = 0 instead would shift the point by u·d/R (1.3 cm
    at 10 km).
    """
    _check_origin(origin_lat_deg, origin_lon_deg)
    from pymap3d import enu2geodetic

    east = np.asarray(east_m, dtype=float)
    north = np.asarray(north_m, dtype=float)
    target_h = np.asarray(height_m, dtype=float)
    up = np.zeros(np.broadcast(east, north, target_h).shape)
    for _ in range(3):
        lat, lon, h = enu2geodetic(east, north, up, origin_lat_deg, origin_lon_deg, origin_height_m)
        up = up - (np.asarray(h) - target_h)
    lat, lon, _ = enu2geodetic(east, north, up, origin_lat_deg, origin_lon_deg, origin_height_m)
    return np.asarray(lat)[()], np.asarray(lon)[()]


def _distance_m(lat1, lon1, lat2, lon2):
    """Great-circle distance [m] (haversine, sphere of radius a): ±0.5 %, enough to compare with 50 km."""
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dl = np.radians(np.asarray(lon2, dtype=float) - lon1)
    s = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * np.arcsin(np.sqrt(np.clip(s, 0.0, 1.0)))


def check_lat_lon(lat_deg, lon_deg, what: str, *, reference=None, reference_what: str = "the origin"):
    """Check a latitude/longitude pair (scalars or arrays) [deg]; return them as float arrays.

    Parameters
    ----------
    lat_deg, lon_deg : float or array_like
        The pair as given [deg], latitude first.
    what : str
        Name of the parameter or file column in the messages (e.g. ``"start"``).
    reference : (float, float), optional
        (lat, lon) [deg] of another point of the same mission (the beacon, the
        origin): enables the swap check below.
    reference_what : str
        Name of ``reference`` in the warning.

    Returns
    -------
    lat_deg, lon_deg : float or ndarray

    Raises
    ------
    ConfigError
        A value that is not finite, |lat| > 90 or |lon| > 180. When |lat| > 90 but
        |lon| ≤ 90 the message adds that the pair looks given as lon,lat.

    Warns
    -----
    CoordinateWarning
        When, with ``reference``, the points are more than
        :data:`SWAP_DISTANCE_M` (50 km) from it as given but within 50 km once
        their latitude and longitude are exchanged: then the pair was almost
        certainly typed as lon,lat.

    Notes
    -----
    A single-beacon acoustic mission spans a few kilometres (the modem's range), so
    50 km between the beacon and the start fix is never real, while exchanging
    latitude and longitude moves a point by hundreds of kilometres except within
    ~0.3° of the line lat = lon. Near that line the check cannot tell and stays
    silent; so does it when both points are swapped alike (they are then close to
    each other either way): only the range check can catch those.
    """
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    for name, value in (("latitude", lat), ("longitude", lon)):
        bad = ~np.isfinite(value)
        if bad.any():
            raise ConfigError(what, f"{name} must be finite, got {float(value[bad].flat[0])!r}")
    bad_lat = np.abs(lat) > 90
    if bad_lat.any():
        lat_b, lon_b = np.broadcast_arrays(lat, lon)
        k = np.flatnonzero(bad_lat.ravel() if bad_lat.ndim else [True])[0]
        value, other = float(lat_b.ravel()[k]), float(lon_b.ravel()[k])
        hint = " (looks like lon,lat: give lat,lon)" if abs(other) <= 90 else ""
        raise ConfigError(what, f"latitude must be in [-90, 90] degrees, got {value!r}{hint}")
    bad_lon = np.abs(lon) > 180
    if bad_lon.any():
        raise ConfigError(what, f"longitude must be in [-180, 180] degrees, got {float(lon[bad_lon].flat[0])!r}")
    if reference is not None:
        ref_lat, ref_lon = (float(v) for v in reference)
        as_given = _distance_m(ref_lat, ref_lon, lat, lon)
        swapped = _distance_m(ref_lat, ref_lon, lon, lat)
        suspect = (as_given > SWAP_DISTANCE_M) & (swapped < SWAP_DISTANCE_M)
        if suspect.any():
            n = int(np.count_nonzero(suspect))
            where = f"{n} of {suspect.size} points" if suspect.size > 1 else f"({float(lat.flat[0]):g}, {float(lon.flat[0]):g})"
            warnings.warn(
                f"{what}: {where} {math.ceil(float(as_given[suspect].flat[0]) / 1e3):g} km from {reference_what} "
                f"but within {SWAP_DISTANCE_M / 1e3:g} km if read as lon,lat: was it given as lon,lat? (expected lat,lon)",
                CoordinateWarning, stacklevel=2)
    return lat[()], lon[()]
