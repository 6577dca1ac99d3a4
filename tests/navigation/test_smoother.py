"""RTS smoother: equal to the batch Gaussian posterior on a linear model, better than the filter, wired in."""

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.navigation.ekf import ExtendedKalmanFilter
from seamodem.navigation.montecarlo import (
    MissionConfig,
    held_fix_index,
    mission_noise,
    simulate_mission,
)
from seamodem.navigation.smoother import rts_smooth


class LinearModel:
    """x_{k+1} = F x_k, z = H x: the EKF on it is the Kalman filter."""

    kinds = {"z": None}

    def __init__(self, F, H):
        self.F, self.H = F, H

    def transition(self, x, u, dt):
        return self.F @ x

    def transition_jacobian(self, x, u, dt):
        return self.F

    def measure(self, x, kind):
        return self.H @ x

    def measurement_jacobian(self, x, kind):
        return self.H

    def angular(self, kind):
        return np.zeros(self.H.shape[0], dtype=bool)


def linear_problem(rng, n=3, m=1, steps=40):
    F = np.eye(n) + 0.2 * rng.normal(size=(n, n)) / n
    H = rng.normal(size=(m, n))
    Q = np.diag(rng.uniform(0.01, 0.1, n))
    R = np.diag(rng.uniform(0.2, 1.0, m))
    m0, P0 = rng.normal(size=n), np.diag(rng.uniform(0.5, 2.0, n))
    x = m0 + np.linalg.cholesky(P0) @ rng.normal(size=n)
    truth, zs = [x], []
    for _ in range(steps):
        x = F @ x + np.sqrt(np.diag(Q)) * rng.normal(size=n)
        truth.append(x)
        zs.append(H @ x + np.sqrt(np.diag(R)) * rng.normal(size=m))
    return F, H, Q, R, m0, P0, np.array(truth), np.array(zs)


def forward(F, H, Q, R, m0, P0, zs):
    """Run the package's EKF, recording what the smoother needs."""
    ekf = ExtendedKalmanFilter(LinearModel(F, H), m0, P0, Q)
    xp, Pp, xf, Pf, Fs = [m0], [P0], [m0], [P0], [np.eye(m0.size)]
    for k, z in enumerate(zs, start=1):
        ekf.predict(float(k))
        xp.append(ekf.state)
        Pp.append(ekf.covariance)
        Fs.append(ekf.F)
        ekf.update(z, "z", R)
        xf.append(ekf.state)
        Pf.append(ekf.covariance)
    return [np.array(a) for a in (xf, Pf, xp, Pp, Fs)]


def batch_posterior(F, H, Q, R, m0, P0, zs):
    """Mean and marginal covariances of p(x_0..N | z_1..N) from the stacked information matrix.

    Independent of any recursion: the negative log-posterior is quadratic, so the
    mean solves the normal equations and the covariance is the inverse information.
    """
    n, N = m0.size, len(zs) + 1
    Lam = np.zeros((n * N, n * N))
    eta = np.zeros(n * N)
    Pi, Qi, Ri = np.linalg.inv(P0), np.linalg.inv(Q), np.linalg.inv(R)
    Lam[:n, :n] += Pi
    eta[:n] += Pi @ m0
    for k in range(1, N):
        a, b = slice(n * (k - 1), n * k), slice(n * k, n * (k + 1))
        # (x_k − F x_{k−1})ᵀ Q⁻¹ (x_k − F x_{k−1})
        Lam[a, a] += F.T @ Qi @ F
        Lam[a, b] -= F.T @ Qi
        Lam[b, a] -= Qi @ F
        Lam[b, b] += Qi
        # (z_k − H x_k)ᵀ R⁻¹ (z_k − H x_k)
        Lam[b, b] += H.T @ Ri @ H
        eta[b] += H.T @ Ri @ zs[k - 1]
    cov = np.linalg.inv(Lam)
    mean = np.linalg.solve(Lam, eta).reshape(N, n)
    blocks = np.array([cov[n * k:n * (k + 1), n * k:n * (k + 1)] for k in range(N)])
    return mean, blocks


