"""JANUS front end: passband → complex baseband about fc at 40 samples per tone spacing (6400 Hz for set 1)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy.signal import resample_poly

from ...transmit.janus import JanusParameterSet

__all__ = ["baseband_rate", "to_baseband"]

#: baseband samples per 1/cf: the 26 tones fall on bins of a 40-point DFT over one chip (e = 0)
SAMPLES_PER_SPACING = 40


def baseband_rate(pset: JanusParameterSet) -> float:
    """Baseband sample rate [Hz]: 40·cf (6400 Hz for parameter set 1)."""
    return SAMPLES_PER_SPACING * pset.chip_hz


def to_baseband(x_pb: np.ndarray, fs: float, pset: JanusParameterSet) -> tuple[np.ndarray, float]:
    """Mix ``x_pb`` down by fc and resample it to :func:`baseband_rate` (zero-phase polyphase filter).

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
    n = np.arange(len(x_pb))
    phase = 2 * np.pi * ((pset.fc_hz * n) % fs) / fs
    x = np.asarray(x_pb, dtype=np.float64)
    re = resample_poly(x * np.cos(phase), ratio.numerator, ratio.denominator)
    im = resample_poly(x * np.sin(phase), ratio.numerator, ratio.denominator)
    # resample_poly's rate is exactly fs·p/q; fs_bb is that when the fraction is exact
    return re - 1j * im, float(fs * ratio.numerator / ratio.denominator)
