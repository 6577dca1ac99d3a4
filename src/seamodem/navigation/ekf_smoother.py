"""Rauch–Tung–Striebel smoother: post-processing a filtered track with the measurements that came later.

Paper 000 positions the vehicle in real time, so its filter only uses the past;
a track computed after the mission (``seamodem nav track --smooth``) can also
use the frames that arrived after each instant. Between two frames the filter
dead-reckons and its error grows (paper 000 §4.1.2); the backward pass pulls
each dead-reckoned stretch towards the next frame as well as the previous one.

For an extended Kalman filter this is the extended RTS smoother: the same
recursion with the Jacobians the filter linearized at.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import ConfigError

__all__ = ["rts_smooth"]


@njit(cache=True)
def _rts_core(x_post, P_post, x_prior, P_prior, F):
    n = x_post.shape[0]
    xs = x_post.copy()
    Ps = P_post.copy()
    for k in range(n - 2, -1, -1):
        # C = P⁺_k Fᵀ_{k+1} (P⁻_{k+1})⁻¹, computed as the solution of P⁻_{k+1} Cᵀ = F_{k+1} P⁺_k.
        Ct = np.linalg.solve(P_prior[k + 1], F[k + 1] @ P_post[k])
        C = Ct.T
        xs[k] = x_post[k] + C @ (xs[k + 1] - x_prior[k + 1])
        D = Ps[k + 1] - P_prior[k + 1]
        Pk = P_post[k] + C @ D @ Ct
        Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps


def rts_smooth(x_post, P_post, x_prior, P_prior, F):
    """Smoothed states and covariances from a forward Kalman filter's history.

    Parameters
    ----------
    x_post : array_like, shape (N, n)
        Filtered (posterior) state at each step k.
    P_post : array_like, shape (N, n, n)
        Filtered covariance at each step.
    x_prior : array_like, shape (N, n)
        Predicted (prior) state at step k, before its measurements (row 0 unused).
    P_prior : array_like, shape (N, n, n)
        Predicted covariance at step k (row 0 unused).
    F : array_like, shape (N, n, n)
        Transition matrix (the Jacobian for an EKF) from step k − 1 to k (row 0 unused).

    Returns
    -------
    x_smooth : ndarray, shape (N, n)
    P_smooth : ndarray, shape (N, n, n)

    Notes
    -----
    Backward recursion (Rauch, Tung & Striebel 1965), from the last step where
    smoothed = filtered:
    C_k = P⁺_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹,
    x̂ˢ_k = x̂⁺_k + C_k (x̂ˢ_{k+1} − x̂⁻_{k+1}),
    Pˢ_k = P⁺_k + C_k (Pˢ_{k+1} − P⁻_{k+1}) C_kᵀ.
    On a linear-Gaussian model this is the minimum-variance estimate given all
    measurements; angles in the state are used as they are (the filters of this
    package keep heading unwrapped, so differences are small).
    """
    x_post = np.ascontiguousarray(x_post, dtype=float)
    P_post = np.ascontiguousarray(P_post, dtype=float)
    x_prior = np.ascontiguousarray(x_prior, dtype=float)
    P_prior = np.ascontiguousarray(P_prior, dtype=float)
    F = np.ascontiguousarray(F, dtype=float)
    if x_post.ndim != 2 or x_post.shape[0] < 1:
        raise ConfigError("x_post", f"must have shape (N, n) with N >= 1, got {x_post.shape}")
    N, n = x_post.shape
    for name, a, shape in (("P_post", P_post, (N, n, n)), ("x_prior", x_prior, (N, n)),
                           ("P_prior", P_prior, (N, n, n)), ("F", F, (N, n, n))):
        if a.shape != shape:
            raise ConfigError(name, f"must have shape {shape}, got {a.shape}")
    for name, a in (("x_post", x_post), ("P_post", P_post), ("x_prior", x_prior), ("P_prior", P_prior), ("F", F)):
        if not np.all(np.isfinite(a[1:] if name in ("x_prior", "P_prior", "F") else a)):
            raise ConfigError(name, "contains NaN or inf")
    return _rts_core(x_post, P_post, x_prior, P_prior, F)