def test_rts_equals_batch_gaussian_posterior_on_linear_model():
    rng = np.random.default_rng(11)
    F, H, Q, R, m0, P0, _, zs = linear_problem(rng)
    xs, Ps = rts_smooth(*forward(F, H, Q, R, m0, P0, zs))
    mean, cov = batch_posterior(F, H, Q, R, m0, P0, zs)
    # Two exact computations of the same Gaussian posterior (a 123×123 inverse vs 40 backward
    # steps): they differ only by rounding, ≈ 1e-13 here.
    np.testing.assert_allclose(xs, mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(Ps, cov, rtol=0, atol=1e-10)


def test_rts_equals_textbook_recursion_and_last_step_is_filtered():
    rng = np.random.default_rng(12)
    F, H, Q, R, m0, P0, _, zs = linear_problem(rng, n=4, m=2, steps=30)
    xf, Pf, xp, Pp, Fs = forward(F, H, Q, R, m0, P0, zs)
    xs, Ps = rts_smooth(xf, Pf, xp, Pp, Fs)
    # Textbook form (Simon 2006 eq 9.103), with an explicit inverse.
    x, P = xf[-1], Pf[-1]
    for k in range(len(xf) - 2, -1, -1):
        C = Pf[k] @ F.T @ np.linalg.inv(Pp[k + 1])
        x = xf[k] + C @ (x - xp[k + 1])
        P = Pf[k] + C @ (P - Pp[k + 1]) @ C.T
        np.testing.assert_allclose(xs[k], x, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(Ps[k], P, rtol=1e-11, atol=1e-11)
    np.testing.assert_array_equal(xs[-1], xf[-1])


def test_smoother_beats_filter_and_is_consistent():
    rng = np.random.default_rng(13)
    F, H, Q, R, m0, P0, _, _ = linear_problem(rng, steps=0)
    se_f, se_s, nees_s = [], [], []
    for _ in range(200):
        # Same model, new truth and noise, drawn from the model itself.
        x = m0 + np.linalg.cholesky(P0) @ rng.normal(size=m0.size)
        truth, zs = [x], []
        for _ in range(40):
            x = F @ x + np.sqrt(np.diag(Q)) * rng.normal(size=x.size)
            truth.append(x)
            zs.append(H @ x + np.sqrt(np.diag(R)) * rng.normal(size=H.shape[0]))
        truth = np.array(truth)
        xf, Pf, xp, Pp, Fs = forward(F, H, Q, R, m0, P0, zs)
        xs, Ps = rts_smooth(xf, Pf, xp, Pp, Fs)
        se_f.append(np.sum((xf - truth) ** 2))
        se_s.append(np.sum((xs - truth) ** 2))
        e = xs[20] - truth[20]
        nees_s.append(e @ np.linalg.solve(Ps[20], e))
    # The smoother's covariance is smaller at every step but the last (it uses more data) ...
    assert np.all(np.trace(Ps[:-1], axis1=1, axis2=2) < np.trace(Pf[:-1], axis1=1, axis2=2))
    # ... and the realised squared error follows: clearly below the filter's over 200 runs.
    assert np.mean(se_s) < 0.9 * np.mean(se_f)
    # NEES at a middle step: mean of 200 χ²(3) values, 99 % band 3 ± 2.576·√(6/200).
    assert abs(np.mean(nees_s) - 3.0) < 2.576 * np.sqrt(6 / 200)


def test_rts_rejects_bad_shapes_and_nan():
    x = np.zeros((5, 2))
    P = np.broadcast_to(np.eye(2), (5, 2, 2)).copy()
    with pytest.raises(ConfigError, match="P_prior"):
        rts_smooth(x, P, x, P[:4], P)
    bad = x.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ConfigError, match="x_post"):
        rts_smooth(bad, P, x, P, P)


SHORT_PATH = {"lane_length_m": 40.0, "n_lanes": 2, "y0_m": 80.0}


def test_kernel_history_smoothing_and_held_fix():
    base = MissionConfig(tcom_s=3.0, steer_on_estimate=False, path=SHORT_PATH)
    reference, _ = base.reference()
    n = reference.shape[0] - 1
    noise = mission_noise(3, 0, n)
    err_f, est_f, truth = simulate_mission(base, noise, reference=reference)
    cfg_s = MissionConfig(tcom_s=3.0, steer_on_estimate=False, path=SHORT_PATH, error_of="smoothed")
    err_s, est_s, truth_s = simulate_mission(cfg_s, noise, reference=reference)
    np.testing.assert_array_equal(truth, truth_s)  # smoothing is post-processing: same mission
    np.testing.assert_array_equal(est_s[-1], est_f[-1])  # the last step has no future to use
    assert err_s.mean() < err_f.mean()
    cfg_h = MissionConfig(tcom_s=3.0, steer_on_estimate=False, path=SHORT_PATH, error_of="last_fix")
    err_h, est_h, _ = simulate_mission(cfg_h, noise, reference=reference)
    np.testing.assert_array_equal(held_fix_index(7, 3), [0, 0, 0, 3, 3, 3, 6, 6])
    k = np.arange(n + 1)
    np.testing.assert_array_equal(est_h, est_f[(k // 12) * 12])
    np.testing.assert_allclose(err_h, np.hypot(*(est_h - truth).T))


def test_mission_config_rejects_bad_q_and_error_of():
    with pytest.raises(ConfigError, match="error_of"):
        MissionConfig(error_of="smooth")
    with pytest.raises(ConfigError, match="q"):
        MissionConfig(q=(1e-4, 1e-4))
    with pytest.raises(ConfigError, match="q"):
        MissionConfig(q=-1.0)
    assert MissionConfig(q=(1, 2, 3, 4, 5, 6)).process_diag.tolist() == [1, 2, 3, 4, 5, 6]
