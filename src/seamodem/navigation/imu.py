"""The vehicle's IMU/AHRS: what the heading sensor, the gyro and the accelerometer read.

One model for every simulation of the package: paper 000's Monte Carlo kernel
(:func:`~seamodem.navigation._kernels.mission_kernel`), its pure-Python
reference (:func:`~seamodem.navigation.missions.simulate_mission_reference`)
and the mission demo (:func:`seamodem.demo.simulate_vehicle`) all call
:func:`bias_step` and :func:`imu_reading`, the kernel from compiled code, the
others through :func:`simulate_imu` or directly.

At step k (t = k·Δt), with standard normals n in :data:`IMU_NOISE_COLUMNS` order:

- heading bias: b_k = b_{k−1} + σ_b n_b,k + ḃ Δt — a random walk whose σ after one
  hour is the datasheet's bias instability (σ_b = drift · √(Δt / 3600 s)), plus a
  constant drift rate ḃ (0 for the pure random walk);
- heading: ψ_k + b_k + σ_ψ n_ψ,k (paper 000 §3.5.3: 1° white noise, 5°/h bias);
- gyro: Ω + σ_Ω n_Ω,k, Ω the turn rate the vehicle made over the step ending at k;
- accelerometer: a + σ_a n_a,k, a = (v_k − v_{k−1}) / Δt the speed change the
  vehicle made (its speed limits included).

numba's cache does not see a change of this file from the kernels that call it
(``_kernels.mission_kernel``): after editing it, delete the ``*.nbi``/``*.nbc``
files under ``navigation/__pycache__``.

Examples
--------
>>> import numpy as np
>>> sigmas = imu_sigmas(sigma_heading_deg=1.0, heading_drift_deg_per_h=5.0, sigma_omega_rad_s=0.01,
...                     sigma_accel_mps2=0.01, dt_s=0.25)
>>> bool(np.isclose(sigmas[3] * np.sqrt(3600 / 0.25), np.radians(5.0)))  # the walk's σ after one hour
True
>>> noise = np.zeros((3, 4))
>>> readings, bias = simulate_imu(np.zeros(3), np.full(3, 0.1), np.zeros(3), noise, sigmas, dt_s=0.25,
...                               bias_rate_rad_s=0.01)
>>> bias.tolist(), readings["omega_rad_s"].tolist()
([0.0, 0.0025, 0.005], [0.1, 0.1, 0.1])
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import ConfigError

__all__ = ["IMU_NOISE_COLUMNS", "imu_sigmas", "bias_step", "imu_reading", "simulate_imu"]

#: Columns of the standard normals the IMU consumes, one row per step (the first four of a Monte Carlo
#: mission's noise array, :data:`~seamodem.navigation._kernels.NOISE_COLUMNS`).
IMU_NOISE_COLUMNS = ("heading", "omega", "accel", "heading_bias")


def imu_sigmas(*, sigma_heading_deg: float, heading_drift_deg_per_h: float, sigma_omega_rad_s: float,
               sigma_accel_mps2: float, dt_s: float, bias_random_walk: bool = True) -> np.ndarray:
    """Per-step standard deviations in :data:`IMU_NOISE_COLUMNS` order [rad, rad/s, m/s², rad].

    Parameters
    ----------
    sigma_heading_deg : float
        White heading noise [deg].
    heading_drift_deg_per_h : float
        Bias instability: the bias random walk's standard deviation after one hour [deg].
    sigma_omega_rad_s, sigma_accel_mps2 : float
        Gyro [rad/s] and accelerometer [m/s²] white noise.
    dt_s : float
        Step [s].
    bias_random_walk : bool
        False: no random walk (σ_b = 0; the bias then moves only at its drift rate).
    """
    return np.array([
        math.radians(sigma_heading_deg),
        sigma_omega_rad_s,
        sigma_accel_mps2,
        math.radians(heading_drift_deg_per_h) * math.sqrt(dt_s / 3600.0) if bias_random_walk else 0.0,
    ])


@njit(cache=True, nogil=True)
def bias_step(bias_rad, sigmas, noise, k, rate_rad_s, dt_s):
    """The heading bias at step ``k`` from the one at k − 1: b + σ_b n_b,k + ḃ Δt [rad].

    ``sigmas`` holds at least the four :data:`IMU_NOISE_COLUMNS` σ, ``noise`` (n, ≥ 4) the standard normals.
    """
    return bias_rad + (sigmas[3] * noise[k, 3] + rate_rad_s * dt_s)


@njit(cache=True, nogil=True)
def imu_reading(psi_rad, bias_rad, omega_rad_s, accel_mps2, sigmas, noise, k):
    """The readings at step ``k``: (heading [rad], gyro [rad/s], accelerometer [m/s²]).

    ``psi_rad`` is the true heading at step k, ``bias_rad`` the heading bias at step k,
    ``omega_rad_s`` and ``accel_mps2`` the true turn rate and speed change over the step ending at k.
    """
    return (psi_rad + bias_rad + sigmas[0] * noise[k, 0],
            omega_rad_s + sigmas[1] * noise[k, 1],
            accel_mps2 + sigmas[2] * noise[k, 2])


@njit(cache=True, nogil=True)
def _imu_series(psi, omega, accel, noise, sigmas, bias0, rate, dt, out):
    bias = bias0
    for k in range(psi.size):
        if k > 0:
            bias = bias_step(bias, sigmas, noise, k, rate, dt)
        out[k, 0], out[k, 1], out[k, 2] = imu_reading(psi[k], bias, omega[k], accel[k], sigmas, noise, k)
        out[k, 3] = bias


def simulate_imu(heading_rad, omega_rad_s, accel_mps2, noise, sigmas, *, dt_s: float,
                 bias_rate_rad_s: float = 0.0, bias0_rad: float = 0.0):
    """The readings of a whole run: steps 0 … n − 1 of :func:`bias_step` and :func:`imu_reading`.

    Parameters
    ----------
    heading_rad, omega_rad_s, accel_mps2 : array_like, shape (n,)
        True heading at each step, turn rate and speed change over the step ending there [rad, rad/s, m/s²].
    noise : numpy.ndarray, shape (n, ≥ 4)
        Standard normals, columns as :data:`IMU_NOISE_COLUMNS`.
    sigmas : numpy.ndarray, shape (≥ 4,)
        Per-step σ (:func:`imu_sigmas`).
    dt_s : float
        Step [s].
    bias_rate_rad_s : float
        Constant drift rate of the heading bias [rad/s].
    bias0_rad : float
        Heading bias at step 0 [rad] (the walk starts from it; step 0's bias normal is not used).

    Returns
    -------
    readings : dict of numpy.ndarray, shape (n,)
        ``heading_rad, omega_rad_s, accel_mps2``.
    bias_rad : numpy.ndarray, shape (n,)
        The true heading bias.
    """
    psi = np.ascontiguousarray(heading_rad, dtype=float)
    omega = np.ascontiguousarray(omega_rad_s, dtype=float)
    accel = np.ascontiguousarray(accel_mps2, dtype=float)
    noise = np.ascontiguousarray(noise, dtype=float)
    if not (psi.shape == omega.shape == accel.shape and psi.ndim == 1 and noise.ndim == 2
            and noise.shape[0] == psi.size and noise.shape[1] >= len(IMU_NOISE_COLUMNS)):
        raise ConfigError("noise", f"heading, omega, accel must be (n,) and noise (n, >= 4), got shapes "
                                   f"{psi.shape}, {omega.shape}, {accel.shape}, {noise.shape}")
    out = np.empty((psi.size, 4))
    _imu_series(psi, omega, accel, noise, np.asarray(sigmas, dtype=float), float(bias0_rad),
                float(bias_rate_rad_s), float(dt_s), out)
    readings = {"heading_rad": out[:, 0], "omega_rad_s": out[:, 1], "accel_mps2": out[:, 2]}
    return readings, out[:, 3]
