"""Desired paths: boustrophedon (paper 000 Table 2), lemniscate (paper 003 eq 2), waypoints.

A path is sampled at times ``t`` [s] and returns position, velocity and
acceleration, each of shape (n, 2) [m, m/s, m/s²], which is what the
feedback-linearization controller (paper 000 eq 2) needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["PathSample", "SegmentPath", "boustrophedon", "waypoint_path", "Lemniscate"]


@dataclass(frozen=True)
class PathSample:
    """Desired position, velocity and acceleration at the sample times, each (n, 2)."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


class SegmentPath:
    """Lines and circular arcs travelled at a constant speed.

    Parameters
    ----------
    segments : list of tuple
        ``("line", start_xy, end_xy)`` or ``("arc", centre_xy, radius_m, start_angle_rad, sweep_rad)``
        (positive sweep = counter-clockwise); consecutive segments should join.
    speed_mps : float
        Constant speed along the path [m/s]. After the end the target stays at the end point.
    """

    def __init__(self, segments, speed_mps: float):
        if not speed_mps > 0:
            raise ConfigError("speed_mps", f"must be > 0 m/s, got {speed_mps!r}")
        if not segments:
            raise ConfigError("segments", "needs at least one segment")
        self.segments = list(segments)
        self.speed_mps = float(speed_mps)
        lengths = []
        for seg in self.segments:
            if seg[0] == "line":
                lengths.append(float(np.hypot(*(np.subtract(seg[2], seg[1])))))
            elif seg[0] == "arc":
                lengths.append(abs(float(seg[2]) * float(seg[4])))
            else:
                raise ConfigError("segments", f"segment type must be 'line' or 'arc', got {seg[0]!r}")
        self.lengths = np.array(lengths)
        self.length_m = float(self.lengths.sum())

    @property
    def duration_s(self) -> float:
        """Time to travel the whole path [s]."""
        return self.length_m / self.speed_mps

    def sample(self, t_s) -> PathSample:
        """Desired state at times ``t_s`` [s], shape (n,)."""
        s = np.clip(np.asarray(t_s, dtype=float) * self.speed_mps, 0.0, self.length_m)
        moving = np.asarray(t_s, dtype=float) * self.speed_mps < self.length_m
        starts = np.concatenate([[0.0], np.cumsum(self.lengths)[:-1]])
        index = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(self.segments) - 1)
        pos = np.zeros((s.size, 2))
        vel = np.zeros((s.size, 2))
        acc = np.zeros((s.size, 2))
        v = self.speed_mps
        for i, seg in enumerate(self.segments):
            sel = index == i
            u = s[sel] - starts[i]
            if seg[0] == "line":
                p0, p1 = np.asarray(seg[1], float), np.asarray(seg[2], float)
                direction = (p1 - p0) / self.lengths[i]
                pos[sel] = p0 + u[:, None] * direction
                vel[sel] = v * direction
            else:
                centre, radius, a0, sweep = np.asarray(seg[1], float), float(seg[2]), float(seg[3]), float(seg[4])
                sign = np.sign(sweep)
                angle = a0 + sign * u / radius
                radial = np.stack([np.cos(angle), np.sin(angle)], axis=1)
                tangent = sign * np.stack([-np.sin(angle), np.cos(angle)], axis=1)
                pos[sel] = centre + radius * radial
                vel[sel] = v * tangent
                acc[sel] = -(v * v / radius) * radial  # centripetal
        vel[~moving] = 0.0
        acc[~moving] = 0.0
        return PathSample(pos, vel, acc)


