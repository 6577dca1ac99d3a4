"""Closed forms a ray tracer is checked against: the linear gradient's circular arcs.

In c(z) = c0 + g z a ray is an arc of a circle centred at the depth where c
would be 0; the medium is the hyperbolic half-plane with metric ds / c, so the
travel time between two points is the hyperbolic distance divided by |g|.
Nothing here is used by the tracer itself (it integrates layer by layer).
"""

from __future__ import annotations

import numpy as np

__all__ = ["linear_gradient_arc"]


def linear_gradient_arc(c0_mps: float, gradient_per_s: float, source_depth_m: float, receiver_depth_m: float,
                        range_m: float) -> tuple[float, float, float]:
    """Travel time and grazing angles of the one ray between two points in a linear gradient.

    Parameters
    ----------
    c0_mps : float
        c at the surface [m/s].
    gradient_per_s : float
        g = dc/dz [1/s], non-zero.
    source_depth_m, receiver_depth_m : float
        Depths [m], positive down.
    range_m : float
        Horizontal range [m], > 0.

    Returns
    -------
    travel_time_s, launch_rad, arrival_rad : float
        t = arccosh(1 + g² d² / (2 c_s c_r)) / |g| (d the chord), and the grazing angles of the arc's
        tangent at the source and at the receiver [rad], positive heading down.

    Examples
    --------
    >>> t, _, _ = linear_gradient_arc(1500.0, 1e-9, 10.0, 10.0, 1500.0)
    >>> round(t, 9)
    1.0
    """
    g, zs, zr, r = gradient_per_s, source_depth_m, receiver_depth_m, range_m
    cs, cr = c0_mps + g * zs, c0_mps + g * zr
    x = g * g * (r * r + (zr - zs) ** 2) / (2.0 * cs * cr)
    t = float(np.log1p(x + np.sqrt(x * (x + 2.0))) / abs(g))  # arccosh(1 + x), without cancelling when g → 0
    zc = -c0_mps / g
    xc = (r * r + (zr - zc) ** 2 - (zs - zc) ** 2) / (2.0 * r)

    def grazing(x, z):
        # the tangent is perpendicular to the radius; take the one heading towards +x
        vx, vz = z - zc, -(x - xc)
        return float(np.arctan2(-vz, -vx) if vx < 0 else np.arctan2(vz, vx))

    return t, grazing(0.0, zs), grazing(r, zr)
