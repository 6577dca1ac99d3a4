"""The one IMU/AHRS model (navigation/imu.py): closed forms, its statistics, and its users.

The Monte Carlo kernel, its pure-Python reference and the demo all read the
IMU through this module; ``test_montecarlo.py`` holds kernel = reference and
``test_paper_tables.py`` holds the paper tables to the digits they had before.
"""

import math

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.navigation.imu import bias_step, imu_reading, imu_sigmas, simulate_imu
from seamodem.navigation.montecarlo import NoiseModel


def _sigmas(dt_s=0.25, **kw):
    base = dict(sigma_heading_deg=1.0, heading_drift_deg_per_h=5.0, sigma_omega_rad_s=0.02,
                sigma_accel_mps2=0.03, dt_s=dt_s)
    return imu_sigmas(**{**base, **kw})


def test_readings_are_truth_plus_scaled_normals():
    """Each reading, written out by hand: ψ + b + σ_ψ n, Ω + σ_Ω n, a + σ_a n; b walks from b0."""
    rng = np.random.default_rng(3)
    n = 50
    psi, omega, accel = rng.uniform(-3, 3, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)
    noise = rng.standard_normal((n, 6))  # a mission's array: the IMU reads its first four columns
    s = _sigmas()
    readings, bias = simulate_imu(psi, omega, accel, noise, s, dt_s=0.25, bias0_rad=0.01)
    b = np.empty(n)
    b[0] = 0.01
    for k in range(1, n):
        b[k] = b[k - 1] + s[3] * noise[k, 3]
    # same operations in the same order: equal to the last bit
    np.testing.assert_array_equal(bias, b)
    np.testing.assert_array_equal(readings["heading_rad"], psi + b + s[0] * noise[:, 0])
    np.testing.assert_array_equal(readings["omega_rad_s"], omega + s[1] * noise[:, 1])
    np.testing.assert_array_equal(readings["accel_mps2"], accel + s[2] * noise[:, 2])
    # the per-step functions the kernel calls give the same numbers when called from Python
    assert bias_step(b[4], s, noise, 5, 0.0, 0.25) == b[5]
    assert imu_reading(psi[5], b[5], omega[5], accel[5], s, noise, 5) == (
        readings["heading_rad"][5], readings["omega_rad_s"][5], readings["accel_mps2"][5])


def test_bias_random_walk_sigma_after_one_hour_is_the_instability():
    """Bias instability 5°/h: the walk's standard deviation after 3600 s is 5°, at any step size."""
    runs, dt = 4000, 60.0
    n = int(3600 / dt) + 1
    s = _sigmas(dt_s=dt)
    rng = np.random.default_rng(11)
    end = np.array([simulate_imu(np.zeros(n), np.zeros(n), np.zeros(n), rng.standard_normal((n, 4)), s,
                                 dt_s=dt)[1][-1] for _ in range(runs)])
    # 4000 runs: the sample σ is within 1.1 % (1 σ) of the truth; 5 % is 4.5 σ
    assert np.std(end) == pytest.approx(math.radians(5.0), rel=0.05)
    assert abs(np.mean(end)) < 4 * math.radians(5.0) / math.sqrt(runs)


def test_drift_rate_without_random_walk_is_a_straight_line():
    n, dt, rate = 400, 0.25, math.radians(5.0) / 3600.0
    s = _sigmas(bias_random_walk=False)
    assert s[3] == 0.0
    _, bias = simulate_imu(np.zeros(n), np.zeros(n), np.zeros(n), np.ones((n, 4)), s, dt_s=dt,
                           bias_rate_rad_s=rate, bias0_rad=0.002)
    # closed form b0 + ḃ·t, up to the rounding of n sums
    np.testing.assert_allclose(bias, 0.002 + rate * dt * np.arange(n), rtol=1e-12, atol=1e-15)


def test_noise_model_sigmas_are_the_imu_model_plus_range_and_vr():
    noise = NoiseModel(sigma_heading_deg=2.0, heading_drift_deg_per_h=7.0, sigma_range_m=0.5, sigma_vr_mps=0.1)
    s = noise.sigmas(0.5)
    np.testing.assert_array_equal(s[:4], imu_sigmas(sigma_heading_deg=2.0, heading_drift_deg_per_h=7.0,
                                                    sigma_omega_rad_s=noise.sigma_omega_rad_s,
                                                    sigma_accel_mps2=noise.sigma_accel_mps2, dt_s=0.5))
    assert s[4:].tolist() == [0.5, 0.1]
    assert NoiseModel(heading_bias_model="drift").sigmas(0.5)[3] == 0.0


def test_demo_vehicle_imu_reads_the_true_motion():
    """Noise-free, the demo's gyro and accelerometer read the turn and speed change of the true track.

    Independent of the model's code: the heading and speed the vehicle actually had, differenced.
    """
    from seamodem.demo import DemoConfig, simulate_vehicle

    cfg = DemoConfig(sigma_heading_deg=0.0, heading_drift_deg_per_h=0.0, sigma_omega_rad_s=0.0,
                     sigma_accel_mps2=0.0)
    run = simulate_vehicle(cfg, t_end_s=60.0, rng=np.random.default_rng(0))
    imu = run.imu
    np.testing.assert_array_equal(imu["heading_rad"], run.heading_rad)
    # Euler step ψ_k = ψ_{k−1} + Ω Δt: the difference gives Ω back to rounding (|ψ| < 10 rad: 1e-12)
    np.testing.assert_allclose(imu["omega_rad_s"][1:], np.diff(run.heading_rad) / cfg.dt_s, atol=1e-12)
    np.testing.assert_allclose(imu["accel_mps2"][1:], np.diff(run.speed_mps) / cfg.dt_s, atol=1e-12)
    assert imu["omega_rad_s"][0] == imu["accel_mps2"][0] == 0.0


def test_demo_vehicle_imu_noise_has_the_configured_sigma():
    from seamodem.demo import DemoConfig, simulate_vehicle

    cfg = DemoConfig()
    run = simulate_vehicle(cfg, t_end_s=2000.0, rng=np.random.default_rng(2))
    gyro_err = run.imu["omega_rad_s"][1:] - np.diff(run.heading_rad) / cfg.dt_s
    accel_err = run.imu["accel_mps2"][1:] - np.diff(run.speed_mps) / cfg.dt_s
    # 8000 samples: the sample σ is within 0.8 % (1 σ); 4 % is 5 σ
    assert np.std(gyro_err) == pytest.approx(cfg.sigma_omega_rad_s, rel=0.04)
    assert np.std(accel_err) == pytest.approx(cfg.sigma_accel_mps2, rel=0.04)


def test_bad_shapes_are_a_config_error():
    with pytest.raises(ConfigError, match="noise"):
        simulate_imu(np.zeros(5), np.zeros(5), np.zeros(5), np.zeros((5, 3)), _sigmas(), dt_s=0.25)
    with pytest.raises(ConfigError, match="noise"):
        simulate_imu(np.zeros(5), np.zeros(4), np.zeros(5), np.zeros((5, 4)), _sigmas(), dt_s=0.25)
