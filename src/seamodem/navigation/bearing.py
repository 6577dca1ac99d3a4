"""The beacon's bearing from the vehicle's hydrophone array as a measurement (issue 17).

A receiver array (:mod:`seamodem.receive.array`) measures the direct path's
direction of arrival in the vehicle's *body* frame (x forward, y port, z up).
Level vehicle (pitch = roll = 0), heading ψ counter-clockwise from east
(paper 000 eq 1), beacon at (x_b, y_b, z_b), vehicle at (x, y, z):

    azimuth_body  = wrap(atan2(y_b − y, x_b − x) − ψ)
    elevation     = atan2(z_b − z, ρ),  ρ = √((x_b − x)² + (y_b − y)²)

so heading enters the measurement: a heading bias moves every bearing fix
sideways by ρ·bias, while a range + bearing fix needs no motion at all.

:func:`single_frame_fix` turns one frame's slant range, body azimuth (and
elevation), the heading sensor and a depth into a position with its
covariance, by first-order propagation of the inputs' variances.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["wrap_angle", "bearing_body", "bearing_jacobian", "elevation", "elevation_jacobian",
           "BearingFix", "single_frame_fix"]


def wrap_angle(a):
    """Angle(s) wrapped to [−π, π)."""
    return (np.asarray(a, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def bearing_body(x_m, y_m, heading_rad, beacon_xy_m) -> np.ndarray:
    """Body-frame azimuth of the beacon, wrap(atan2(y_b − y, x_b − x) − ψ) [rad] (level vehicle).

    Examples
    --------
    >>> round(float(bearing_body(0.0, 0.0, np.pi / 2, (0.0, 10.0))), 12)  # dead ahead
    0.0
    >>> round(float(bearing_body(0.0, 0.0, 0.0, (0.0, 10.0))), 6)  # to port
    1.570796
    """
    xb, yb = float(beacon_xy_m[0]), float(beacon_xy_m[1])
    return wrap_angle(np.arctan2(yb - np.asarray(y_m, float), xb - np.asarray(x_m, float)) - np.asarray(heading_rad, float))


def bearing_jacobian(x_m, y_m, beacon_xy_m) -> np.ndarray:
    """∂(azimuth_body)/∂(x, y, ψ), shape (..., 3).

    With dx = x_b − x, dy = y_b − y, ρ² = dx² + dy²: (dy/ρ², −dx/ρ², −1).
    """
    dx = float(beacon_xy_m[0]) - np.asarray(x_m, float)
    dy = float(beacon_xy_m[1]) - np.asarray(y_m, float)
    rho2 = dx**2 + dy**2
    return np.stack([dy / rho2, -dx / rho2, -np.ones_like(rho2)], axis=-1)


def elevation(x_m, y_m, z_m, beacon_m) -> np.ndarray:
    """Elevation of the beacon seen from the vehicle, atan2(z_b − z, ρ) [rad] (z up; level vehicle)."""
    dx = float(beacon_m[0]) - np.asarray(x_m, float)
    dy = float(beacon_m[1]) - np.asarray(y_m, float)
    return np.arctan2(float(beacon_m[2]) - np.asarray(z_m, float), np.hypot(dx, dy))


def elevation_jacobian(x_m, y_m, z_m, beacon_m) -> np.ndarray:
    """∂(elevation)/∂(x, y, z), shape (..., 3).

    With dz = z_b − z, R² = ρ² + dz²: (dx·dz/(ρR²), dy·dz/(ρR²), −ρ/R²).
    """
    dx = float(beacon_m[0]) - np.asarray(x_m, float)
    dy = float(beacon_m[1]) - np.asarray(y_m, float)
    dz = float(beacon_m[2]) - np.asarray(z_m, float)
    rho = np.hypot(dx, dy)
    r2 = rho**2 + dz**2
    return np.stack([dx * dz / (rho * r2), dy * dz / (rho * r2), -rho / r2], axis=-1)


@dataclass(frozen=True)
class BearingFix:
    """A position from one frame.

    Attributes
    ----------
    x_m, y_m, z_m : float
        Vehicle position (east, north, up) [m].
    covariance : numpy.ndarray, shape (3, 3)
        Of (x, y, z) [m²], first-order.
    horizontal_range_m : float
    bearing_world_rad : float
        Direction from the vehicle towards the beacon, counter-clockwise from east [rad].
    """

    x_m: float
    y_m: float
    z_m: float
    covariance: np.ndarray
    horizontal_range_m: float
    bearing_world_rad: float


def _fix(range_m, azimuth_body_rad, heading_rad, beacon, z_m, elevation_rad):
    """(x, y, z) from the inputs; z from the elevation when ``z_m`` is None."""
    beta = heading_rad + azimuth_body_rad
    if z_m is None:
        rho = range_m * math.cos(elevation_rad)
        z = beacon[2] - range_m * math.sin(elevation_rad)
    else:
        dz = beacon[2] - z_m
        if abs(dz) >= range_m:
            raise ConfigError("range_m", f"slant range {range_m:g} m is shorter than the depth difference {abs(dz):g} m")
        rho = math.sqrt(range_m**2 - dz**2)
        z = z_m
    return np.array([beacon[0] - rho * math.cos(beta), beacon[1] - rho * math.sin(beta), z]), rho, beta


def single_frame_fix(
    range_m: float,
    azimuth_body_rad: float,
    heading_rad: float,
    beacon_m,
    *,
    sigma_range_m: float,
    sigma_azimuth_rad: float,
    sigma_heading_rad: float,
    z_m: float | None = None,
    sigma_z_m: float = 0.0,
    elevation_rad: float | None = None,
    sigma_elevation_rad: float = 0.0,
) -> BearingFix:
    """Vehicle position from one frame: slant range, body azimuth, heading and a depth (or the elevation).

    Parameters
    ----------
    range_m : float
        Slant range to the beacon [m].
    azimuth_body_rad : float
        Body-frame azimuth of the beacon [rad] (level vehicle).
    heading_rad : float
        Heading ψ, counter-clockwise from east [rad].
    beacon_m : (float, float, float)
        Beacon position (east, north, up) [m].
    sigma_range_m, sigma_azimuth_rad, sigma_heading_rad : float
        Their standard deviations (independent).
    z_m, sigma_z_m : float, optional
        Vehicle z (up; −depth) from a pressure sensor, and its std [m].
    elevation_rad, sigma_elevation_rad : float, optional
        Used instead when no ``z_m`` is given.

    Returns
    -------
    BearingFix

    Notes
    -----
    ρ = √(R² − (z_b − z)²), β = ψ + azimuth, (x, y) = (x_b − ρ cos β, y_b − ρ sin β).
    The covariance is J Σ Jᵀ with J the Jacobian of (x, y, z) with respect to
    (R, azimuth, ψ, z or elevation), by central differences, and Σ the inputs'
    variances, plus (ρσ_β²)² along the line of sight (σ_β² = σ_az² + σ_ψ²): the
    second-order shortening ρ(1 − cos δ), which a first-order covariance misses
    and which dominates the radial error when the range is centimetric. Cross-range error ≈ ρ·√(σ_az² + σ_ψ²): a heading bias shifts
    the fix by ρ·bias, whatever the array's accuracy.

    Examples
    --------
    >>> f = single_frame_fix(50.0, 0.0, 0.0, (100.0, 0.0, -10.0), z_m=-10.0, sigma_range_m=0.01,
    ...                      sigma_azimuth_rad=0.01, sigma_heading_rad=0.01)
    >>> round(f.x_m, 9), round(f.y_m, 9)
    (50.0, 0.0)
    """
    beacon = tuple(float(v) for v in beacon_m)
    if len(beacon) != 3:
        raise ConfigError("beacon_m", f"must be (x, y, z) [m], got {beacon_m!r}")
    if z_m is None and elevation_rad is None:
        raise ConfigError("z_m", "give the vehicle's z (depth sensor) or the measured elevation")
    if not range_m > 0:
        raise ConfigError("range_m", f"must be > 0, got {range_m!r}")
    last = z_m if z_m is not None else elevation_rad
    sig_last = sigma_z_m if z_m is not None else sigma_elevation_rad
    inputs = np.array([range_m, azimuth_body_rad, heading_rad, last], dtype=float)
    sigmas = np.array([sigma_range_m, sigma_azimuth_rad, sigma_heading_rad, sig_last], dtype=float)
    if np.any(~np.isfinite(sigmas)) or np.any(sigmas < 0):
        raise ConfigError("sigma", f"standard deviations must be finite and >= 0, got {sigmas.tolist()}")

    def f(v):
        if z_m is not None:
            return _fix(v[0], v[1], v[2], beacon, v[3], None)[0]
        return _fix(v[0], v[1], v[2], beacon, None, v[3])[0]

    pos, rho, beta = _fix(range_m, azimuth_body_rad, heading_rad, beacon, z_m, elevation_rad)
    steps = np.array([1e-6 * max(range_m, 1.0), 1e-7, 1e-7, 1e-6 if z_m is not None else 1e-7])
    J = np.column_stack([(f(inputs + h * e) - f(inputs - h * e)) / (2 * h) for h, e in zip(steps, np.eye(4))])
    cov = J @ np.diag(sigmas**2) @ J.T
    # second order: an angle error δ shortens the fix along the line of sight by ρ(1 − cos δ) ≈ ρδ²/2
    # (mean ρσ²/2, std ρσ²/√2); at metres of cross-range it exceeds a centimetre range σ
    var_beta = sigma_azimuth_rad**2 + sigma_heading_rad**2
    u = np.array([math.cos(beta), math.sin(beta), 0.0])
    cov = cov + (rho * var_beta) ** 2 * np.outer(u, u)
    return BearingFix(float(pos[0]), float(pos[1]), float(pos[2]), cov, float(rho), float(wrap_angle(beta)))
