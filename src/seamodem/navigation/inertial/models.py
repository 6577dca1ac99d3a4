"""The inertial filter's models: the motion (prediction) and the acoustic measurement, with their Jacobians.

State layout: (x, y, ψ, v, b) always, then ḃ, (c_x, c_y), s when enabled
(:attr:`~seamodem.navigation.inertial.config.InertialConfig.layout`), the
position in either chart (:mod:`.charts`). The gyro and the accelerometer are
inputs of the motion model; the process noise is their density times the step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .charts import choose_chart, wrap

__all__ = ["motion", "propagate_cov", "process_polar", "predict", "acoustic_model", "innovation_cov"]


@njit(cache=True, nogil=True)
def motion(z, lay, omega, accel, dt, z_out, F):
    """z_out = f(z) over dt with the IMU rates; F = ∂f/∂z (identity plus the couplings).

    Parameters
    ----------
    z : ndarray, shape (n,)
        State in the chart ``lay[4]``.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    omega : float
        Gyro rate over the step [rad/s].
    accel : float
        Acceleration over the step [m/s²].
    dt : float
        Step [s].
    z_out : ndarray, shape (n,)
        Output: the moved state (same chart; β kept continuous).
    F : ndarray, shape (n, n)
        Output: the Jacobian ∂f/∂z.

    Returns
    -------
    None
    """
    n = z.shape[0]
    x, y, psi, v = z[0], z[1], z[2], z[3]
    c, s = np.cos(psi), np.sin(psi)
    cx = z[lay[1]] if lay[1] >= 0 else 0.0
    cy = z[lay[1] + 1] if lay[1] >= 0 else 0.0
    for i in range(n):
        z_out[i] = z[i]
        for j in range(n):
            F[i, j] = 1.0 if i == j else 0.0
    z_out[2] = psi + omega * dt
    z_out[3] = v + accel * dt
    if lay[0] >= 0:
        z_out[4] = z[4] + z[lay[0]] * dt
        F[4, lay[0]] = dt
    if lay[4] == 0:
        z_out[0] = x + (v * c + cx) * dt
        z_out[1] = y + (v * s + cy) * dt
        F[0, 2], F[0, 3] = -v * dt * s, dt * c
        F[1, 2], F[1, 3] = v * dt * c, dt * s
        if lay[1] >= 0:
            F[0, lay[1]] = dt
            F[1, lay[1] + 1] = dt
        return
    # polar about the beacon: (ρ, β) = (x, y); move in Cartesian, back to polar (β kept continuous).
    # F = ∂(ρ', β')/∂p' · (∂p/∂(ρ, β) | ∂p'/∂(ψ, v, c))
    rho, beta = x, y
    cb, sb = np.cos(beta), np.sin(beta)
    px = rho * cb + (v * c + cx) * dt
    py = rho * sb + (v * s + cy) * dt
    rho2 = max(np.sqrt(px * px + py * py), 1e-9)
    z_out[0] = rho2
    z_out[1] = beta + wrap(np.arctan2(py, px) - beta)
    ux, uy = px / rho2, py / rho2
    tx, ty = -uy / rho2, ux / rho2
    F[0, 0], F[0, 1] = ux * cb + uy * sb, rho * (-ux * sb + uy * cb)
    F[1, 0], F[1, 1] = tx * cb + ty * sb, rho * (-tx * sb + ty * cb)
    F[0, 2], F[1, 2] = (-ux * s + uy * c) * v * dt, (-tx * s + ty * c) * v * dt
    F[0, 3], F[1, 3] = (ux * c + uy * s) * dt, (tx * c + ty * s) * dt
    if lay[1] >= 0:
        F[0, lay[1]], F[0, lay[1] + 1] = ux * dt, uy * dt
        F[1, lay[1]], F[1, lay[1] + 1] = tx * dt, ty * dt


@njit(cache=True, nogil=True)
def propagate_cov(P, F, qd, dt, A, P_out):
    """P_out = F P Fᵀ + diag(qd)·dt.

    Parameters
    ----------
    P, F : ndarray, shape (n, n)
        Covariance and step Jacobian.
    qd : ndarray, shape (n,)
        Process noise density [state unit²/s].
    dt : float
        Step [s].
    A : ndarray, shape (n, n)
        Scratch (F P).
    P_out : ndarray, shape (n, n)
        Output covariance.

    Returns
    -------
    None
    """
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += F[i, k] * P[k, j]
            A[i, j] = acc
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for k in range(n):
                acc += A[i, k] * F[j, k]
            P_out[i, j] = acc
            P_out[j, i] = acc
        P_out[i, i] += qd[i] * dt


@njit(cache=True, nogil=True)
def process_polar(P, z, lay, qd, dt):
    """The position random walk of ``qd[0:2]`` [m²/s] in polar states: β's share is divided by ρ².

    Parameters
    ----------
    P : ndarray, shape (n, n)
        Predicted covariance, corrected in place when ``lay[4]`` is polar.
    z : ndarray, shape (n,)
        Predicted state (ρ [m] first).
    lay : ndarray, shape (5,), int64
        State layout and chart.
    qd : ndarray, shape (n,)
        Process noise density [state unit²/s].
    dt : float
        Step [s].

    Returns
    -------
    None
    """
    if lay[4] != 0:
        P[1, 1] += qd[1] * dt * (1.0 / max(z[0] * z[0], 1e-12) - 1.0)


@njit(cache=True, nogil=True)
def predict(z, P, lay, model, omega, accel, dt, ws):
    """One prediction step in place: z ← f(z), P ← F P Fᵀ + Q; ``ws.F`` is left as the step's Jacobian.

    Then the chart for the new node is chosen (``lay[4]``; F then maps the old chart to the new one).

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, moved in place.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    model : FilterModel
        Process noise density and beacon.
    omega, accel : float
        IMU rates over the step [rad/s, m/s²].
    dt : float
        Step [s].
    ws : Workspace
        Scratch arrays (``zp``, ``F``, ``A``, ``Pp``).

    Returns
    -------
    None
    """
    motion(z, lay, omega, accel, dt, ws.zp, ws.F)
    propagate_cov(P, ws.F, model.qd, dt, ws.A, ws.Pp)
    process_polar(ws.Pp, ws.zp, lay, model.qd, dt)
    z[:] = ws.zp
    P[:, :] = ws.Pp
    choose_chart(z, P, lay, model.beacon, ws.F)


@njit(cache=True, nogil=True)
def acoustic_model(z, lay, beacon, use_range, use_vr, h, H):
    """Predicted (range, v_r) rows and their Jacobian at z.

    Parameters
    ----------
    z : ndarray, shape (n,)
        State in the chart ``lay[4]``.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    use_range, use_vr : bool
        Which rows (range first).
    h : ndarray, shape (≥ 2,)
        Output: predicted range [m] and/or v_r [m/s].
    H : ndarray, shape (2, n)
        Output: their Jacobian (rows 0 … rows − 1; both rows zeroed first).

    Returns
    -------
    int
        The number of rows.
    """
    n = z.shape[0]
    if lay[4] == 0:
        dx, dy = z[0] - beacon[0], z[1] - beacon[1]
        r = np.sqrt(dx * dx + dy * dy)
        r = max(r, 1e-6)
        ux, uy = dx / r, dy / r
    else:
        r = z[0]
        ux, uy = np.cos(z[1]), np.sin(z[1])
    psi, v = z[2], z[3]
    c, s = np.cos(psi), np.sin(psi)
    cx = z[lay[1]] if lay[1] >= 0 else 0.0
    cy = z[lay[1] + 1] if lay[1] >= 0 else 0.0
    k = 1.0 + (z[lay[2]] if lay[2] >= 0 else 0.0)
    rows = 0
    for i in range(2):
        for j in range(n):
            H[i, j] = 0.0
    if use_range:
        h[rows] = k * r
        if lay[4] == 0:
            H[rows, 0], H[rows, 1] = k * ux, k * uy
        else:
            H[rows, 0] = k
        if lay[2] >= 0:
            H[rows, lay[2]] = r
        rows += 1
    if use_vr:
        gx, gy = v * c + cx, v * s + cy
        ug = ux * gx + uy * gy
        h[rows] = -k * ug
        if lay[4] == 0:
            H[rows, 0] = -k * (gx - ug * ux) / r
            H[rows, 1] = -k * (gy - ug * uy) / r
        else:
            H[rows, 1] = -k * (uy * -gx + ux * gy)  # ∂(−k u·g)/∂β, ∂u/∂β = (−sin β, cos β)
        H[rows, 2] = -k * (-ux * v * s + uy * v * c)
        H[rows, 3] = -k * (ux * c + uy * s)
        if lay[1] >= 0:
            H[rows, lay[1]] = -k * ux
            H[rows, lay[1] + 1] = -k * uy
        if lay[2] >= 0:
            H[rows, lay[2]] = -ug
        rows += 1
    return rows


@njit(cache=True, nogil=True)
def innovation_cov(P, Hw, rows, var0, var1, PHt0, PHt1):
    """PHᵀ into (PHt0, PHt1) and S = H P Hᵀ + R as (s00, s01, s11) for ``rows`` (1 or 2) measurement rows.

    Parameters
    ----------
    P : ndarray, shape (n, n)
        Covariance.
    Hw : ndarray, shape (2, n)
        Jacobian of the rows.
    rows : int
        1 or 2.
    var0, var1 : float
        Variances of the rows (R diagonal).
    PHt0, PHt1 : ndarray, shape (n,)
        Output: P Hᵀ, one column per row (PHt1 zero with one row).

    Returns
    -------
    s00, s01, s11 : float
        The innovation covariance S.
    """
    n = P.shape[0]
    for i in range(n):
        a0 = 0.0
        a1 = 0.0
        for j in range(n):
            a0 += P[i, j] * Hw[0, j]
            if rows > 1:
                a1 += P[i, j] * Hw[1, j]
        PHt0[i] = a0
        PHt1[i] = a1
    s00, s01, s11 = var0, 0.0, var1
    for j in range(n):
        s00 += Hw[0, j] * PHt0[j]
        if rows > 1:
            s01 += Hw[0, j] * PHt1[j]
            s11 += Hw[1, j] * PHt1[j]
    return s00, s01, s11
