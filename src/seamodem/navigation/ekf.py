"""Extended Kalman filter behind one interface: predict with inputs, update with time-stamped measurements.

A model (see :mod:`seamodem.navigation.models`) supplies the state transition, its
Jacobian, and for each *kind* of measurement the observation function and its
Jacobian. The filter itself knows nothing about vehicles or beacons; the same
code runs the 6-state filter of paper 000, the 4-state filter of paper 002, the
3-state filter of paper 003 and the constant-velocity filter of paper 004.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import ConfigError

__all__ = ["ExtendedKalmanFilter", "kalman_update", "nees"]


def kalman_update(
    x: np.ndarray,
    P: np.ndarray,
    innovation: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Textbook Kalman measurement update (Joseph form).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior state.
    P : ndarray, shape (n, n)
        Prior covariance.
    innovation : ndarray, shape (m,)
        Measurement minus predicted measurement.
    H : ndarray, shape (m, n)
        Measurement matrix (Jacobian of the observation function at the prior).
    R : ndarray, shape (m, m)
        Measurement noise covariance.

    Returns
    -------
    x_post : ndarray, shape (n,)
    P_post : ndarray, shape (n, n)
    nis : float
        Normalized innovation squared ν' S⁻¹ ν (χ²(m) when the model is right).

    Notes
    -----
    K = P Hᵀ S⁻¹, S = H P Hᵀ + R (paper 000 Algorithm 1, line 5; line 7 means K·ν).
    The Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ keeps P symmetric and positive
    over the 6 000 updates of a mission, where I − KH alone drifts.
    """
    S = H @ P @ H.T + R
    PHt = P @ H.T
    K = np.linalg.solve(S, PHt.T).T  # S is symmetric: K = P Hᵀ S⁻¹
    x_post = x + K @ innovation
    IKH = np.eye(P.shape[0]) - K @ H
    P_post = IKH @ P @ IKH.T + K @ R @ K.T
    nis = float(innovation @ np.linalg.solve(S, innovation))
    return x_post, 0.5 * (P_post + P_post.T), nis


def nees(error: np.ndarray, P: np.ndarray) -> float:
    """Normalized estimation error squared eᵀ P⁻¹ e (χ²(n) for a consistent filter).

    Parameters
    ----------
    error : numpy.ndarray, shape (n,)
        Estimate minus truth, in the state's units.
    P : numpy.ndarray, shape (n, n)
        The filter's covariance of that estimate.

    Returns
    -------
    float
        eᵀ P⁻¹ e (dimensionless).
    """
    return float(error @ np.linalg.solve(P, error))


class ExtendedKalmanFilter:
    """EKF over any model with ``transition``/``measure`` and their Jacobians.

    Parameters
    ----------
    model : object
        Provides ``transition(x, u, dt)``, ``transition_jacobian(x, u, dt)``,
        ``measure(x, kind)``, ``measurement_jacobian(x, kind)`` and
        ``angular(kind)`` (boolean mask of measurement components that are
        angles, whose innovation is wrapped to (−π, π]).
    x0 : array_like, shape (n,)
        Initial state.
    P0 : array_like, shape (n, n)
        Initial covariance.
    Q : array_like, shape (n, n), or callable
        Process noise covariance added at each prediction, or ``Q(dt)``.
    t0_s : float
        Time of the initial state [s].

    Notes
    -----
    ``predict(t_s, u)`` moves the state to time ``t_s`` in one step of length
    ``t_s − t``; ``update(z, kind, R, t_s=...)`` first predicts to ``t_s`` with the
    last input when the measurement is later than the state, so every
    measurement is fused at its own time (paper 004 §IV-B).
    """

    def __init__(self, model, x0, P0, Q, *, t0_s: float = 0.0):
        self.model = model
        self.x = np.array(x0, dtype=float)
        self.P = np.array(P0, dtype=float)
        n = self.x.size
        if self.P.shape != (n, n):
            raise ConfigError("P0", f"must be {n}×{n} for a state of {n}, got shape {self.P.shape}")
        self._Q = Q if callable(Q) else np.asarray(Q, dtype=float)
        if not callable(Q) and self._Q.shape != (n, n):
            raise ConfigError("Q", f"must be {n}×{n}, got shape {self._Q.shape}")
        self.t = float(t0_s)
        self.u = None
        self.F = np.eye(n)
        self.last_nis = np.nan

    def _process_noise(self, dt: float) -> np.ndarray:
        return self._Q(dt) if callable(self._Q) else self._Q

    def predict(self, t_s: float, u=None) -> None:
        """Propagate to time ``t_s`` [s] with input ``u`` (kept for later updates)."""
        dt = float(t_s) - self.t
        if dt < 0:
            raise ValueError(f"t_s: prediction backwards in time ({t_s!r} s < state time {self.t!r} s)")
        if u is not None:
            self.u = np.asarray(u, dtype=float)
        F = self.model.transition_jacobian(self.x, self.u, dt)
        self.F = F  # the Jacobian of the last prediction (a smoother needs it)
        self.x = self.model.transition(self.x, self.u, dt)
        self.P = F @ self.P @ F.T + self._process_noise(dt)
        self.t = float(t_s)

    def update(self, z, kind: str, R, *, t_s: float | None = None) -> None:
        """Fuse measurement ``z`` of type ``kind`` with noise covariance ``R``.

        Parameters
        ----------
        z : array_like, shape (m,)
        kind : str
            A measurement kind the model knows (e.g. ``"com"`` or ``"ahrs"``).
        R : array_like, shape (m, m) or (m,)
            Covariance, or its diagonal.
        t_s : float, optional
            Time of the measurement [s]; the state is first predicted to it.
        """
        if t_s is not None and t_s > self.t:
            self.predict(t_s)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        R = np.asarray(R, dtype=float)
        if R.ndim < 2:
            R = np.diag(np.broadcast_to(R, z.shape))
        innovation = z - self.model.measure(self.x, kind)
        wrap = self.model.angular(kind)
        innovation[wrap] = np.angle(np.exp(1j * innovation[wrap]))
        H = self.model.measurement_jacobian(self.x, kind)
        self.x, self.P, self.last_nis = kalman_update(self.x, self.P, innovation, H, R)

    @property
    def state(self) -> np.ndarray:
        return self.x.copy()

    @property
    def covariance(self) -> np.ndarray:
        return self.P.copy()
