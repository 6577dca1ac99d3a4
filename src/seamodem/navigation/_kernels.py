"""Compiled mission loop of paper 000's simulation: vehicle, sensors and 6-state EKF.

One call runs one whole mission (≈ 6 200 steps); it is sequential by nature,
hence numba. The IMU/AHRS readings are :mod:`.imu`'s model (the demo's and the
reference's too). The pure-Python form of the same loop is
:func:`seamodem.navigation.missions.simulate_mission_reference`, built from
:class:`~seamodem.navigation.ekf.ExtendedKalmanFilter` and
:class:`~seamodem.navigation.models.Auv6Model`; the tests hold the two equal.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .imu import bias_step, imu_reading
from .vehicle import feedback_command, vehicle_step

#: Columns of the standard-normal noise array a mission consumes.
NOISE_COLUMNS = ("heading", "omega", "accel", "heading_bias", "range", "v_r")


@njit(cache=True, nogil=True)
def _predict6(z, P, F, A, dt, q):
    """z ← f(z) (eq 7), P ← F P Fᵀ + diag(q) (eq 21, 25), in place."""
    x, y, psi, v, om, a = z[0], z[1], z[2], z[3], z[4], z[5]
    c, s = np.cos(psi), np.sin(psi)
    for i in range(6):
        for j in range(6):
            F[i, j] = 1.0 if i == j else 0.0
    F[0, 2], F[0, 3] = -v * dt * s, dt * c
    F[1, 2], F[1, 3] = v * dt * c, dt * s
    F[2, 4] = dt
    F[3, 5] = dt
    z[0], z[1], z[2], z[3] = x + v * dt * c, y + v * dt * s, psi + dt * om, v + dt * a
    for i in range(6):
        for j in range(6):
            acc = 0.0
            for k in range(6):
                acc += F[i, k] * P[k, j]
            A[i, j] = acc
    for i in range(6):
        for j in range(i, 6):
            acc = 0.0
            for k in range(6):
                acc += A[i, k] * F[j, k]
            P[i, j] = acc
            P[j, i] = acc
        P[i, i] += q[i]


@njit(cache=True, nogil=True)
def _update_rows(z, P, innov, H, r, n_rows, ph):
    """Fuse ``n_rows`` scalar measurements with a diagonal R, one after the other.

    ``innov[i]`` is y_i − h_i(z⁻) and ``H[i]`` the gradient at the prior z⁻; the
    innovation of row i is corrected by −H_i (z − z⁻) for the rows already fused,
    which makes the sequence equal to the batch update of Algorithm 1 (paper 000)
    with R diagonal, without a matrix inverse.
    """
    z_prior = z.copy()
    for row in range(n_rows):
        nu = innov[row]
        for j in range(6):
            nu -= H[row, j] * (z[j] - z_prior[j])
        s = r[row]
        for i in range(6):
            acc = 0.0
            for j in range(6):
                acc += P[i, j] * H[row, j]
            ph[i] = acc
        for i in range(6):
            s += H[row, i] * ph[i]
        for i in range(6):
            z[i] += ph[i] / s * nu
        for i in range(6):
            for j in range(6):
                P[i, j] -= ph[i] * ph[j] / s


@njit(cache=True, nogil=True)
def _wrap(angle):
    return np.arctan2(np.sin(angle), np.cos(angle))


@njit(cache=True, nogil=True)
def mission_kernel(reference, noise, start, sigmas, r_diag, p0_diag, beacon, dt, q, com_every,
                   use_vr, steer_on_estimate, v_min, v_max, omega_max, accel_max, history, bias_rate=0.0):
    """Run one mission of paper 000's simulation; return the position error and both tracks.

    Parameters
    ----------
    reference : ndarray, shape (n + 1, 6)
        Desired x, y, ẋ, ẏ, ẍ, ÿ at t = k·dt [m, m/s, m/s²].
    noise : ndarray, shape (n + 1, 6)
        Standard normals, columns as :data:`NOISE_COLUMNS`.
    start : ndarray, shape (4,)
        True initial (x, y, ψ, v); the filter starts there too (GNSS fix before diving).
    sigmas : ndarray, shape (6,)
        Standard deviations of the noise columns: heading [rad], gyro [rad/s],
        accelerometer [m/s²], heading-bias random-walk step [rad], range [m], v_r [m/s].
    r_diag : ndarray, shape (5,)
        Filter R for (d, v_r, ψ, Ω, a) (eq 25 reordered to eq 18's order).
    p0_diag : ndarray, shape (6,)
        Initial covariance diagonal.
    beacon : ndarray, shape (2,)
    dt : float
        Step [s].
    q : ndarray, shape (6,)
        Process noise variance of each state per step (eq 25: Δt⁸ for all).
    com_every : int
        A frame arrives every ``com_every`` steps (T_com / dt).
    use_vr : bool
        True: the proposed filter; False: ROSB (range without v_r).
    steer_on_estimate : bool
        Steer the controller (eq 2) on the filter's estimate (a real vehicle) or on the truth.
    v_min, v_max : float
        Speed limits of the vehicle [m/s].
    omega_max, accel_max : float
        Actuator limits of the controller [rad/s, m/s²].
    history : ndarray, shape (n + 1, 6, 20) or (0, 6, 20)
        When not empty, filled with what a Rauch–Tung–Striebel smoother needs:
        ``history[k, :, 0]`` prior state at step k, ``[:, 1]`` posterior state,
        ``[:, 2:8]`` prior covariance, ``[:, 8:14]`` posterior covariance,
        ``[:, 14:20]`` the transition Jacobian F from step k − 1 to k
        (row i of each matrix in ``history[k, i]``). Step 0 has prior = posterior, F = I.
    bias_rate : float
        Heading-bias drift rate [rad/s] added to the random walk (``NoiseModel(heading_bias_model="drift")``);
        0 leaves every number of the paper's reproduction as it was (x + 0.0 = x).

    Returns
    -------
    error : ndarray, shape (n + 1,)
        Horizontal position error [m].
    estimate, truth : ndarray, shape (n + 1, 2)
    """
    n = reference.shape[0] - 1
    error = np.empty(n + 1)
    estimate = np.empty((n + 1, 2))
    truth = np.empty((n + 1, 2))
    F = np.empty((6, 6))
    A = np.empty((6, 6))
    H = np.zeros((5, 6))
    innov = np.empty(5)
    r = np.empty(5)
    ph = np.empty(6)
    x, y, psi, v = start[0], start[1], start[2], start[3]
    z = np.array([x, y, psi, v, 0.0, 0.0])
    P = np.diag(p0_diag.copy())
    bias = 0.0
    record = history.shape[0] > 0
    if record:
        for i in range(6):
            history[0, i, 0] = history[0, i, 1] = z[i]
            for j in range(6):
                history[0, i, 2 + j] = history[0, i, 8 + j] = P[i, j]
                history[0, i, 14 + j] = 1.0 if i == j else 0.0
    estimate[0, 0], estimate[0, 1] = z[0], z[1]
    truth[0, 0], truth[0, 1] = x, y
    error[0] = 0.0
    sx, sy, spsi, sv = (z[0], z[1], z[2], z[3]) if steer_on_estimate else (x, y, psi, v)
    omega, accel = feedback_command(sx, sy, spsi, sv, reference[0, 0], reference[0, 1], reference[0, 2],
                                    reference[0, 3], reference[0, 4], reference[0, 5], v_min,
                                    omega_max, accel_max)
    for k in range(1, n + 1):
        v_old = v
        x, y, psi, v = vehicle_step(x, y, psi, v, omega, accel, dt, v_min, v_max)
        accel_true = (v - v_old) / dt  # what the accelerometer feels, speed limits included
        _predict6(z, P, F, A, dt, q)
        if record:
            for i in range(6):
                history[k, i, 0] = z[i]
                for j in range(6):
                    history[k, i, 2 + j] = P[i, j]
                    history[k, i, 14 + j] = F[i, j]
        bias = bias_step(bias, sigmas, noise, k, bias_rate, dt)
        heading_m, omega_m, accel_m = imu_reading(psi, bias, omega, accel_true, sigmas, noise, k)
        rows = 0
        for i in range(5):
            for j in range(6):
                H[i, j] = 0.0
        if k % com_every == 0:
            dx, dy = z[0] - beacon[0], z[1] - beacon[1]
            d_hat = np.sqrt(dx * dx + dy * dy)
            d_true = np.sqrt((x - beacon[0]) ** 2 + (y - beacon[1]) ** 2)
            innov[0] = d_true + sigmas[4] * noise[k, 4] - d_hat
            H[0, 0], H[0, 1] = dx / d_hat, dy / d_hat
            r[0] = r_diag[0]
            rows = 1
            if use_vr:
                c_hat = np.arctan2(dy, dx) - z[2]
                vr_true = -v * np.cos(np.arctan2(y - beacon[1], x - beacon[0]) - psi)
                innov[1] = vr_true + sigmas[5] * noise[k, 5] + z[3] * np.cos(c_hat)
                b = z[3] * np.sin(c_hat) / (d_hat * d_hat)
                H[1, 0], H[1, 1], H[1, 2], H[1, 3] = -b * dy, b * dx, -z[3] * np.sin(c_hat), -np.cos(c_hat)
                r[1] = r_diag[1]
                rows = 2
        innov[rows] = _wrap(heading_m - z[2])
        innov[rows + 1] = omega_m - z[4]
        innov[rows + 2] = accel_m - z[5]
        H[rows, 2] = H[rows + 1, 4] = H[rows + 2, 5] = 1.0  # ψ, Ω, a are states: unit rows (eq 24)
        for i in range(3):
            r[rows + i] = r_diag[2 + i]
        _update_rows(z, P, innov, H, r, rows + 3, ph)
        if record:
            for i in range(6):
                history[k, i, 1] = z[i]
                for j in range(6):
                    history[k, i, 8 + j] = P[i, j]
        estimate[k, 0], estimate[k, 1] = z[0], z[1]
        truth[k, 0], truth[k, 1] = x, y
        error[k] = np.sqrt((z[0] - x) ** 2 + (z[1] - y) ** 2)
        sx, sy, spsi, sv = (z[0], z[1], z[2], z[3]) if steer_on_estimate else (x, y, psi, v)
        omega, accel = feedback_command(sx, sy, spsi, sv, reference[k, 0], reference[k, 1], reference[k, 2],
                                        reference[k, 3], reference[k, 4], reference[k, 5], v_min,
                                        omega_max, accel_max)
    return error, estimate, truth
