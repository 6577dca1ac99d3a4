"""Array geometry for direction finding: unit vectors, volume / planar / linear arrays and their ambiguity.

Body frame x forward, y port, z up; azimuth atan2(u_y, u_x), elevation
asin(u_z) (:mod:`seamodem.channel.array`). The mirror image through a flat
array's plane, or the cone about a line, fits as well as the truth: an
assumption (beacon below the plane; beacon to port at elevation 0) picks one,
and :class:`ArrayGeometry` states it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError


def unit_vector(azimuth_rad, elevation_rad) -> np.ndarray:
    """The unit vector of a direction, u = (cos e cos a, cos e sin a, sin e).

    Parameters
    ----------
    azimuth_rad, elevation_rad : float or numpy.ndarray
        Azimuth a and elevation e [rad] (broadcast together).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        u in the body frame (x forward, y port, z up).
    """
    a, e = np.asarray(azimuth_rad, float), np.asarray(elevation_rad, float)
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


#: a flat array's normal (a line's axis) must be this far from horizontal (vertical) for the stated assumption
MIN_AXIS_COMPONENT = 0.2


@dataclass(frozen=True, eq=False)
class ArrayGeometry:
    """What an array's element positions can measure, and the assumption that completes it.

    Attributes
    ----------
    positions_m : numpy.ndarray, shape (n, 3)
    kind : str
        "volume" (azimuth and elevation unambiguous), "planar" (the direction's
        component along the plane's normal is known up to its sign: the mirror
        image through the plane fits equally well) or "linear" (only the angle
        to the line is measured: every direction on a cone about it fits).
    axis : numpy.ndarray, shape (3,)
        Planar: the plane's unit normal, oriented upwards (n_z > 0). Linear: the
        line's unit direction (horizontal). Volume: zeros.
    assume : str
        Planar: "below" (default) or "above": the side of the plane the beacon is on.
        Linear: "port" (default) or "starboard" of the line, and elevation 0.
    """

    positions_m: np.ndarray
    kind: str
    axis: np.ndarray
    assume: str = ""

    @property
    def ambiguity(self) -> str:
        """One line: the ambiguity and how it is resolved ("" for a volume array)."""
        if self.kind == "planar":
            return (f"flat array: the elevation's sign is not measured; the beacon is assumed {self.assume} "
                    "the array's plane (its mirror image through the plane fits equally well)")
        if self.kind == "linear":
            return ("linear array: only the angle to the line is measured (a cone about it); the beacon is assumed "
                    f"on its {self.assume} side at elevation 0, elevation not reported")
        return ""


_ASSUMPTIONS = {"planar": ("below", "above"), "linear": ("port", "starboard")}


def array_geometry(positions_m, assume: str | None = None) -> ArrayGeometry:
    """Classify element positions for direction finding (volume, planar, linear) and check the assumption.

    Parameters
    ----------
    positions_m : array_like, shape (n, 3)
        Element positions in the body frame [m].
    assume : str, optional
        Planar: "below" (default) or "above"; linear: "port" (default) or
        "starboard"; none for a volume array.

    Returns
    -------
    ArrayGeometry
        The positions, their kind, axis and the assumption taken.

    Raises
    ------
    ConfigError
        Too few elements, coincident elements, a flat array standing vertically
        or a line that is not horizontal (their ambiguity is not about the
        elevation's sign or the side), or an assumption the geometry does not take.
    """
    p = np.asarray(positions_m, float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
        raise ConfigError("array", f"direction finding needs >= 2 element positions (n, 3), got shape {p.shape}")
    centred = p - p.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred)
    rank = int(np.sum(sv > 1e-6 * max(sv[0], 1e-300))) if sv[0] > 1e-9 else 0
    kind = {3: "volume", 2: "planar", 1: "linear"}.get(rank)
    if kind is None:
        raise ConfigError("array", "direction finding needs elements at distinct positions")
    if kind == "volume":
        if p.shape[0] < 4:
            raise ConfigError("array", f"a volume array needs >= 4 elements, got {p.shape[0]}")
        if assume not in (None, ""):
            raise ConfigError("array", f"assume={assume!r}: this array measures azimuth and elevation "
                                       "unambiguously (no assumption to make)")
        return ArrayGeometry(p, kind, np.zeros(3), "")
    choices = _ASSUMPTIONS[kind]
    a = choices[0] if assume in (None, "") else str(assume)
    if a not in choices:
        raise ConfigError("array", f"assume={assume!r}: a {kind} array takes one of {', '.join(choices)}")
    if kind == "planar":
        n = vt[2] if vt[2][2] >= 0 else -vt[2]
        if n[2] < MIN_AXIS_COMPONENT:
            raise ConfigError("array", "a flat array standing (nearly) vertically: its mirror ambiguity is "
                                       "fore/aft or port/starboard, not the elevation's sign; not supported "
                                       "(use a horizontal flat array or a volume array such as 'tetra')")
        if p.shape[0] < 3:
            raise ConfigError("array", "a flat array needs >= 3 elements")
        return ArrayGeometry(p, kind, n, a)
    d = vt[0]
    if abs(d[2]) > MIN_AXIS_COMPONENT:
        raise ConfigError("array", "a linear array that is not (nearly) horizontal is not supported: "
                                   "its cone does not map to a body azimuth under the elevation-0 assumption")
    d = np.array([d[0], d[1], 0.0])
    d = d / np.linalg.norm(d)
    return ArrayGeometry(p, kind, d, a)
