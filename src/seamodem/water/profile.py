"""A sound-speed profile c(z): depths and speeds, linear between them.

The profile is range-independent (the same everywhere horizontally) and
piecewise linear in depth: between two nodes c(z) varies linearly, so a ray
in each layer is a circular arc (:mod:`seamodem.water.rays`). Above its first
node and below its last, c keeps the end value.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError

__all__ = ["SoundSpeedProfile", "C_MIN_MPS", "C_MAX_MPS"]

#: plausible sound speeds in natural water [m/s]: fresh water near 0 °C is ≈ 1403, the deepest trenches ≈ 1650
C_MIN_MPS, C_MAX_MPS = 1380.0, 1700.0


@dataclass(frozen=True, eq=False)
class SoundSpeedProfile:
    """Sound speed against depth, linear between the nodes.

    Parameters
    ----------
    depth_m : array_like
        Node depths [m], positive down, ≥ 0, strictly increasing, shape ``(n,)``.
    c_mps : array_like
        Sound speed at each node [m/s], within 1380–1700 m/s, shape ``(n,)``.
    source : str, optional
        Where the profile came from (a file name, a formula), for messages and sidecars.

    Raises
    ------
    ConfigError
        Empty, mismatched, non-finite, non-increasing depths, or implausible speeds;
        the message names ``source`` and the first offending node.

    Examples
    --------
    >>> p = SoundSpeedProfile([0.0, 15.0, 35.0], [1530.0, 1530.0, 1490.0])
    >>> float(p.c(25.0))
    1510.0
    """

    depth_m: np.ndarray
    c_mps: np.ndarray
    source: str = field(default="")

    def __post_init__(self):
        where = self.source or "profile"
        z = np.asarray(self.depth_m, dtype=float).reshape(-1)
        c = np.asarray(self.c_mps, dtype=float).reshape(-1)
        if z.size == 0 or z.size != c.size:
            raise ConfigError(where, f"needs as many depths as sound speeds, at least one (got {z.size} and {c.size})")
        for name, v in (("depth_m", z), ("c_mps", c)):
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                raise ConfigError(where, f"{name} at node {bad[0]} is not a finite number ({v[bad[0]]!r})")
        if z[0] < 0:
            raise ConfigError(where, f"depths are positive down; node 0 has depth {z[0]:g} m")
        step = np.flatnonzero(np.diff(z) <= 0)
        if step.size:
            i = step[0] + 1
            raise ConfigError(where, f"depths must increase strictly; node {i} ({z[i]:g} m) follows {z[i - 1]:g} m "
                                     "(an up-cast or a repeated depth: keep one direction, or bin the cast)")
        off = np.flatnonzero((c < C_MIN_MPS) | (c > C_MAX_MPS))
        if off.size:
            i = off[0]
            raise ConfigError(where, f"sound speed {c[i]:g} m/s at {z[i]:g} m is outside {C_MIN_MPS:g}–{C_MAX_MPS:g} m/s "
                                     "(a column in other units?)")
        z.flags.writeable = False
        c.flags.writeable = False
        object.__setattr__(self, "depth_m", z)
        object.__setattr__(self, "c_mps", c)

    @classmethod
    def isovelocity(cls, c_mps: float, *, depth_m: float = 0.0) -> "SoundSpeedProfile":
        """The same speed at every depth (one node at ``depth_m``)."""
        return cls([depth_m], [c_mps], source=f"isovelocity {c_mps:g} m/s")

    @classmethod
    def linear(cls, c0_mps: float, gradient_per_s: float, max_depth_m: float) -> "SoundSpeedProfile":
        """c(z) = c0 + g z from the surface to ``max_depth_m`` [m] (g in (m/s)/m = 1/s)."""
        return cls([0.0, max_depth_m], [c0_mps, c0_mps + gradient_per_s * max_depth_m],
                   source=f"linear {c0_mps:g} m/s {gradient_per_s:+g} /s")

    def c(self, depth_m) -> np.ndarray:
        """Sound speed [m/s] at depths [m] (array_like), held constant outside the nodes."""
        out = np.interp(np.asarray(depth_m, dtype=float), self.depth_m, self.c_mps)
        return out[()] if np.ndim(out) == 0 else out

    def mean_slowness_speed(self, depth_a_m: float, depth_b_m: float) -> float:
        """Harmonic mean of c between two depths [m/s]: a vertical ray's depth / travel time."""
        a, b = sorted((float(depth_a_m), float(depth_b_m)))
        if b - a < 1e-9:
            return float(self.c(a))
        z = np.union1d(np.clip(self.depth_m, a, b), [a, b])
        c = self.c(z)
        dz = np.diff(z)
        # ∫ dz / c over each linear piece: dz · ln(c1/c0) / (c1 − c0), → dz / c0 when c1 = c0
        ratio = (c[1:] - c[:-1]) / c[:-1]
        per = np.where(np.abs(ratio) > 1e-12, np.log1p(ratio) / np.where(ratio == 0, 1.0, ratio), 1.0) * dz / c[:-1]
        return float((b - a) / per.sum())

    def mean_speed(self, depth_a_m: float | None = None, depth_b_m: float | None = None) -> float:
        """Depth-averaged c [m/s] between two depths (default: the nodes' span)."""
        a = self.depth_m[0] if depth_a_m is None else float(depth_a_m)
        b = self.depth_m[-1] if depth_b_m is None else float(depth_b_m)
        a, b = sorted((a, b))
        if b - a < 1e-9:
            return float(self.c(a))
        z = np.union1d(np.clip(self.depth_m, a, b), [a, b])
        return float(np.trapezoid(self.c(z), z) / (b - a))

    def to_dict(self) -> dict:
        """Plain lists, for a sidecar or a scenario (:meth:`from_dict` reads them back)."""
        return {"depth_m": self.depth_m.tolist(), "c_mps": self.c_mps.tolist(), "source": self.source}

    @classmethod
    def from_dict(cls, d: dict, *, where: str = "profile") -> "SoundSpeedProfile":
        """The profile :meth:`to_dict` wrote (``where`` names it in errors)."""
        if not isinstance(d, dict) or "depth_m" not in d or "c_mps" not in d:
            raise ConfigError(where, "needs depth_m and c_mps lists")
        try:
            return cls(np.asarray(d["depth_m"], dtype=float), np.asarray(d["c_mps"], dtype=float),
                       source=str(d.get("source") or where))
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ConfigError):
                raise
            raise ConfigError(where, f"depth_m and c_mps must be lists of numbers ({exc})") from None

    def __repr__(self) -> str:
        return (f"SoundSpeedProfile({self.depth_m.size} nodes, {self.depth_m[0]:g}–{self.depth_m[-1]:g} m, "
                f"c {self.c_mps.min():.2f}–{self.c_mps.max():.2f} m/s, source={self.source!r})")
