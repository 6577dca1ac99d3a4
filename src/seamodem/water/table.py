"""A fast table of one path's travel time against receiver depth and horizontal range, and back.

The eigenrays are traced once on a grid of receiver depths × horizontal
ranges (all ranges of a depth at once, :meth:`RayTracer.solve`); queries
between the nodes use cubic Hermite interpolation with the exact
derivatives the tracer gives (∂t/∂R = p, ∂t/∂z_r = the vertical slowness),
so that the table stays within micrometres of the tracer on metre-spaced
nodes. The inverse, horizontal range from travel time, interpolates
R(t) the same way (∂R/∂t = 1/p, ∂R/∂z_r = −(∂t/∂z_r)/p).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .rays import RayTracer, path_name

__all__ = ["TravelTimeTable"]


def _hermite(x0, x1, y0, y1, d0, d1, x):
    """Cubic Hermite between (x0, y0, y0') and (x1, y1, y1'), evaluated at x (all arrays, broadcast)."""
    h = x1 - x0
    u = np.where(h != 0, (x - x0) / np.where(h != 0, h, 1.0), 0.0)
    u2, u3 = u * u, u * u * u
    return ((2 * u3 - 3 * u2 + 1) * y0 + (u3 - 2 * u2 + u) * h * d0
            + (-2 * u3 + 3 * u2) * y1 + (u3 - u2) * h * d1)


class TravelTimeTable:
    """Travel time of the first arrival along one path, from a source depth to a grid of depths and ranges.

    Parameters
    ----------
    tracer : RayTracer
        The profile and the water depth.
    source_depth_m : float
        The source's depth [m].
    receiver_depths_m : array_like
        Receiver depths [m], increasing, shape ``(n_z,)`` (one depth: no interpolation in depth).
    ranges_m : array_like
        Horizontal ranges [m], > 0, increasing, shape ``(n_r,)``.
    path : str
        Which path: ``direct`` (no reflection; turning points allowed), ``surface``, ``bottom``,
        ``surface-bottom``, ... (:func:`~seamodem.water.rays.path_name`).
    max_vertices : int
        Vertices (reflections and turning points) the search allows.

    Attributes
    ----------
    time_s, dt_drange, dt_ddepth : numpy.ndarray
        The nodes: travel time [s] and its derivatives [s/m], shape ``(n_z, n_r)``; NaN where
        the path does not reach the receiver (a shadow).

    Raises
    ------
    ConfigError
        Grids that are not increasing, or ranges that are not positive.

    Examples
    --------
    >>> from seamodem.water import SoundSpeedProfile
    >>> tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=50.0)
    >>> table = TravelTimeTable(tracer, 10.0, [5.0], np.arange(10.0, 1001.0, 10.0))
    >>> round(float(table.travel_time(5.0, 300.0)) * 1500.0, 6), round(float(table.horizontal_range(5.0, 0.2)), 6)
    (300.041664, 299.95833)
    """

    def __init__(self, tracer: RayTracer, source_depth_m: float, receiver_depths_m, ranges_m, *,
                 path: str = "direct", max_vertices: int = 2):
        z = np.atleast_1d(np.asarray(receiver_depths_m, dtype=float))
        r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
        if np.any(np.diff(z) <= 0) or np.any(np.diff(r) <= 0):
            raise ConfigError("travel-time table", "receiver depths and ranges must increase strictly")
        if r[0] <= 0:
            raise ConfigError("travel-time table", f"ranges must be positive, got {r[0]!r}")
        tracer.check_depths(source_depth_m, *z)
        self.tracer, self.path = tracer, path
        self.source_depth_m = float(source_depth_m)
        self.depths_m, self.ranges_m = z, r
        shape = (z.size, r.size)
        self.time_s = np.full(shape, np.nan)
        self.dt_drange = np.full(shape, np.nan)
        self.dt_ddepth = np.full(shape, np.nan)
        for i, zr in enumerate(z):
            self._fill_row(i, zr, max_vertices)

    def _fill_row(self, i: int, zr: float, max_vertices: int) -> None:
        tr, zs = self.tracer, self.source_depth_m
        for fam in tr.families(max_vertices):
            for idx, angles in tr.solve(fam, zs, zr, self.ranges_m):
                a = tr.ray_arrays(fam, zs, zr, angles)
                names = np.array([path_name(int(s), int(b), not fam.down) for s, b in zip(a["n_surface"], a["n_bottom"])])
                keep = a["valid"] & (names == self.path)
                idx, t = idx[keep], a["time_s"][keep]
                first = ~(self.time_s[i, idx] <= t)  # NaN (no ray yet) or later than this one
                idx = idx[first]
                self.time_s[i, idx] = t[first]
                self.dt_drange[i, idx] = a["p"][keep][first]
                self.dt_ddepth[i, idx] = a["dt_dzr"][keep][first]

    def travel_time(self, receiver_depth_m, range_m) -> np.ndarray:
        """Travel time [s] to a receiver depth [m] at a horizontal range [m] (arrays, broadcast); NaN off the table."""
        zq, rq = np.broadcast_arrays(np.asarray(receiver_depth_m, dtype=float), np.asarray(range_m, dtype=float))
        r = self.ranges_m
        j = np.clip(np.searchsorted(r, rq) - 1, 0, r.size - 2)

        def row(i):
            t0, t1 = self.time_s[i, j], self.time_s[i, j + 1]
            p0, p1 = self.dt_drange[i, j], self.dt_drange[i, j + 1]
            q = self.dt_ddepth[i, j] + (self.dt_ddepth[i, j + 1] - self.dt_ddepth[i, j]) * (rq - r[j]) / (r[j + 1] - r[j])
            return _hermite(r[j], r[j + 1], t0, t1, p0, p1, rq), q

        out = self._along_depth(zq, row)
        return np.where((rq >= r[0]) & (rq <= r[-1]), out, np.nan)[()]

    def horizontal_range(self, receiver_depth_m, travel_time_s) -> np.ndarray:
        """Horizontal range [m] at which the path takes ``travel_time_s`` [s] to a receiver depth [m]; NaN off the table."""
        zq, tq = np.broadcast_arrays(np.asarray(receiver_depth_m, dtype=float), np.asarray(travel_time_s, dtype=float))
        r = self.ranges_m

        def row(i):
            out = np.full(tq.shape, np.nan)
            slope = np.full(tq.shape, np.nan)
            for k in np.unique(i):
                sel = i == k
                ok = np.isfinite(self.time_s[k])
                if ok.sum() < 2:
                    continue
                tt, rr, pp, qq = self.time_s[k][ok], r[ok], self.dt_drange[k][ok], self.dt_ddepth[k][ok]
                t = tq[sel]
                j = np.clip(np.searchsorted(tt, t) - 1, 0, tt.size - 2)
                inside = (t >= tt[0]) & (t <= tt[-1])
                x = _hermite(tt[j], tt[j + 1], rr[j], rr[j + 1], 1.0 / pp[j], 1.0 / pp[j + 1], t)
                w = (t - tt[j]) / (tt[j + 1] - tt[j])
                s = -((1 - w) * qq[j] / pp[j] + w * qq[j + 1] / pp[j + 1])
                out[sel], slope[sel] = np.where(inside, x, np.nan), np.where(inside, s, np.nan)
            return out, slope

        return self._along_depth(zq, row)[()]

    def _along_depth(self, zq, row):
        """Hermite in depth between the two rows around each query (``row(i)`` → values, their depth slopes)."""
        z = self.depths_m
        if z.size == 1:
            v, _ = row(np.zeros(zq.shape, dtype=int))
            return np.where(np.abs(zq - z[0]) < 1e-9, v, np.nan)
        i = np.clip(np.searchsorted(z, zq) - 1, 0, z.size - 2)
        v0, d0 = row(i)
        v1, d1 = row(i + 1)
        out = _hermite(z[i], z[i + 1], v0, v1, d0, d1, zq)
        return np.where((zq >= z[0]) & (zq <= z[-1]), out, np.nan)
