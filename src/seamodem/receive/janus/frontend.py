"""JANUS front end: passband → complex baseband about fc at 40 samples per tone spacing (6400 Hz for set 1)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy.fft import ifft, next_fast_len, rfft

from ...transmit.janus import JanusParameterSet

__all__ = ["baseband_rate", "to_baseband"]

#: baseband samples per 1/cf: the 26 tones fall on bins of a 40-point DFT over one chip (e = 0)
SAMPLES_PER_SPACING = 40


def baseband_rate(pset: JanusParameterSet) -> float:
    """Baseband sample rate [Hz]: 40·cf (6400 Hz for parameter set 1)."""
    return SAMPLES_PER_SPACING * pset.chip_hz


def to_baseband(x_pb: np.ndarray, fs: float, pset: JanusParameterSet) -> tuple[np.ndarray, float]:
    """Shift the band about fc to 0 Hz and resample to :func:`baseband_rate`, in the frequency domain.

    One real FFT of the recording, the bins within ±fs_bb/2 of fc kept (tapered by a raised cosine
    from 0.85 to 1 of fs_bb/2, beyond the tones' ±2.1 kHz), one inverse FFT at the baseband rate.

    Parameters
    ----------
    x_pb : numpy.ndarray, shape (n_samples,)
        Real passband samples.
    fs : float
        Their sample rate [Hz].
    pset : JanusParameterSet
        Parameter set (fc and band).

    Returns
    -------
    x_bb : numpy.ndarray, complex128
        Baseband; sample m is at time m / fs_bb on the recording's clock.
    fs_bb : float
        Its rate [Hz].
    """
    pset.check_rate(fs)
    fs_bb = baseband_rate(pset)
    ratio = Fraction(fs_bb / fs).limit_denominator(4000)
    p, q = ratio.numerator, ratio.denominator
    n_in = len(x_pb)
    # an FFT length that the output rate divides exactly and that pocketfft factors well
    n_fft = q * next_fast_len(-(-n_in // q))
    n_out = n_fft // q * p
    # single precision: 24-bit audio fits, and the transform's error (~1e-7) is far below any noise floor
    spec = rfft(np.asarray(x_pb, dtype=np.float32), n_fft)
    df = fs / n_fft
    k = np.arange(-(n_out // 2), n_out - n_out // 2)
    f = k * df
    src = np.round(pset.fc_hz / df).astype(np.int64) + k
    ok = (src >= 0) & (src < spec.size)
    edge = 0.85 * fs_bb / 2
    taper = np.where(np.abs(f) <= edge, 1.0, 0.5 * (1 + np.cos(np.pi * (np.abs(f) - edge) / (fs_bb / 2 - edge))))
    out = np.zeros(n_out, dtype=np.complex128)
    out[k[ok] % n_out] = spec[src[ok]] * taper[ok]
    # the real spectrum's positive half holds the band: ×2 makes the analytic signal; the shift by
    # round(fc/df) bins is exact when fc is a multiple of df, else a residual fc − round(fc/df)·df
    # is mixed out in time
    x_bb = ifft(out) * (2 * n_out / n_fft)
    residual = pset.fc_hz - np.round(pset.fc_hz / df) * df
    m = np.arange(n_out)
    if residual:
        x_bb *= np.exp(-2j * np.pi * residual * m / fs_bb)
    return x_bb[: int(np.ceil(n_in * p / q))], float(fs * p / q)
