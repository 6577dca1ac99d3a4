"""Vehicle: feedback-linearization command (paper 000 eq 2) and unicycle model (eq 3–4).

Both functions are compiled with numba because the Monte Carlo kernel calls
them at every step; they are plain scalar functions and callable from Python.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["feedback_command", "vehicle_step"]


@njit(cache=True, nogil=True)
def feedback_command(x, y, psi, v, xd, yd, vxd, vyd, axd, ayd, v_min, omega_max, accel_max):
    """Turn rate Ω [rad/s] and acceleration a [m/s²] that track a desired path.

    Parameters
    ----------
    x, y, psi, v : float
        Vehicle state used for steering (true or estimated) [m, m, rad, m/s].
    xd, yd, vxd, vyd, axd, ayd : float
        Desired position, velocity and acceleration [m, m/s, m/s²].
    v_min : float
        Speed below which the command is computed as if v = v_min [m/s]: the
        matrix of eq 2 has determinant −v and is singular at rest.
    omega_max, accel_max : float
        Actuator limits: the command is clipped to |Ω| ≤ omega_max [rad/s] and
        |a| ≤ accel_max [m/s²] (eq 2 itself is unbounded).

    Returns
    -------
    omega, accel : float

    Notes
    -----
    Paper 000 eq 2: (Ω, a)ᵀ = M⁻¹ b with M = [[−v sin ψ, cos ψ], [v cos ψ, sin ψ]],
    b = e + 2 ė + ẍ_d (gains 1 and 2: a critically damped error at 1 rad/s).
    M⁻¹ b in closed form: a = b·(cos ψ, sin ψ), Ω = b·(−sin ψ, cos ψ) / v.
    """
    c, s = np.cos(psi), np.sin(psi)
    bx = (xd - x) + 2.0 * (vxd - v * c) + axd
    by = (yd - y) + 2.0 * (vyd - v * s) + ayd
    v_eff = max(v, v_min)
    omega = (-s * bx + c * by) / v_eff
    accel = c * bx + s * by
    return min(max(omega, -omega_max), omega_max), min(max(accel, -accel_max), accel_max)


@njit(cache=True, nogil=True)
def vehicle_step(x, y, psi, v, omega, accel, dt, v_min, v_max):
    """One Euler step of the unicycle, paper 000 eq 3–4, speed kept in [v_min, v_max] [m/s].

    Returns the new (x, y, ψ, v). The speed limit is paper 000 Table 2's |v| ≤ 3 m/s;
    the lower limit keeps the vehicle moving forward, as a survey AUV does.
    """
    x_new = x + v * np.cos(psi) * dt
    y_new = y + v * np.sin(psi) * dt
    psi_new = psi + omega * dt
    v_new = min(max(v + accel * dt, v_min), v_max)
    return x_new, y_new, psi_new, v_new
