"""Random time variation of a path: a Rician complex gain with a Gaussian Doppler spectrum.

ξ(t) = √(K/(K+1)) + √(1/(K+1)) · z(t), with z a unit-power circular complex
Gaussian process whose Doppler power spectrum is Gaussian,
S(f) ∝ exp(−f² / (2 σ_D²)); σ_D = ``doppler_spread_hz`` is the RMS Doppler
spread, and the autocorrelation is exp(−2π² σ_D² Δt²). E|ξ|² = 1, so the
fluctuation keeps the mean path power. K = ∞ gives ξ = 1 (a steady path).

z is synthesised as complex white noise at a low rate (64 σ_D, at least
1 Hz) filtered by a Gaussian FIR, then linearly interpolated to the sample
times (the variance dip between grid points is below 0.5 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["GaussianDopplerProcess"]

_RATE_PER_HZ = 64.0


@dataclass(frozen=True, eq=False)
class GaussianDopplerProcess:
    """Rician gain ξ(t) of one path over [t0_s, t1_s], drawn once from ``rng``.

    Parameters
    ----------
    doppler_spread_hz : float
        RMS Doppler spread σ_D [Hz], > 0.
    k_factor_db : float
        Rician K (steady / random power) [dB]; ``inf`` for a steady path.
    t0_s, t1_s : float
        Time span to cover [s].
    rng : numpy.random.Generator
    """

    doppler_spread_hz: float
    k_factor_db: float
    t0_s: float
    t1_s: float
    rng: np.random.Generator = field(repr=False)
    grid_s: np.ndarray = field(init=False, repr=False)
    values: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        rate = max(_RATE_PER_HZ * self.doppler_spread_hz, 1.0)
        sigma_t = 1.0 / (2.0 * math.sqrt(2.0) * math.pi * self.doppler_spread_hz)
        half = max(1, math.ceil(4.0 * sigma_t * rate))
        taps = np.exp(-0.5 * (np.arange(-half, half + 1) / rate / sigma_t) ** 2)
        taps /= np.sqrt(np.sum(taps**2))
        n = math.ceil((self.t1_s - self.t0_s) * rate) + 2
        w = (self.rng.standard_normal(n + 2 * half) + 1j * self.rng.standard_normal(n + 2 * half)) / math.sqrt(2.0)
        z = np.convolve(w, taps, mode="valid")
        k = 10.0 ** (self.k_factor_db / 10.0)
        steady, diffuse = (1.0, 0.0) if math.isinf(k) else (math.sqrt(k / (k + 1.0)), math.sqrt(1.0 / (k + 1.0)))
        object.__setattr__(self, "grid_s", self.t0_s + np.arange(n) / rate)
        object.__setattr__(self, "values", steady + diffuse * z)

    def __call__(self, t_s) -> np.ndarray:
        """ξ at times ``t_s`` [s] (complex)."""
        t = np.asarray(t_s, dtype=float)
        return np.interp(t, self.grid_s, self.values.real) + 1j * np.interp(t, self.grid_s, self.values.imag)
