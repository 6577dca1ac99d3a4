"""Passband ↔ complex baseband conversion and the low-pass filters it needs.

Convention (as arlpy): x_pb(t) = Re[x_bb(t) · exp(+j2π fc t)], a positive-frequency
carrier; ``pb2bb`` returns the complex envelope x_bb (hence its factor 2).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["bb2pb", "pb2bb", "lowpass_taps", "kaiser_order", "windowed_sinc_lowpass", "UniformTable"]


def kaiser_order(attenuation_db: float, width: float) -> tuple[int, float]:
    """Taps and β of a Kaiser-window low-pass for a stop-band attenuation and a transition width.

    Kaiser's design formulas (Oppenheim & Schafer, *Discrete-Time Signal Processing*, eqs. 7.62–7.63):
    β = 0.1102 (A − 8.7) above 50 dB, 0.5842 (A − 21)^0.4 + 0.07886 (A − 21) from 21 to 50 dB, 0 below;
    N = ⌈(A − 7.95) / (2.285 π Δ) + 1⌉, Δ the transition width as a fraction of Nyquist. Written here, not
    taken from ``scipy.signal``, whose import is 0.45 s of every ``seamodem rx`` (scipy.stats with it);
    ``tests/test_dsp.py`` compares the two.

    >>> n, beta = kaiser_order(90.0, 0.1)
    >>> n, round(beta, 4)
    (116, 8.9593)
    """
    a = abs(float(attenuation_db))
    if a < 8:
        raise ValueError(f"attenuation_db must be at least 8 dB for Kaiser's formulas, got {attenuation_db!r}")
    if a > 50:
        beta = 0.1102 * (a - 8.7)
    elif a > 21:
        beta = 0.5842 * (a - 21) ** 0.4 + 0.07886 * (a - 21)
    else:
        beta = 0.0
    return int(np.ceil((a - 7.95) / (2.285 * np.pi * width) + 1)), beta


def windowed_sinc_lowpass(numtaps: int, cutoff_hz: float, fs: float, window: np.ndarray) -> np.ndarray:
    """Linear-phase low-pass FIR: the ideal low-pass's impulse response over ``numtaps`` taps, times ``window``
    (symmetric, ``numtaps`` long), scaled to unit gain at 0 Hz (``scipy.signal.firwin``'s design; see
    :func:`kaiser_order` for why it is written here)."""
    cutoff = float(cutoff_hz) / (fs / 2)  # a fraction of Nyquist
    m = np.arange(numtaps) - (numtaps - 1) / 2
    h = cutoff * np.sinc(cutoff * m) * np.asarray(window, dtype=float)
    return h / np.sum(h)


@lru_cache(maxsize=32)
def lowpass_taps(fs: float, passband_hz: float, stopband_hz: float, attenuation_db: float = 90.0) -> np.ndarray:
    """Odd-length linear-phase Kaiser low-pass FIR (delay (n − 1)/2 samples).

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    passband_hz, stopband_hz : float
        Edges of the transition band [Hz], 0 < passband < stopband < fs/2.
    attenuation_db : float
        Stop-band attenuation [dB].
    """
    if not 0 < passband_hz < stopband_hz < fs / 2:
        raise ValueError(
            f"need 0 < passband_hz < stopband_hz < fs/2 = {fs / 2:g}, got {passband_hz!r}, {stopband_hz!r}"
        )
    width = (stopband_hz - passband_hz) / (fs / 2)
    numtaps, beta = kaiser_order(attenuation_db, width)
    numtaps |= 1
    taps = windowed_sinc_lowpass(numtaps, (passband_hz + stopband_hz) / 2, fs, np.kaiser(numtaps, beta))
    taps.setflags(write=False)
    return taps


def bb2pb(x_bb: np.ndarray, fs: float, fc: float, *, t0_s: float = 0.0) -> np.ndarray:
    """Re[x_bb · exp(j2π fc t)] with t = t0 + n/fs [s].

    Parameters
    ----------
    x_bb : numpy.ndarray, shape (n_samples,)
        Complex baseband samples at ``fs``.
    fs, fc : float
        Sample rate and carrier [Hz].
    t0_s : float
        Time of the first sample [s] (carrier phase reference); default 0.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        Real passband samples (no factor 2: a unit baseband tone gives a
        carrier of amplitude 1).
    """
    t = t0_s + np.arange(len(x_bb)) / fs
    return np.real(np.asarray(x_bb) * np.exp(2j * np.pi * fc * t))


def pb2bb(
    x_pb: np.ndarray,
    fs: float,
    fc: float,
    *,
    passband_hz: float,
    stopband_hz: float,
    t0_s: float = 0.0,
    attenuation_db: float = 90.0,
) -> np.ndarray:
    """Complex envelope of a real passband signal (zero-phase low-pass).

    Parameters
    ----------
    x_pb : numpy.ndarray, shape (n_samples,)
        Real passband samples.
    fs, fc : float
        Sample rate and carrier [Hz].
    passband_hz, stopband_hz : float
        Low-pass edges [Hz] around baseband 0 Hz: keep |f| < passband, reject
        |f| > stopband (e.g. the tone offset from the carrier).
    t0_s : float
        Time of the first sample [s] (carrier phase reference).

    Returns
    -------
    numpy.ndarray, shape (n_samples,), complex
        x_bb, with x_pb ≈ Re[x_bb e^{j2π fc t}] in band.
    """
    t = t0_s + np.arange(len(x_pb)) / fs
    mixed = 2.0 * np.asarray(x_pb) * np.exp(-2j * np.pi * fc * t)
    taps = lowpass_taps(float(fs), float(passband_hz), float(stopband_hz), float(attenuation_db))
    import scipy.signal  # here: the receiver's front end filters on its own (kaiser_order)

    return scipy.signal.oaconvolve(mixed, taps, mode="same")


class UniformTable:
    """A function tabulated on a uniform grid, read back by linear interpolation (0 outside).

    ``f`` is evaluated once at x = −half_extent + k/rate, k = 0 … 2·half_extent·rate.
    Reading indexes the grid directly (no search), so that hot loops pay a few
    array operations per point instead of the closed form. The error is at most
    (1/rate)²/8 · max|f''|.

    Parameters
    ----------
    f : callable
        Vectorised function of x.
    half_extent : int
        The table covers [−half_extent, half_extent].
    rate : int
        Points per unit of x.
    """

    def __init__(self, f, half_extent: int, rate: int):
        self.half_extent, self.rate = int(half_extent), int(rate)
        self.values = np.asarray(f(np.linspace(-half_extent, half_extent, 2 * self.half_extent * self.rate + 1)))

    def __call__(self, x) -> np.ndarray:
        pos = (np.asarray(x, dtype=float) + self.half_extent) * self.rate
        i = np.clip(np.floor(pos).astype(np.int64), 0, self.values.size - 2)
        frac = pos - i
        out = self.values[i] * (1.0 - frac) + self.values[i + 1] * frac
        return np.where((pos >= 0) & (pos <= self.values.size - 1), out, 0.0)
