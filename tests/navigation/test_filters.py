"""The other estimators: paper 003 (3-state), paper 002 (4-state), paper 004 (anchors, LLS), paper 001 (PF)."""

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.navigation.ekf import ExtendedKalmanFilter
from seamodem.navigation.models import Auv3Model, Auv4Model, ConstantVelocityModel, closing_speed
from seamodem.navigation.multilateration import lls_position, track_anchor_ranges
from seamodem.navigation.particle import ParticleFilter, systematic_resample
from seamodem.navigation.trajectories import Lemniscate


def run_paper003(kind, seed):
    """Lemniscate of paper 003 (a = 0.6 m, dt = 0.2 s, 60 steps, beacon (0.7, 0)) with noisy d and v."""
    rng = np.random.default_rng(seed)
    dt, beacon = 0.2, (0.7, 0.0)
    t = np.arange(61) * dt
    path = Lemniscate(a_m=0.6, omega_rad_s=1.0).sample(t)
    heading = np.arctan2(path.velocity[:, 1], path.velocity[:, 0])
    speed = np.hypot(*path.velocity.T)
    model = Auv3Model(beacon)
    R = {"both": [0.02**2, 0.02**2], "range": [0.02**2], "speed": [0.02**2]}[kind]
    ekf = ExtendedKalmanFilter(model, [path.position[0, 0], path.position[0, 1], speed[0]], np.eye(3) * 1e-4,
                               np.diag([1e-4, 1e-4, 1e-2]))
    errors = []
    for k in range(1, t.size):
        ekf.predict(t[k], [heading[k - 1]])
        d = np.hypot(*(path.position[k] - beacon)) + 0.02 * rng.normal()
        v = speed[k] + 0.02 * rng.normal()
        z = {"both": [d, v], "range": [d], "speed": [v]}[kind]
        ekf.update(z, kind, R)
        errors.append(np.hypot(*(ekf.x[:2] - path.position[k])))
    return np.mean(errors)


def test_paper003_range_and_speed_beats_speed_only():
    """Paper 003 §IV-B: combining range and speed bounds the error; speed only drifts (heading-driven Euler)."""
    both = np.mean([run_paper003("both", s) for s in range(10)])
    speed = np.mean([run_paper003("speed", s) for s in range(10)])
    range_only = np.mean([run_paper003("range", s) for s in range(10)])
    assert np.isfinite(range_only)
    assert both < speed


def test_paper002_vr_makes_speed_observable():
    """Straight leg, speed initialised 0.5 m/s wrong, position ±5 m: one frame's v_r fixes the speed, a range cannot."""
    model = Auv4Model((0.0, 50.0))
    dt, heading, v_true = 1.0, 0.0, 1.5
    results = {}
    for kind in ("com", "rosb"):
        ekf = ExtendedKalmanFilter(model, [-100.0, 0.0, heading, v_true - 0.5], np.diag([25.0, 25.0, 0.01, 1.0]),
                                   np.diag([1e-4, 1e-4, 1e-6, 1e-6]))
        for k in range(1, 4):  # one frame, at k = 3
            ekf.predict(k * dt)
            x = -100.0 + v_true * k * dt
            if k % 3 == 0:
                d = np.hypot(x, 50.0)
                vr = float(closing_speed(x, 0.0, heading, v_true, (0.0, 50.0)))
                z = [d, heading, vr] if kind == "com" else [d, heading]
                ekf.update(z, kind, [0.01, 1e-4, 1e-4][: len(z)])
            else:
                ekf.update([heading], "heading", 1e-4)
        results[kind] = abs(ekf.x[3] - v_true)
    # Noise-free: one v_r removes > 90 % of the 0.5 m/s error; one range mixes it with the position error.
    assert results["com"] < 0.05
    assert results["com"] < 0.5 * results["rosb"], results


def test_lls_exact_without_noise_and_rejects_short_cycles():
    anchors = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 80.0], [90.0, 90.0]])
    p = np.array([37.0, 21.0])
    ranges = np.hypot(*(anchors - p).T)
    np.testing.assert_allclose(lls_position(anchors, ranges), p, atol=1e-9)  # exact algebra, rounding only
    ranges[[1, 3]] = np.nan
    assert np.all(np.isnan(lls_position(anchors, ranges)))  # 2 of 4 packets lost: cycle rejected
    with pytest.raises(ConfigError, match="anchors_xy"):
        lls_position(anchors, ranges[:2])


