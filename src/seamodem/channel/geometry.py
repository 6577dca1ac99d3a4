"""Geometry: a fixed beacon, a vehicle on a trajectory, and the image sources of a flat waveguide.

Axes (a local east-north-up frame): x east, y north, z **up**, in metres. The
sea surface is the plane z = 0 and the flat bottom z = −depth, so every point
in the water has −depth ≤ z ≤ 0 (depth below the surface = −z).

The beacon transmits and stays still; the vehicle receives. A wave that
reaches the vehicle at time t along path p left the beacon at t − τ_p(t) with
τ_p(t) = |r(t) − b_p| / c, b_p the beacon's image for that path: exact for a
still source in a uniform, still medium, with no iteration.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import ConfigError, InputFileError

__all__ = [
    "Trajectory",
    "StraightLine",
    "WaypointTrack",
    "SampledTrack",
    "ImageSource",
    "image_sources",
    "read_track_csv",
]


class Trajectory:
    """Vehicle position r(t) [m], shape (3, n) for n times."""

    parameter = "vehicle"

    def position(self, t_s) -> np.ndarray:
        """Vehicle position at the given times.

        Parameters
        ----------
        t_s : float or array_like
            Times [s].

        Returns
        -------
        numpy.ndarray
            Positions [m], shape ``(3, n_times)``.
        """
        raise NotImplementedError

    def max_speed(self, t0_s: float, t1_s: float) -> float:
        """Largest speed |dr/dt| over [t0, t1].

        Parameters
        ----------
        t0_s, t1_s : float
            Interval ends [s].

        Returns
        -------
        float
            Speed [m/s].
        """
        raise NotImplementedError

    def z_range(self, t0_s: float, t1_s: float) -> tuple[float, float]:
        """Lowest and highest z over [t0, t1] [m].

        Parameters
        ----------
        t0_s, t1_s : float
            Interval ends [s].

        Returns
        -------
        tuple of float
            ``(z_min, z_max)`` [m], z up.
        """
        t = np.linspace(t0_s, t1_s, 10_001)
        z = self.position(t)[2]
        return float(z.min()), float(z.max())


@dataclass(frozen=True, eq=False)
class StraightLine(Trajectory):
    """r(t) = start + velocity · t.

    Attributes
    ----------
    start_m : numpy.ndarray
        Position at t = 0 [m], shape ``(3,)`` (x east, y north, z up).
    velocity_mps : numpy.ndarray
        Constant velocity [m/s], shape ``(3,)``.
    parameter : str
        Scenario key named in error messages.
    """

    start_m: np.ndarray
    velocity_mps: np.ndarray
    parameter = "vehicle.velocity_mps"

    def position(self, t_s):
        t = np.asarray(t_s, dtype=float)
        return self.start_m[:, None] + self.velocity_mps[:, None] * t.reshape(1, -1)

    def max_speed(self, t0_s, t1_s):
        return float(np.linalg.norm(self.velocity_mps))

    def z_range(self, t0_s, t1_s):
        z = self.position(np.array([t0_s, t1_s]))[2]
        return float(z.min()), float(z.max())


@dataclass(frozen=True, eq=False)
class WaypointTrack(Trajectory):
    """Straight legs between waypoints at a constant speed, from ``start_s``.

    The vehicle waits at the first waypoint before ``start_s`` and stays at the
    last one after it arrives there.

    Attributes
    ----------
    waypoints_m : numpy.ndarray
        Waypoints [m], shape ``(n_waypoints, 3)``, no two consecutive equal.
    speed_mps : float
        Speed along every leg [m/s].
    start_s : float, optional
        Time of departure from the first waypoint [s]; default 0.
    times_s : numpy.ndarray
        Arrival time at each waypoint [s], shape ``(n_waypoints,)``
        (computed).
    parameter : str
        Scenario key named in error messages.
    """

    waypoints_m: np.ndarray  # (n, 3)
    speed_mps: float
    start_s: float = 0.0
    times_s: np.ndarray = field(init=False, repr=False)
    parameter = "vehicle.waypoints_m"

    def __post_init__(self):
        legs = np.linalg.norm(np.diff(self.waypoints_m, axis=0), axis=1)
        if np.any(legs == 0):
            raise ConfigError("vehicle.waypoints_m", "two consecutive waypoints are equal")
        times = self.start_s + np.concatenate([[0.0], np.cumsum(legs)]) / self.speed_mps
        object.__setattr__(self, "times_s", times)

    def position(self, t_s):
        t = np.asarray(t_s, dtype=float).reshape(-1)
        return np.vstack([np.interp(t, self.times_s, self.waypoints_m[:, i]) for i in range(3)])

    def max_speed(self, t0_s, t1_s):
        return self.speed_mps

    def z_range(self, t0_s, t1_s):
        z = self.waypoints_m[:, 2]
        return float(z.min()), float(z.max())


@dataclass(frozen=True, eq=False)
class SampledTrack(Trajectory):
    """A measured or planned track: positions at times, joined by a cubic spline.

    Held at the first and last position outside ``times_s``.

    Attributes
    ----------
    times_s : numpy.ndarray
        Sample times [s], shape ``(n_points,)``, strictly increasing, n_points ≥ 2.
    positions_m : numpy.ndarray
        Positions [m], shape ``(n_points, 3)`` (x east, y north, z up).
    source : str, optional
        Where the track came from (a file name), for error messages.
    spline : scipy.interpolate.CubicSpline
        The interpolant (computed).
    parameter : str
        Scenario key named in error messages.
    """

    times_s: np.ndarray  # (n,)
    positions_m: np.ndarray  # (n, 3)
    source: str = ""
    spline: CubicSpline = field(init=False, repr=False)
    parameter = "vehicle.track_file"

    def __post_init__(self):
        if self.times_s.size < 2 or np.any(np.diff(self.times_s) <= 0):
            raise ConfigError(self.parameter, f"{self.source}: needs ≥ 2 rows with strictly increasing t_s")
        object.__setattr__(self, "spline", CubicSpline(self.times_s, self.positions_m, axis=0))

    def position(self, t_s):
        t = np.clip(np.asarray(t_s, dtype=float).reshape(-1), self.times_s[0], self.times_s[-1])
        return self.spline(t).T

    def check_covers(self, t0_s: float, t1_s: float) -> None:
        """Check that the track spans the times a recording needs.

        Parameters
        ----------
        t0_s, t1_s : float
            First and last time needed [s]; ``t0_s`` below 0 counts as 0.

        Raises
        ------
        ConfigError
            The track starts after ``max(t0_s, 0)`` or ends before ``t1_s``.
        """
        if self.times_s[0] > max(t0_s, 0.0) or self.times_s[-1] < t1_s:
            raise ConfigError(
                self.parameter,
                f"{self.source} covers [{self.times_s[0]:g}, {self.times_s[-1]:g}] s, "
                f"the recording needs [{max(t0_s, 0.0):g}, {t1_s:g}] s",
            )

    def max_speed(self, t0_s, t1_s):
        t = np.linspace(max(t0_s, self.times_s[0]), min(t1_s, self.times_s[-1]), 10_001)
        return float(np.max(np.linalg.norm(self.spline(t, 1), axis=1)))


def read_track_csv(path: str | Path) -> SampledTrack:
    """Read a track file: CSV with a header ``t_s,x_m,y_m,z_m`` (z up, ≤ 0 in the water).

    Parameters
    ----------
    path : str or Path
        The CSV file; other columns are ignored.

    Returns
    -------
    SampledTrack
        The rows as a spline track, ``source`` set to ``path``.

    Raises
    ------
    InputFileError
        Missing file, missing columns, or non-numeric values.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"vehicle.track_file: {path} not found")
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        need = ["t_s", "x_m", "y_m", "z_m"]
        if reader.fieldnames is None or any(c not in reader.fieldnames for c in need):
            raise InputFileError(f"vehicle.track_file: {path} needs the columns {','.join(need)}, got {reader.fieldnames}")
        try:
            rows = [[float(r[c]) for c in need] for r in reader]
        except (TypeError, ValueError) as exc:
            raise InputFileError(f"vehicle.track_file: {path} holds a non-numeric value ({exc})") from None
    data = np.array(rows, dtype=float).reshape(-1, 4)
    if not np.all(np.isfinite(data)):
        raise InputFileError(f"vehicle.track_file: {path} holds NaN or infinite values")
    return SampledTrack(data[:, 0], data[:, 1:], source=str(path))


