"""EKF and models: Jacobians against numerical derivatives, the textbook Kalman filter, NEES."""

import numpy as np
import pytest
from scipy import stats

from seamodem.errors import ConfigError
from seamodem.navigation.ekf import ExtendedKalmanFilter, kalman_update, nees
from seamodem.navigation.models import Auv3Model, Auv4Model, Auv6Model, ConstantVelocityModel

BEACON = (50.0, 100.0)


def numerical_jacobian(fun, x, h=1e-6):
    """Central differences; truncation error O(h²) ≈ 1e-12, rounding ≈ eps/h ≈ 1e-10."""
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        step = np.zeros_like(x)
        step[i] = h
        cols.append((np.atleast_1d(fun(x + step)) - np.atleast_1d(fun(x - step))) / (2 * h))
    return np.stack(cols, axis=1)


MODELS = [
    (Auv6Model(BEACON), lambda rng: np.r_[rng.uniform(0, 100, 2), rng.uniform(-3, 3), rng.uniform(0.5, 2), rng.normal(0, 0.1, 2)], None),
    (Auv4Model(BEACON), lambda rng: np.r_[rng.uniform(0, 100, 2), rng.uniform(-3, 3), rng.uniform(0.5, 2)], None),
    (Auv3Model(BEACON), lambda rng: np.r_[rng.uniform(0, 100, 2), rng.uniform(0.5, 2)], np.array([0.7])),
    (ConstantVelocityModel([[0, 0], [100, 0], [0, 100]]), lambda rng: np.r_[rng.uniform(10, 90, 2), rng.normal(0, 1, 2)], None),
]


@pytest.mark.parametrize("model, draw, u", MODELS, ids=lambda m: type(m).__name__ if not callable(m) else "")
def test_jacobians_equal_numerical_derivatives(model, draw, u):
    rng = np.random.default_rng(1)
    kinds = list(model.kinds) if hasattr(model, "kinds") else [0, 1, 2]
    for _ in range(20):
        x = draw(rng)
        F = model.transition_jacobian(x, u, 0.25)
        # 1e-7 absolute: numerical derivative error (≈1e-10) with a wide margin, far below any row's size.
        np.testing.assert_allclose(F, numerical_jacobian(lambda s: model.transition(s, u, 0.25), x), atol=1e-7)
        for kind in kinds:
            H = model.measurement_jacobian(x, kind)
            np.testing.assert_allclose(H, numerical_jacobian(lambda s: model.measure(s, kind), x), atol=1e-7)


def test_paper000_com_jacobian_fixes_eq22_typo():
    """The a row must differentiate a (eq 22 prints the Ω row twice)."""
    H = Auv6Model(BEACON).measurement_jacobian(np.array([10.0, 20.0, 0.3, 1.0, 0.0, 0.0]), "com")
    np.testing.assert_array_equal(H[4], [0, 0, 0, 0, 0, 1])
    np.testing.assert_array_equal(H[3], [0, 0, 0, 0, 1, 0])


class LinearModel:
    """x' = F x + B u, z = H x: the EKF on it must be the Kalman filter."""

    def __init__(self, F, B, H):
        self.F, self.B, self.H = F, B, H

    def transition(self, x, u, dt):
        return self.F @ x + self.B @ u

    def transition_jacobian(self, x, u, dt):
        return self.F

    def measure(self, x, kind):
        return self.H @ x

    def measurement_jacobian(self, x, kind):
        return self.H

    def angular(self, kind):
        return np.zeros(self.H.shape[0], dtype=bool)