def test_sequential_ekf_beats_lls_on_moving_vehicle_with_losses():
    """Paper 004 §V: the LLS ignores that ranges of one cycle are taken at different times; the EKF does not."""
    rng = np.random.default_rng(4)
    anchors = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0], [100.0, 100.0]])
    velocity = np.array([0.8, 0.5])
    start = np.array([20.0, 10.0])
    spacing, n_cycles, sigma = 1.0, 40, 0.3
    t = np.arange(4 * n_cycles) * spacing
    index = np.arange(t.size) % 4
    truth = start + t[:, None] * velocity
    ranges = np.hypot(*(truth - anchors[index]).T) + sigma * rng.normal(size=t.size)
    ranges[rng.random(t.size) < 0.15] = np.nan  # 15 % packet loss
    states, covs = track_anchor_ranges(anchors, t, index, ranges, x0=[*start, 0.0, 0.0],
                                       P0=np.diag([4.0, 4.0, 1.0, 1.0]), range_std_m=sigma)
    ekf_err = np.hypot(*(states[:, :2] - truth).T)[20:]
    lls_err = []
    for c in range(n_cycles):
        sel = slice(4 * c, 4 * c + 4)
        p = lls_position(anchors[index[sel]], ranges[sel])
        if np.all(np.isfinite(p)):
            lls_err.append(np.hypot(*(p - truth[4 * c + 3])))  # position reported at the cycle's end
    assert np.median(ekf_err) < np.median(lls_err)
    assert covs.shape == (t.size, 4, 4)


def test_particle_filter_matches_gaussian_posterior():
    """Static scalar state, prior N(0, 1), one measurement z = 1 with R = 1: posterior N(0.5, 0.5)."""

    class Scalar:
        def transition(self, x, u, dt):
            return x

        def measure(self, x, kind):
            return np.atleast_1d(x[0])

        def angular(self, kind):
            return np.zeros(1, dtype=bool)

    rng = np.random.default_rng(5)
    n = 20000
    pf = ParticleFilter(Scalar(), rng.normal(size=(n, 1)), [0.0], rng=rng, threshold=0.1)
    pf.update([1.0], "z", 1.0)
    # Monte Carlo error of a weighted mean with N_eff ≈ 0.7 N: std ≈ √(0.5/14000) = 0.006; 5σ margin.
    assert pf.x[0] == pytest.approx(0.5, abs=0.03)
    assert pf.P[0, 0] == pytest.approx(0.5, abs=0.03)
    assert pf.resample_count == 0 and pf.n_eff > 0.5 * n


def test_particle_filter_tracks_range_and_speed_and_resamples():
    rng = np.random.default_rng(6)
    beacon = (0.7, 0.0)
    model = Auv3Model(beacon)
    dt = 0.2
    t = np.arange(61) * dt
    path = Lemniscate().sample(t)
    heading = np.arctan2(path.velocity[:, 1], path.velocity[:, 0])
    speed = np.hypot(*path.velocity.T)
    init = np.c_[path.position[0] + rng.uniform(-0.1, 0.1, (500, 2)), speed[0] + rng.uniform(-0.1, 0.1, 500)]
    pf = ParticleFilter(model, init, [0.005, 0.005, 0.02], rng=rng, threshold=0.5)
    errors = []
    for k in range(1, t.size):
        pf.predict(t[k], [heading[k - 1]])
        z = [np.hypot(*(path.position[k] - beacon)) + 0.02 * rng.normal(), speed[k] + 0.02 * rng.normal()]
        pf.update(z, "both", [0.02**2, 0.02**2])
        errors.append(np.hypot(*(pf.x[:2] - path.position[k])))
    # The figure spans 1.2 m; 0.1 m mean error is what the EKF of paper 003 reaches in the pool.
    assert np.mean(errors) < 0.1
    assert pf.resample_count > 0


def test_systematic_resample_counts():
    w = np.array([0.5, 0.25, 0.25, 0.0])
    idx = systematic_resample(w, np.random.default_rng(0))
    # Systematic resampling gives each particle floor or ceil of N·w copies.
    np.testing.assert_array_equal(np.bincount(idx, minlength=4), [2, 1, 1, 0])


def test_constant_velocity_process_noise_is_white_acceleration():
    Q = ConstantVelocityModel([[0, 0]], accel_psd=2.0).process_noise(3.0)
    assert Q[0, 0] == pytest.approx(2.0 * 27 / 3) and Q[0, 2] == pytest.approx(2.0 * 9 / 2) and Q[2, 2] == 6.0