@dataclass(frozen=True)
class ImageSource:
    """One propagation path: the beacon's image and the boundaries it met.

    ``name`` spells the reflections in order, e.g. ``"direct"``, ``"S"``
    (surface), ``"B"`` (bottom), ``"SB"`` (surface, then bottom).

    Attributes
    ----------
    name : str
        The path's reflections in order (``"direct"`` for none).
    position_m : tuple of float
        The image's position ``(x, y, z)`` [m].
    n_surface : int
        Number of surface reflections.
    n_bottom : int
        Number of bottom reflections.
    """

    name: str
    position_m: tuple[float, float, float]
    n_surface: int
    n_bottom: int


def image_sources(beacon_m, water_depth_m: float, max_bounces: int) -> list[ImageSource]:
    """Direct path and the image sources of up to ``max_bounces`` reflections.

    Each order k ≥ 1 adds two paths, one whose first reflection is at the
    surface and one at the bottom, alternating afterwards. A reflection at the
    surface mirrors z ↦ −z; at the bottom z ↦ −2·depth − z. The image of a
    path with reflections r₁, …, r_k is M_{r_k}(…M_{r₁}(beacon)).

    Parameters
    ----------
    beacon_m : array_like
        Beacon position ``(x, y, z)`` [m], z up, −depth ≤ z ≤ 0.
    water_depth_m : float
        Depth of the flat bottom [m], > 0.
    max_bounces : int
        Highest number of reflections on one path; 0 gives the direct path only.

    Returns
    -------
    list of ImageSource
        ``1 + 2 * max_bounces`` paths, direct first, then by order.
    """
    x, y, z = (float(v) for v in beacon_m)
    out = [ImageSource("direct", (x, y, z), 0, 0)]
    for order in range(1, max_bounces + 1):
        for first in "SB":
            seq = "".join("SB"[("SB".index(first) + i) % 2] for i in range(order))
            zi = z
            for r in seq:
                zi = -zi if r == "S" else -2.0 * water_depth_m - zi
            out.append(ImageSource(seq, (x, y, zi), seq.count("S"), seq.count("B")))
    return out
