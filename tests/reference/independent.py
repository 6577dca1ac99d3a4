"""Independent received pings: scipy's own chirp and m-sequence at analytic, time-scaled times.

Nothing here uses the project's waveform generator or channel simulator. A ping
emitted at 0 and heard from t_a on with closing speed v (SPEC §1: s̃(t) = s((1 + v/c)(t − t_a)))
is ``scipy.signal.chirp`` (or the m-sequence, SRRC-shaped by direct summation) evaluated at
u = (1 + v/c)(t − t_a), times a Tukey window; white Gaussian noise is added at an in-band SNR
over [f_low, f_high] during the ping.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal


def tukey(u: np.ndarray, taper: float) -> np.ndarray:
    """Tukey window on u ∈ [0, 1] (0 outside), by its textbook formula."""
    w = np.where((u >= 0) & (u <= 1), 1.0, 0.0)
    edge = np.minimum(u, 1 - u)
    ramp = (edge < taper / 2) & (w > 0)
    w[ramp] = 0.5 * (1 - np.cos(2 * np.pi * edge[ramp] / taper))
    return w


def chirp_ping(u: np.ndarray, *, f0: float, f1: float, duration_s: float, method: str, taper: float = 0.1) -> np.ndarray:
    """scipy.signal.chirp over [0, T] (``method`` 'linear' or 'hyperbolic'), Tukey-windowed."""
    inside = np.clip(u, 0, duration_s)
    return tukey(u / duration_s, taper) * scipy.signal.chirp(inside, f0=f0, t1=duration_s, f1=f1, method=method)


def received(
    ping,
    *,
    fs: float,
    duration_s: float,
    arrivals_s,
    v_mps,
    sound_speed_mps: float = 1500.0,
    ping_duration_s: float,
) -> np.ndarray:
    """Σ ping((1 + v/c)(t − t_a)) over the arrivals (one v per arrival, or one for all)."""
    t = np.arange(int(round(duration_s * fs))) / fs
    x = np.zeros_like(t)
    v = np.broadcast_to(np.asarray(v_mps, dtype=float), (len(arrivals_s),))
    for ta, vi in zip(arrivals_s, v):
        lo, hi = int(math.floor(ta * fs)) - 2, int(math.ceil((ta + ping_duration_s) * fs)) + 2
        lo, hi = max(lo, 0), min(hi, len(t))
        x[lo:hi] += ping((1 + vi / sound_speed_mps) * (t[lo:hi] - ta))
    return x


def add_noise(x: np.ndarray, *, fs: float, ping, band_hz: tuple[float, float], ping_duration_s: float,
              snr_db: float, rng: np.random.Generator) -> np.ndarray:
    """White noise for an in-band SNR: ping power over [0, T] / (N0·B), N0 the one-sided PSD."""
    u = np.arange(int(ping_duration_s * fs)) / fs
    power = float(np.mean(ping(u) ** 2))
    n0 = power / (10 ** (snr_db / 10) * (band_hz[1] - band_hz[0]))
    return x + rng.normal(0.0, math.sqrt(n0 * fs / 2), len(x))
