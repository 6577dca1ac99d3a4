"""Rays in a range-independent, piecewise-linear sound-speed profile: eigenrays, travel times, angles.

Within a layer where c(z) = c_a + g (z − z_a), a ray is a circular arc and
its horizontal run and travel time between two depths have closed forms
(Snell: the ray parameter p = cos θ / c is constant, θ the grazing angle)::

    Δr = p (c_a + c_b) Δz / (s_a + s_b),          s = √(1 − p² c²)
    Δt = [ln(c_b / c_a) + ln((1 + s_a) / (1 + s_b))] / g

(the second written with ``log1p`` so that g → 0 gives Δz / (c s) without
cancellation). A ray with parameter p oscillates between an upper vertex
(where c = 1/p, a turning point, or the surface, a reflection) and a lower
one (a turning point or the bottom). A *family* is a starting direction and
a number of vertices; its horizontal range X(p) and travel time T(p) are
sums of layer integrals. Eigenrays to a receiver at horizontal range R are
the roots of X(p) = R, bracketed on a grid of launch angles and refined by
bisection, all families and all ranges at once.

Depths are positive down [m]; angles are grazing angles [rad], positive when
the ray heads down.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .profile import SoundSpeedProfile

__all__ = ["Eigenray", "RayTracer", "Family", "path_name"]


@dataclass(frozen=True)
class Family:
    """A path topology: which way the ray leaves the source, and how many vertices it passes.

    Parameters
    ----------
    down : bool
        True when the ray leaves the source heading down.
    n_vertices : int
        Vertices (turning points or reflections) between source and receiver.
    """

    down: bool
    n_vertices: int

    def last_vertex_is_upper(self) -> bool:
        """True when the last vertex is the upper one (the ray then arrives heading down)."""
        return (not self.down) == (self.n_vertices % 2 == 1)

    def n_upper(self) -> int:
        """How many of the vertices are upper ones."""
        return (self.n_vertices + (0 if self.down else 1)) // 2


@dataclass(frozen=True)
class Eigenray:
    """One ray from a source to a receiver.

    Attributes
    ----------
    name : str
        ``direct`` (no reflection, turning points allowed), ``surface``, ``bottom``,
        ``surface-bottom``, ``bottom-surface``, ... (the reflections in order) .
    n_surface, n_bottom, n_turning : int
        Surface reflections, bottom reflections and turning points on the way.
    travel_time_s : float
        Travel time [s].
    ray_parameter_spm : float
        p = cos θ / c [s/m], = ∂t/∂R.
    launch_angle_rad, arrival_angle_rad : float
        Grazing angles at the source and at the receiver [rad], positive heading down.
    dt_drange_spm, dt_dsource_depth_spm, dt_dreceiver_depth_spm : float
        Derivatives of the travel time with horizontal range and with each end's depth [s/m].
    """

    name: str
    n_surface: int
    n_bottom: int
    n_turning: int
    travel_time_s: float
    ray_parameter_spm: float
    launch_angle_rad: float
    arrival_angle_rad: float
    dt_drange_spm: float
    dt_dsource_depth_spm: float
    dt_dreceiver_depth_spm: float


def _log1p_ratio(x: np.ndarray) -> np.ndarray:
    """log1p(x) / x, = 1 at x = 0 (exact to rounding for |x| ≤ 1e-8 by its series)."""
    small = np.abs(x) <= 1e-8
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 - 0.5 * x, np.log1p(safe) / safe)


def path_name(n_surface: int, n_bottom: int, upper_first: bool) -> str:
    """A path's name from its reflections: ``direct``, ``surface``, ``bottom``, ``surface2``, ``surface-bottom``, ...

    ``upper_first``: the ray leaves the source heading up (so a surface reflection comes first
    when both kinds alternate).
    """
    n = n_surface + n_bottom
    if n == 0:
        return "direct"
    if n_surface == 0 or n_bottom == 0:
        return ("surface" if n_surface else "bottom") + (f"{n}" if n > 1 else "")
    seq = ["surface", "bottom"] if upper_first else ["bottom", "surface"]
    return "-".join(seq[i % 2] for i in range(n))


class RayTracer:
    """Trace rays through a profile between a flat surface (z = 0) and, optionally, a flat bottom.

    Parameters
    ----------
    profile : SoundSpeedProfile
        c(z), linear between its nodes, held beyond them.
    water_depth_m : float, optional
        Depth of the bottom [m]; None: no bottom (rays that do not turn are lost).
    n_angles : int
        Launch angles on the grid that brackets the eigenrays (more finds eigenrays closer together).

    Raises
    ------
    ConfigError
        A water depth that is not positive.

    Examples
    --------
    >>> tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=100.0)
    >>> ray = tracer.eigenrays(10.0, 20.0, 300.0)[0]
    >>> ray.name, round(ray.travel_time_s * 1500.0, 6)
    ('direct', 300.16662)
    """

    def __init__(self, profile: SoundSpeedProfile, *, water_depth_m: float | None = None, n_angles: int = 400):
        if water_depth_m is not None and not water_depth_m > 0:
            raise ConfigError("water_depth_m", f"must be positive, got {water_depth_m!r}")
        self.profile = profile
        self.water_depth_m = None if water_depth_m is None else float(water_depth_m)
        bottom = self.water_depth_m if self.water_depth_m is not None else max(profile.depth_m[-1], 1.0) * 2 + 1e4
        z = np.union1d([0.0, bottom], profile.depth_m[profile.depth_m < bottom])
        self.node_z = z
        self.node_c = profile.c(z)
        self._top, self._bottom = z[:-1], z[1:]
        self._c_top = self.node_c[:-1]
        self._g = np.diff(self.node_c) / np.diff(z)
        n_fine = n_angles // 4
        self.angle_grid = np.concatenate([np.geomspace(1e-9, 0.02, n_fine, endpoint=False),
                                          np.linspace(0.02, np.pi / 2, n_angles - n_fine)])

    # ---- layer integrals ------------------------------------------------------------------------------
    def integrals(self, p, z1, z2, *, turn1=False, turn2=False, angle=None, c_ref=None) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal run and travel time of rays with parameter p between two depths (one way).

        Parameters
        ----------
        p : array_like
            Ray parameters [s/m], with p·c(z) ≤ 1 on the span.
        z1, z2 : array_like
            The span's ends [m], z1 ≤ z2, broadcast with ``p``.
        turn1, turn2 : bool or array_like of bool
            Whether each end is the ray's turning point (there the vertical slowness is zero,
            set exactly: √(1 − p²c²) computed from a rounded p·c ≈ 1 would be ≈ 1e-8, an error
            of a millimetre in the run of a grazing ray).
        angle, c_ref : array_like and float, optional
            The rays as p = cos(angle) / c_ref: then s = √(1 − p²c²) is computed as
            √(sin² angle + cos² angle (c_ref − c)(c_ref + c) / c_ref²), exact for grazing rays
            where 1 − p²c² would cancel.

        Returns
        -------
        run_m, time_s : numpy.ndarray
            Horizontal distance [m] and travel time [s], the broadcast shape.
        """
        phi = 0.0 if angle is None else angle  # used only with c_ref
        p, z1, z2, t1, t2, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (p, z1, z2, turn1, turn2, phi)))
        p, a_, b_, phi = p[..., None], z1[..., None], z2[..., None], phi[..., None]
        a = np.clip(self._top, a_, b_)
        b = np.clip(self._bottom, a_, b_)
        dz = b - a
        g = self._g
        ca = self._c_top + g * (a - self._top)
        cb = self._c_top + g * (b - self._top)
        if c_ref is None:
            sa = np.sqrt(np.maximum(0.0, 1.0 - (p * ca) ** 2))
            sb = np.sqrt(np.maximum(0.0, 1.0 - (p * cb) ** 2))
        else:
            sin2, cos2 = np.sin(phi) ** 2, np.cos(phi) ** 2 / (c_ref * c_ref)
            sa = np.sqrt(np.maximum(0.0, sin2 + cos2 * (c_ref - ca) * (c_ref + ca)))
            sb = np.sqrt(np.maximum(0.0, sin2 + cos2 * (c_ref - cb) * (c_ref + cb)))
        sa = np.where((t1[..., None] > 0) & (a == a_), 0.0, sa)
        sb = np.where((t2[..., None] > 0) & (b == b_), 0.0, sb)
        den = sa + sb
        live = dz > 0
        den = np.where(live, den, 1.0)
        run = np.where(live, p * (ca + cb) * dz / den, 0.0)
        k = p * p * (ca + cb) / (den * (1.0 + sb))
        time = dz * (_log1p_ratio(g * dz / ca) / ca + k * _log1p_ratio(g * dz * k))
        time = np.where(live, time, 0.0)
        return run.sum(axis=-1), time.sum(axis=-1)

    def _turning(self, angles: np.ndarray, c_ref: float, z0: float, upward: bool) -> tuple[np.ndarray, np.ndarray]:
        """Depth of the first vertex above (or below) z0 for each ray, and whether it is a reflection.

        A ray p = cos(angle) / c_ref turns where c = 1/p, i.e. where c − c_ref reaches
        c_ref (1 − cos angle) / cos angle = 2 c_ref sin²(angle/2) / cos angle (written so that a
        grazing ray, whose cos rounds to 1, still tells an isovelocity layer from a turning point).
        """
        inside = (self.node_z < z0) if upward else (self.node_z > z0)
        nodes = self.node_z[inside][::-1] if upward else self.node_z[inside]
        depths = np.concatenate([[z0], nodes])
        rise = np.interp(depths, self.node_z, self.node_c) - c_ref  # c − c_ref along the way
        excess = (2.0 * c_ref * np.sin(0.5 * angles) ** 2 / np.cos(angles))[:, None]
        over = rise[None, :] >= excess  # (m, K)
        over[:, 0] = False
        hit = over.any(axis=1)
        k = np.where(hit, np.argmax(over, axis=1), 1)
        za, zb = depths[k - 1], depths[k]
        ra, rb = rise[k - 1], rise[k]
        step = np.where(rb != ra, rb - ra, 1.0)
        frac = np.where(rb != ra, (excess[:, 0] - ra) / step, 0.0)
        z_turn = za + np.clip(frac, 0.0, 1.0) * (zb - za)
        wall = 0.0 if upward else (self.water_depth_m if self.water_depth_m is not None else np.inf)
        return np.where(hit, z_turn, wall), ~hit

    # ---- families -------------------------------------------------------------------------------------
    def families(self, max_vertices: int) -> list[Family]:
        """Direct (0 vertices), then each starting direction with 1 … ``max_vertices`` vertices."""
        return [Family(False, 0)] + [Family(d, k) for k in range(1, max_vertices + 1) for d in (False, True)]

    def family_curves(self, family: Family, source_depth_m: float, receiver_depth_m: float, angles) -> dict:
        """Horizontal range X and travel time T of one family's rays, with what their vertices are.

        Parameters
        ----------
        family : Family
        source_depth_m, receiver_depth_m : float
            Depths [m].
        angles : array_like
            The rays, by their grazing angle at the faster of the two ends [rad], in (0, π/2]:
            p = cos(angle) / max(c_source, c_receiver).

        Returns
        -------
        dict
            ``p`` [s/m], ``range_m``, ``time_s`` (NaN where the family does not reach the receiver),
            ``upper_reflects``, ``lower_reflects`` (bool arrays) and ``valid``.
        """
        zs, zr = self._ends(family, source_depth_m, receiver_depth_m)
        angles = np.asarray(angles, dtype=float)
        c_ref = max(float(self.profile.c(zs)), float(self.profile.c(zr)))
        p = np.cos(angles) / c_ref

        def run(z1, z2, **turns):
            return self.integrals(p, z1, z2, angle=angles, c_ref=c_ref, **turns)

        z_up, up_wall = self._turning(angles, c_ref, zs, True)
        z_dn, dn_wall = self._turning(angles, c_ref, zs, False)
        valid = (z_up <= zr + 1e-12) & (zr <= z_dn + 1e-12)
        if family.n_vertices == 0:
            x, t = run(min(zs, zr), max(zs, zr))
        else:
            upper_first = not family.down
            up_turns, dn_turns = ~up_wall, ~dn_wall
            head = run(z_up, zs, turn1=up_turns) if upper_first else run(zs, z_dn, turn2=dn_turns)
            tail = run(z_up, zr, turn1=up_turns) if family.last_vertex_is_upper() else run(zr, z_dn, turn2=dn_turns)
            x, t = head[0] + tail[0], head[1] + tail[1]
            if family.n_vertices > 1:
                fx, ft = run(z_up, np.where(np.isfinite(z_dn), z_dn, zs), turn1=up_turns, turn2=dn_turns)
                x, t = x + (family.n_vertices - 1) * fx, t + (family.n_vertices - 1) * ft
            if family.down or family.n_vertices > 1:
                valid &= np.isfinite(z_dn)
        x = np.where(valid, x, np.nan)
        t = np.where(valid, t, np.nan)
        return {"p": p, "range_m": x, "time_s": t, "upper_reflects": up_wall, "lower_reflects": dn_wall,
                "valid": valid}

    #: for the vertex-free family, a receiver at the source's depth is moved this far [m]: the horizontal
    #: direct ray is then found as any other, at a travel-time cost of Δz² / (2 R c) < 1e-13 s beyond 1 m
    EQUAL_DEPTH_STEP_M = 1e-5

    def _ends(self, family: Family, source_depth_m: float, receiver_depth_m: float) -> tuple[float, float]:
        zs, zr = float(source_depth_m), float(receiver_depth_m)
        if family.n_vertices == 0 and abs(zr - zs) < self.EQUAL_DEPTH_STEP_M:
            deeper = self.water_depth_m is None or zs + self.EQUAL_DEPTH_STEP_M <= self.water_depth_m
            zr = zs + (self.EQUAL_DEPTH_STEP_M if deeper else -self.EQUAL_DEPTH_STEP_M)
        return zs, zr

    def check_depths(self, *depths_m: float) -> None:
        """Raise ConfigError when a depth is above the surface or below the bottom."""
        for z in depths_m:
            if not np.all(np.asarray(z) >= 0) or (self.water_depth_m is not None and np.any(np.asarray(z) > self.water_depth_m)):
                raise ConfigError("depth", f"must lie within the water, 0–{self.water_depth_m or np.inf:g} m, got {z!r}")

    def solve(self, family: Family, source_depth_m: float, receiver_depth_m: float, ranges_m,
              *, iterations: int = 40) -> list[tuple[np.ndarray, np.ndarray]]:
        """Launch angles of one family's eigenrays at many horizontal ranges at once.

        Parameters
        ----------
        family : Family
        source_depth_m, receiver_depth_m : float
            Depths [m].
        ranges_m : array_like
            Horizontal ranges [m], shape ``(n,)``.
        iterations : int
            False-position steps at most (a grid cell reaches rounding in about 10).

        Returns
        -------
        list of (numpy.ndarray, numpy.ndarray)
            One entry per monotonic branch of X(p): the indices of the ranges it reaches and
            the grid-angle parameter (angle at the faster end [rad]) of each eigenray.
        """
        grid = self.angle_grid
        targets = np.asarray(ranges_m, dtype=float).reshape(-1)
        x = self.family_curves(family, source_depth_m, receiver_depth_m, grid)["range_m"]
        out = []
        finite = np.isfinite(x)
        # branches: runs of valid samples, cut where X(p) turns (caustics)
        edges = np.flatnonzero(np.diff(finite.astype(np.int8)) != 0) + 1
        for run in np.split(np.arange(grid.size), edges):
            if run.size < 2 or not finite[run[0]]:
                continue
            dx = np.diff(x[run])
            turns = np.flatnonzero(np.sign(dx[1:]) * np.sign(dx[:-1]) < 0) + 1
            for piece in np.split(run, turns):
                if piece.size < 2:
                    continue
                xp = x[piece]
                lo, hi = min(xp[0], xp[-1]), max(xp[0], xp[-1])
                idx = np.flatnonzero((targets >= lo) & (targets <= hi))
                if idx.size == 0:
                    continue
                increasing = xp[-1] > xp[0]
                order = xp if increasing else xp[::-1]
                j = np.clip(np.searchsorted(order, targets[idx]), 1, piece.size - 1)
                if not increasing:
                    j = piece.size - j
                    a, b = grid[piece[j]], grid[piece[j - 1]]
                else:
                    a, b = grid[piece[j - 1]], grid[piece[j]]
                out.append((idx, self._bisect(family, source_depth_m, receiver_depth_m, targets[idx], a, b, iterations)))
        return out

    def _bisect(self, family, zs, zr, targets, a, b, iterations):
        """Illinois false position, vectorised: keeps the bracket, converges superlinearly on a smooth X."""
        fa = self._range_at(family, zs, zr, a) - targets
        fb = self._range_at(family, zs, zr, b) - targets
        for _ in range(iterations):
            den = fb - fa
            ok = (den != 0) & np.isfinite(den)
            m = np.where(ok, b - fb * (b - a) / np.where(ok, den, 1.0), 0.5 * (a + b))
            m = np.where((m - a) * (m - b) < 0, m, 0.5 * (a + b))
            fm = self._range_at(family, zs, zr, m) - targets
            flip = np.sign(fm) != np.sign(fb)
            a, fa = np.where(flip, b, a), np.where(flip, fb, 0.5 * fa)
            b, fb = m, fm
            if np.all((np.abs(fb) < 1e-10) | (np.abs(b - a) <= 4e-16 * np.abs(b))):  # 0.1 nm, or rounding
                break
        return np.where(np.abs(fa) < np.abs(fb), a, b)

    def _range_at(self, family, zs, zr, angles):
        x = self.family_curves(family, zs, zr, angles)["range_m"]
        return np.where(np.isfinite(x), x, np.inf)

    # ---- eigenrays ------------------------------------------------------------------------------------
    def eigenrays(self, source_depth_m: float, receiver_depth_m: float, range_m: float, *,
                  max_vertices: int = 2) -> list[Eigenray]:
        """Every ray from the source to the receiver with at most ``max_vertices`` vertices, first arrival first.

        Parameters
        ----------
        source_depth_m, receiver_depth_m : float
            Depths [m], within the water.
        range_m : float
            Horizontal range [m], > 0.
        max_vertices : int
            Turning points plus reflections allowed (2: direct, surface, bottom,
            surface-bottom, bottom-surface, and refracted rays that turn).

        Returns
        -------
        list of Eigenray
            Sorted by travel time.
        """
        if not range_m > 0:
            raise ConfigError("range_m", f"must be positive, got {range_m!r}")
        self.check_depths(source_depth_m, receiver_depth_m)
        rays = [ray for fam in self.families(max_vertices)
                for _, angles in self.solve(fam, source_depth_m, receiver_depth_m, [range_m])
                for ray in self.describe(fam, source_depth_m, receiver_depth_m, angles)]
        return sorted(rays, key=lambda r: r.travel_time_s)

    def ray_arrays(self, family: Family, source_depth_m: float, receiver_depth_m: float, angles) -> dict:
        """Travel time, angles, reflections and derivatives of a family's rays at grid angles, as arrays.

        Returns
        -------
        dict
            ``valid``, ``time_s``, ``p`` (= ∂t/∂R), ``launch_rad``, ``arrival_rad``,
            ``n_surface``, ``n_bottom``, ``dt_dzs``, ``dt_dzr`` [s/m], one entry per angle.
        """
        zs, zr = self._ends(family, source_depth_m, receiver_depth_m)
        angles = np.asarray(angles, dtype=float)
        cur = self.family_curves(family, zs, zr, angles)
        p = cur["p"]
        cs, cr = float(self.profile.c(zs)), float(self.profile.c(zr))
        c_ref = max(cs, cr)
        # sines and cosines of the end angles from the grid angle (exact for grazing rays, as in integrals)
        ss, sr = (np.sqrt(np.maximum(0.0, np.sin(angles) ** 2 + (np.cos(angles) / c_ref) ** 2 * (c_ref - c) * (c_ref + c)))
                  for c in (cs, cr))
        if family.n_vertices == 0:
            launch_down = arrive_down = zr > zs
        else:
            launch_down, arrive_down = family.down, family.last_vertex_is_upper()
        sign_l, sign_a = (1.0 if launch_down else -1.0), (1.0 if arrive_down else -1.0)
        n_up = family.n_upper()
        return {
            "valid": cur["valid"], "time_s": cur["time_s"], "p": p,
            "launch_rad": sign_l * np.arctan2(ss, p * cs),
            "arrival_rad": sign_a * np.arctan2(sr, p * cr),
            "n_surface": np.where(cur["upper_reflects"], n_up, 0),
            "n_bottom": np.where(cur["lower_reflects"], family.n_vertices - n_up, 0),
            "dt_dzs": -sign_l * ss / cs,
            "dt_dzr": sign_a * sr / cr,
        }

    def describe(self, family: Family, source_depth_m: float, receiver_depth_m: float, angles) -> list[Eigenray]:
        """The :class:`Eigenray` of a family at grid angles that :meth:`solve` found."""
        a = self.ray_arrays(family, source_depth_m, receiver_depth_m, angles)
        rays = []
        for i in np.flatnonzero(a["valid"]):
            ns, nb = int(a["n_surface"][i]), int(a["n_bottom"][i])
            rays.append(Eigenray(
                name=path_name(ns, nb, not family.down), n_surface=ns, n_bottom=nb,
                n_turning=family.n_vertices - ns - nb, travel_time_s=float(a["time_s"][i]),
                ray_parameter_spm=float(a["p"][i]), launch_angle_rad=float(a["launch_rad"][i]),
                arrival_angle_rad=float(a["arrival_rad"][i]), dt_drange_spm=float(a["p"][i]),
                dt_dsource_depth_spm=float(a["dt_dzs"][i]), dt_dreceiver_depth_spm=float(a["dt_dzr"][i])))
        return rays
