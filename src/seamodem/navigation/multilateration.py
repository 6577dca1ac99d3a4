"""Several anchors (paper 004): linear least squares per cycle, and the sequential EKF run over a cycle log."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .ekf import ExtendedKalmanFilter
from .models import ConstantVelocityModel

__all__ = ["lls_position", "track_anchor_ranges"]


def lls_position(anchors_xy, ranges_m) -> np.ndarray:
    """Position [m] from horizontal ranges to ≥ 3 anchors by linear least squares.

    Parameters
    ----------
    anchors_xy : array_like, shape (k, 2)
    ranges_m : array_like, shape (k,)
        Horizontal ranges (paper 004 eq 10 applied); NaN entries (lost packets) are dropped.

    Returns
    -------
    ndarray, shape (2,)
        NaN when fewer than 3 ranges remain (paper 004 §IV-C: the cycle is rejected).

    Notes
    -----
    Subtracting the first circle equation ‖p − a_i‖² = d_i² from the others gives
    the linear system 2(a_i − a_0)ᵀ p = d_0² − d_i² + ‖a_i‖² − ‖a_0‖² (the LLS
    baseline of paper 004 §IV-C).
    """
    anchors = np.asarray(anchors_xy, dtype=float)
    ranges = np.asarray(ranges_m, dtype=float)
    if anchors.ndim != 2 or anchors.shape[1] != 2 or anchors.shape[0] != ranges.size:
        raise ConfigError("anchors_xy", f"must be (k, 2) with one range each, got {anchors.shape} and {ranges.shape}")
    ok = np.isfinite(ranges)
    anchors, ranges = anchors[ok], ranges[ok]
    if ranges.size < 3:
        return np.full(2, np.nan)
    a0, d0 = anchors[0], ranges[0]
    A = 2.0 * (anchors[1:] - a0)
    b = d0**2 - ranges[1:] ** 2 + np.sum(anchors[1:] ** 2, axis=1) - np.sum(a0**2)
    return np.linalg.lstsq(A, b, rcond=None)[0]


def track_anchor_ranges(anchors_xy, t_s, anchor_index, ranges_m, *, x0, P0, range_std_m: float,
                        accel_psd: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Paper 004's EKF: constant velocity, each range fused at its own time, lost packets skipped.

    Parameters
    ----------
    anchors_xy : array_like, shape (k, 2)
    t_s : array_like, shape (m,)
        Arrival times, non-decreasing [s].
    anchor_index : array_like of int, shape (m,)
        Which anchor answered.
    ranges_m : array_like, shape (m,)
        Horizontal ranges [m]; NaN for a lost packet (the update is skipped).
    x0, P0 : initial (x, y, ẋ, ẏ) and covariance.
    range_std_m : float
        Range noise standard deviation [m].

    Returns
    -------
    states : ndarray, shape (m, 4)
        State after each measurement time.
    covariances : ndarray, shape (m, 4, 4)
    """
    t_s = np.asarray(t_s, dtype=float)
    if np.any(np.diff(t_s) < 0):
        raise ConfigError("t_s", "measurement times must be non-decreasing")
    model = ConstantVelocityModel(anchors_xy, accel_psd=accel_psd)
    ekf = ExtendedKalmanFilter(model, x0, P0, model.process_noise, t0_s=float(t_s[0]) if t_s.size else 0.0)
    states, covs = [], []
    for t, i, d in zip(t_s, anchor_index, ranges_m):
        ekf.predict(t)
        if np.isfinite(d):
            ekf.update([d], int(i), range_std_m**2)
        states.append(ekf.state)
        covs.append(ekf.covariance)
    return np.array(states).reshape(-1, 4), np.array(covs).reshape(-1, 4, 4)
