"""What noise alone leaves in the log-amplitude rate (``doppler.log_amplitude_rate``, ``frame._RatePool``).

The rate's σ term of a Doppler (c·rate/(2πf), ``frame.unmodelled_sigmas``) stands for a phase wander of
the scale the amplitude shows. On a channel that does not fade, the line's slope less its noise
expectation leaves about 0.67 of the slope's noise σ (√E max(z² − 1, 0)), the phase
slope's, i.e. the fit's own σ. The parabola's term has five times that noise over a frame (D²/3 · var a2
against var a1), and clipped at 0 it had left 1.7 of the fit's σ: the corpus's steep family, no fading,
had whole-frame v_r σ's 1.6× their errors from it. It now counts beyond 3 of its σ, and a pool of such
mean squares beyond 3 of its noise σ.
"""

from __future__ import annotations

import math

import numpy as np

from seamodem.receive.doppler import log_amplitude_rate
from seamodem.receive.frame import FADE_POOL_FRAMES, _RatePool

D = 0.9  # the stretch [s]
T = (np.arange(32) + 0.5) / 32 * D - D / 2  # 32 segments about its middle
SD = 0.05  # each segment's ln-amplitude noise σ (4 dB, the steep family's lowest frames)
VAR = np.full(T.size, SD**2)


def _slope_sd() -> float:
    """The weighted least-squares slope's noise σ [1/s] (the phase slope's: the fit's own Doppler σ)."""
    design = np.column_stack([np.ones(T.size), T, T**2])
    return float(math.sqrt(np.linalg.inv(design.T @ (design / VAR[:, None]))[1, 1]))


def test_noise_alone_leaves_at_most_the_slopes_own_sigma():
    rng = np.random.default_rng(1)
    rates, squares, noise = [], [], []
    for _ in range(4000):
        rate, terms = log_amplitude_rate(rng.normal(0.0, SD, T.size), VAR, T, duration_s=D)
        rates.append(rate)
        squares.append(terms[:, 0])
        noise.append(terms[:, 1])
    rms = math.sqrt(np.mean(np.square(rates)))
    # 0.67 from the slope, 0.81 with the parabolas beyond 3σ (0.4 % of draws, each ≥ 9·5 of the slope's
    # variance); the parabola clipped at 0 instead: 1.72
    assert rms < 0.9 * _slope_sd(), rms / _slope_sd()
    # each term stays unbiased (pooled over frames) and its noise σ is what it scatters by; the parabola's
    # five times the line's
    squares, noise = np.array(squares), np.array(noise)
    assert np.all(np.abs(squares.mean(axis=0)) < 4 * squares.std(axis=0) / math.sqrt(len(squares)))
    assert np.all(np.abs(squares.std(axis=0) / np.median(noise, axis=0) - 1) < 0.2)
    assert 4 < np.median(noise[:, 1] / noise[:, 0]) < 6


def test_a_fading_parabola_is_still_counted():
    # ln|h| bending by 0.3 over the frame's half (a fade through the frame): its RMS rate over the frame
    a2 = 0.3 / (D / 2) ** 2
    rate, _ = log_amplitude_rate(a2 * T**2 + np.random.default_rng(2).normal(0, SD, T.size), VAR, T,
                                    duration_s=D)
    assert abs(rate - a2 * D / math.sqrt(3)) < 0.2 * a2 * D / math.sqrt(3)


def test_pool_of_noise_is_zero_and_a_fade_counts():
    rng = np.random.default_rng(3)
    zero = 0
    for _ in range(500):
        pool = _RatePool()
        for _ in range(FADE_POOL_FRAMES):
            pool.add(log_amplitude_rate(rng.normal(0.0, SD, T.size), VAR, T, duration_s=D)[1])
        zero += pool.rate_hz == 0.0
    assert zero >= 0.97 * 500, zero  # clipped at 0 alone, a pool of noise counts in half of them
    # a steady slope of 3 of the slope's noise σ on every frame: counted, at its scale
    slope = 3 * _slope_sd()
    pool = _RatePool()
    for _ in range(FADE_POOL_FRAMES):
        pool.add(log_amplitude_rate(slope * T + rng.normal(0.0, SD, T.size), VAR, T, duration_s=D)[1])
    assert 0.7 * slope < pool.rate_hz < 1.3 * slope