def test_ekf_equals_textbook_kalman_filter_on_linear_gaussian_model():
    rng = np.random.default_rng(2)
    n, m = 4, 2
    F = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    B = rng.normal(size=(n, 1))
    H = rng.normal(size=(m, n))
    Q = np.diag(rng.uniform(0.01, 0.1, n))
    R = np.diag(rng.uniform(0.1, 1.0, m))
    x0, P0 = rng.normal(size=n), np.eye(n)
    ekf = ExtendedKalmanFilter(LinearModel(F, B, H), x0, P0, Q)
    x, P = x0.copy(), P0.copy()
    for k in range(1, 60):
        u = rng.normal(size=1)
        z = rng.normal(size=m)
        ekf.predict(float(k), u)
        ekf.update(z, "z", R)
        # Textbook form (Kalman 1960; Simon 2006 eq 5.19), written independently of kalman_update.
        x = F @ x + B @ u
        P = F @ P @ F.T + Q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        x = x + K @ (z - H @ x)
        P = (np.eye(n) - K @ H) @ P
        # 1e-12 relative: both are exact algebra; only the rounding of ~60 steps of 4×4 products differs.
        np.testing.assert_allclose(ekf.x, x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ekf.P, P, rtol=1e-12, atol=1e-12)


def test_nees_inside_chi2_band_on_well_modelled_scenario():
    """Truth drawn from the 6-state model itself, with the filter's Q and R: NEES ~ χ²(6)."""
    model = Auv6Model(BEACON)
    dt = 0.25
    Q = np.diag([1e-4, 1e-4, 1e-5, 1e-4, 1e-4, 1e-4])
    R_com = np.diag([1.0, 0.01, 0.01, 0.005, 0.005])
    R_ahrs = R_com[2:, 2:]
    P0 = np.diag([1.0, 1.0, 0.01, 0.01, 0.01, 0.01])
    rng = np.random.default_rng(3)
    runs, steps = 40, 200
    values = []
    for _ in range(runs):
        truth = np.array([20.0, 30.0, 0.3, 1.0, 0.01, 0.0])
        ekf = ExtendedKalmanFilter(model, truth + rng.multivariate_normal(np.zeros(6), P0), P0, Q)
        for k in range(1, steps + 1):
            truth = model.transition(truth, None, dt) + rng.multivariate_normal(np.zeros(6), Q)
            ekf.predict(k * dt)
            kind, R = ("com", R_com) if k % 12 == 0 else ("ahrs", R_ahrs)
            z = model.measure(truth, kind) + rng.multivariate_normal(np.zeros(len(R)), R)
            ekf.update(z, kind, R)
            if k % 20 == 0:
                values.append(nees(ekf.x - truth, ekf.P))
    values = np.asarray(values)
    # Mean of N NEES values: N·mean ~ χ²(6N) for a consistent filter; 99 % two-sided band.
    N = values.size
    lo, hi = stats.chi2.ppf([0.005, 0.995], 6 * N) / N
    assert lo < values.mean() < hi, (lo, values.mean(), hi)


def test_update_predicts_to_measurement_time_and_rejects_backwards():
    model = ConstantVelocityModel([[0.0, 0.0]])
    ekf = ExtendedKalmanFilter(model, [10.0, 0.0, 1.0, 0.0], np.eye(4), model.process_noise)
    ekf.update([11.0], 0, 0.01, t_s=1.0)
    assert ekf.t == 1.0
    # After 1 s at 1 m/s the prior is 11 m away; the measurement agrees, so x stays near 11.
    assert abs(ekf.x[0] - 11.0) < 0.05
    with pytest.raises(ValueError, match="backwards"):
        ekf.predict(0.5)


def test_kalman_update_nis_is_chi2_statistic():
    x, P = np.zeros(2), np.eye(2)
    H, R = np.eye(2), np.eye(2)
    _, _, nis = kalman_update(x, P, np.array([2.0, 0.0]), H, R)
    assert nis == pytest.approx(2.0)  # ν' S⁻¹ ν with S = 2 I and ν = (2, 0)


def test_bad_shapes_and_kinds_are_named():
    with pytest.raises(ConfigError, match="P0"):
        ExtendedKalmanFilter(Auv6Model(BEACON), np.zeros(6), np.eye(5), np.eye(6))
    with pytest.raises(ConfigError, match="kind"):
        Auv6Model(BEACON).measure(np.ones(6), "sonar")
    with pytest.raises(ConfigError, match="beacon_xy"):
        Auv6Model((np.nan, 0.0))