def boustrophedon(
    *,
    width_m: float = 100.0,
    lane_length_m: float = 235.0,
    n_lanes: int = 6,
    y0_m: float = 7.5,
    speed_mps: float = 1567.0 / 1550.0,
) -> SegmentPath:
    """Lawn-mower survey: ``n_lanes`` lanes along y joined by half circles.

    Parameters
    ----------
    width_m : float
        x of the last lane [m] (the first is at x = 0); lane spacing
        ``width_m / (n_lanes - 1)``, turn radius half of it.
    lane_length_m : float
        Length of a straight lane [m].
    n_lanes : int
        Number of lanes, ≥ 2.
    y0_m : float
        y where the lanes start [m].
    speed_mps : float
        Constant speed along the path [m/s].

    Returns
    -------
    SegmentPath
        Lines and arcs, starting at (0, ``y0_m``) heading +y.

    Raises
    ------
    ConfigError
        ``n_lanes`` below 2.

    Notes
    -----
    Defaults reproduce paper 000 Table 2 as closely as the text allows: lanes from
    x = 0 to x = ``width_m`` (spacing 20 m, turn radius 10 m), 235 m long, so the
    path covers 100 m × 255 m and is 6·235 + 5·π·10 = 1567.1 m long (paper: 1567 m),
    travelled at 1567/1550 m/s (paper: 1550 s mission). The lane layout itself is
    not printed in the paper (Fig. 7 shows it only as a picture) and is our choice.
    """
    if n_lanes < 2:
        raise ConfigError("n_lanes", f"must be >= 2, got {n_lanes!r}")
    spacing = width_m / (n_lanes - 1)
    radius = spacing / 2
    y_low, y_high = y0_m, y0_m + lane_length_m
    segments = []
    for lane in range(n_lanes):
        x = lane * spacing
        up = lane % 2 == 0
        start, end = ((x, y_low), (x, y_high)) if up else ((x, y_high), (x, y_low))
        segments.append(("line", start, end))
        if lane < n_lanes - 1:
            # Turn towards +x: clockwise at the top, counter-clockwise at the bottom.
            centre = (x + radius, end[1])
            segments.append(("arc", centre, radius, np.pi, -np.pi if up else np.pi))
    return SegmentPath(segments, speed_mps)


def waypoint_path(waypoints_xy, speed_mps: float) -> SegmentPath:
    """Straight legs through ``waypoints_xy`` (shape (n, 2), n >= 2) at constant speed.

    Parameters
    ----------
    waypoints_xy : array_like, shape (n_waypoints, 2)
        Waypoints (x, y) [m], n_waypoints ≥ 2.
    speed_mps : float
        Speed along every leg [m/s].

    Returns
    -------
    SegmentPath
        One line segment per leg.

    Raises
    ------
    ConfigError
        Wrong shape or fewer than two waypoints.
    """
    points = np.asarray(waypoints_xy, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
        raise ConfigError("waypoints_xy", f"must have shape (n >= 2, 2), got {points.shape}")
    return SegmentPath([("line", a, b) for a, b in zip(points[:-1], points[1:])], speed_mps)


@dataclass(frozen=True)
class Lemniscate:
    """Lemniscate of Bernoulli, paper 003 eq 2.

    x_d = a·sin(ωt)/(1 + cos²(ωt)), y_d = a·sin(ωt)·cos(ωt)/(1 + cos²(ωt)).

    Parameters
    ----------
    a_m : float
        Half-width [m] (paper 003: 0.6 m).
    omega_rad_s : float
        Angular rate [rad/s] (paper 003 "f_1 = 1 Hz", read as 1 rad/s).
    centre_xy : tuple
        Offset of the figure's centre [m].
    """

    a_m: float = 0.6
    omega_rad_s: float = 1.0
    centre_xy: tuple = (0.0, 0.0)

    def sample(self, t_s) -> PathSample:
        w = self.omega_rad_s
        wt = w * np.asarray(t_s, dtype=float)
        s, c, s2, c2 = np.sin(wt), np.cos(wt), np.sin(2 * wt), np.cos(2 * wt)
        d, d1, d2 = 1 + c * c, -w * s2, -2 * w * w * c2
        nums = (
            (self.a_m * s, self.a_m * w * c, -self.a_m * w * w * s),
            (0.5 * self.a_m * s2, self.a_m * w * c2, -2 * self.a_m * w * w * s2),
        )
        pos, vel, acc = [], [], []
        for n0, n1, n2 in nums:  # quotient rule for N/D, first and second derivatives
            q1 = (n1 * d - n0 * d1) / d**2
            q2 = (n2 * d - n0 * d2) / d**2 - 2 * d1 * q1 / d
            pos.append(n0 / d)
            vel.append(q1)
            acc.append(q2)
        centre = np.asarray(self.centre_xy, dtype=float)
        return PathSample(np.stack(pos, 1) + centre, np.stack(vel, 1), np.stack(acc, 1))
