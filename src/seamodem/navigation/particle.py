"""Particle filter of paper 001: likelihood weights, resampling when N_eff drops below a threshold."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["ParticleFilter", "systematic_resample"]


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices drawn by systematic resampling (one uniform, N evenly spaced pointers)."""
    n = weights.size
    positions = (rng.random() + np.arange(n)) / n
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # guard against rounding leaving the last pointer past the end
    return np.searchsorted(cumulative, positions)


class ParticleFilter:
    """Bootstrap particle filter over any model with a vectorised ``transition``.

    Parameters
    ----------
    model : object
        ``transition(X, u, dt)`` must accept particles as columns, X of shape (n, N)
        (true for the models of :mod:`seamodem.navigation.models`, which are
        elementwise), and ``measure(x, kind)`` is evaluated per particle through
        ``measure_particles`` when the model has it, else row by row.
    particles : ndarray, shape (N, n)
        Initial particles (paper 001 eq 6: drawn uniformly over the prior region).
    process_std : array_like, shape (n,)
        Standard deviation of the noise added to each state at each prediction.
    rng : numpy.random.Generator
    threshold : float
        Resample when N_eff = 1 / Σ w² < threshold · N (paper 001 eq 11, N_th).
    t0_s : float
        Time of the initial particles [s].

    Notes
    -----
    Prediction eq 8, update eq 9–10 with a Gaussian likelihood (eq 54), resampling
    eq 11, estimate = weighted mean. The interface matches
    :class:`~seamodem.navigation.ekf.ExtendedKalmanFilter` (``predict``, ``update``,
    ``x``, ``P``).
    """

    def __init__(self, model, particles, process_std, *, rng: np.random.Generator, threshold: float = 0.5,
                 t0_s: float = 0.0):
        self.model = model
        self.particles = np.array(particles, dtype=float)
        if self.particles.ndim != 2:
            raise ConfigError("particles", f"must have shape (N, n_states), got {self.particles.shape}")
        n_particles = self.particles.shape[0]
        self.weights = np.full(n_particles, 1.0 / n_particles)  # eq 7
        self.process_std = np.asarray(process_std, dtype=float)
        if not 0 < threshold <= 1:
            raise ConfigError("threshold", f"must be in (0, 1] (fraction of N), got {threshold!r}")
        self.threshold = threshold
        self.rng = rng
        self.t = float(t0_s)
        self.u = None
        self.resample_count = 0

    def predict(self, t_s: float, u=None) -> None:
        dt = float(t_s) - self.t
        if dt < 0:
            raise ValueError(f"t_s: prediction backwards in time ({t_s!r} s < state time {self.t!r} s)")
        if u is not None:
            self.u = u
        moved = self.model.transition(self.particles.T, self.u, dt).T
        self.particles = moved + self.rng.normal(size=moved.shape) * self.process_std
        self.t = float(t_s)

    def update(self, z, kind, R, *, t_s: float | None = None) -> None:
        """Weight by the Gaussian likelihood of ``z`` (covariance ``R``), then resample if N_eff is low."""
        if t_s is not None and t_s > self.t:
            self.predict(t_s)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        R = np.asarray(R, dtype=float)
        R = np.diag(np.broadcast_to(R, z.shape)) if R.ndim < 2 else R
        predicted = np.array([self.model.measure(p, kind) for p in self.particles])
        residual = z - predicted
        wrap = self.model.angular(kind)
        residual[:, wrap] = np.angle(np.exp(1j * residual[:, wrap]))
        mahalanobis = np.einsum("ij,ij->i", residual @ np.linalg.inv(R), residual)
        log_w = np.log(self.weights) - 0.5 * mahalanobis
        log_w -= log_w.max()  # normalise in the log domain: far particles would underflow to 0/0
        w = np.exp(log_w)
        self.weights = w / w.sum()
        if self.n_eff < self.threshold * self.weights.size:
            index = systematic_resample(self.weights, self.rng)
            self.particles = self.particles[index]
            self.weights = np.full(self.weights.size, 1.0 / self.weights.size)
            self.resample_count += 1

    @property
    def n_eff(self) -> float:
        """Effective number of particles 1 / Σ w² (paper 001 eq 11)."""
        return float(1.0 / np.sum(self.weights**2))

    @property
    def x(self) -> np.ndarray:
        """Weighted-mean estimate."""
        return self.weights @ self.particles

    @property
    def P(self) -> np.ndarray:
        """Weighted covariance of the particles."""
        d = self.particles - self.x
        return (self.weights[:, None] * d).T @ d
