"""The corpus's own interpolator (benchmarks/corpus.py): a tabulated Kaiser-windowed sinc that delays every path.

The corpus is the benchmark "nobody here tuned to" (issue 25 item 1), so its interpolator is its own and is
checked here against the formula it tabulates and against an analytic band-limited signal.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.signal import hilbert

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import corpus  # noqa: E402


def _direct(xa: np.ndarray, fs: float, times: np.ndarray) -> np.ndarray:
    """The kernel's formula on every tap, zero outside the signal (the interpolator before it was tabulated)."""
    u = times * fs
    first = np.floor(u).astype(np.int64)
    k = np.arange(-corpus.TAPS // 2 + 1, corpus.TAPS // 2 + 1)
    idx = first[:, None] + k[None, :]
    h = corpus.kaiser_sinc((u - first)[:, None] - k[None, :])
    ok = (idx >= 0) & (idx < len(xa))
    return np.sum(np.where(ok, xa[np.clip(idx, 0, len(xa) - 1)], 0) * h, axis=1)


def test_the_table_reads_the_kernel_to_a_hundred_millionth_and_zero_beyond_the_signal():
    rng = np.random.default_rng(3)
    xa = hilbert(rng.standard_normal(20_000))  # full band: the table's worst case
    fs = 1000.0
    times = np.concatenate([rng.uniform(-0.2, 20.2, 4000), [0.0, 5.0, 19.999, -0.05, 20.07]])
    got = corpus._interp(corpus.padded(xa), fs, times)
    want = _direct(xa, fs, times)
    rms = np.sqrt(np.mean(np.abs(xa) ** 2))
    assert np.max(np.abs(got - want)) < 1e-6 * rms
    assert np.all(got[(times < -0.0325) | (times > 20.033)] == 0)  # all 64 taps off the signal


def test_a_delayed_tone_in_the_band_comes_back_70_db_below_its_power():
    fs, f0 = 96_000.0, 0.3 * 96_000.0  # inside the 0.42 fs cut-off, as the beacons' bands are
    n = np.arange(40_000)
    xa = np.exp(2j * np.pi * f0 * n / fs)
    times = np.linspace(0.1, 0.3, 5001) + np.pi * 1e-6  # off the sample grid, away from the ends
    err = corpus._interp(corpus.padded(xa), fs, times) - np.exp(2j * np.pi * f0 * times)
    assert 10 * np.log10(np.mean(np.abs(err) ** 2)) < -70
