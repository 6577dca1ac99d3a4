"""The low-pass designs written in seamodem.dsp (so that `seamodem rx` need not import scipy.signal, 0.45 s)
against scipy.signal's own, an independent implementation of the same textbook formulas."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from seamodem.dsp import kaiser_order, lowpass_taps, windowed_sinc_lowpass


@pytest.mark.parametrize("attenuation_db, width", [(90.0, 0.1), (60.0, 0.05), (40.0, 0.2), (25.0, 0.3),
                                                   (15.0, 0.1), (120.0, 0.01)])
def test_kaiser_order_is_scipys(attenuation_db, width):
    numtaps, beta = kaiser_order(attenuation_db, width)
    ref_taps, ref_beta = scipy.signal.kaiserord(attenuation_db, width)
    assert numtaps == ref_taps
    assert beta == pytest.approx(ref_beta, rel=1e-15, abs=1e-15)


def test_kaiser_order_refuses_an_attenuation_its_formulas_do_not_cover():
    with pytest.raises(ValueError, match="at least 8 dB"):
        kaiser_order(5.0, 0.1)


@pytest.mark.parametrize("numtaps, cutoff_hz, fs, window", [(115, 1000.0, 8000.0, ("kaiser", 8.96)),
                                                            (85, 66.7, 1373.6, "hamming"),
                                                            (201, 5000.0, 96000.0, ("kaiser", 5.0)),
                                                            (31, 0.3, 1.0, "hamming")])
def test_windowed_sinc_lowpass_is_firwins(numtaps, cutoff_hz, fs, window):
    w = np.kaiser(numtaps, window[1]) if isinstance(window, tuple) else np.hamming(numtaps)
    ours = windowed_sinc_lowpass(numtaps, cutoff_hz, fs, w)
    ref = scipy.signal.firwin(numtaps, cutoff_hz, window=window, fs=fs)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-13 * np.max(np.abs(ref)))


def test_lowpass_taps_meet_their_stop_band():
    fs, passband, stopband = 96000.0, 6000.0, 9000.0
    taps = lowpass_taps(fs, passband, stopband, 90.0)
    f = np.linspace(0, fs / 2, 8192)
    h = np.abs(np.exp(-2j * np.pi * np.outer(f / fs, np.arange(len(taps)))) @ taps)
    assert len(taps) % 2 == 1
    assert np.max(np.abs(20 * np.log10(h[f <= passband]))) < 1e-3  # flat to 0.001 dB in the pass band
    assert 20 * np.log10(np.max(h[f >= stopband])) < -85  # Kaiser's formula targets 90 dB
