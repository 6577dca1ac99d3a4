"""Fast kernels against their plain reference forms."""

import numpy as np
import pytest
import scipy.fft
import scipy.signal

from seamodem import get_preset
from seamodem.receive.detect import PilotDetector
from seamodem.receive.doppler import dichotomy_max, matched_filter, tone_frequency_ml
from seamodem.transmit.pulse import srrc_matrix

CFG = get_preset("jmse2024")


@pytest.mark.parametrize("scale, offset_hz", [(1.0, 0.0), (1.002, 56.0)])
def test_dense_matched_filter_equals_the_sparse_srrc_matrix_form(scale, offset_hz):
    rng = np.random.default_rng(0)
    fs = 13736.142857
    r = rng.standard_normal(6000) + 1j * rng.standard_normal(6000)
    tk = 0.05 + np.arange(100) * CFG.symbol_period_s / scale + 1.234e-5
    got = matched_filter(r, fs, 0.01, tk, config=CFG, scale=scale, carrier_offset_hz=offset_hz, t_ref_s=0.05)
    ts = 0.01 + np.arange(len(r)) / fs
    T = CFG.symbol_period_s / scale
    g = srrc_matrix(ts, tk, symbol_period_s=T, rolloff=CFG.rolloff, span_symbols=CFG.srrc_span_symbols)
    want = g.T @ (r * np.exp(-2j * np.pi * offset_hz * (ts - 0.05))) / (fs * T)
    # the receiver interpolates a pulse table (1/2048 symbol): within 1e-6 of the closed form (−120 dB)
    assert np.max(np.abs(got - want)) < 1e-6 * np.sqrt(np.mean(np.abs(want) ** 2))


def test_tabulated_pulse_equals_the_closed_form():
    from seamodem.receive.doppler import _srrc_interp
    from seamodem.transmit.pulse import srrc_pulse

    u = np.random.default_rng(2).uniform(-16, 16, 100_000)
    for a in (0.25, 0.4, 0.5):
        err = np.abs(_srrc_interp(u, a, 16) - srrc_pulse(u, 1.0, a))
        assert err.max() < 2e-7  # (Δu)²/8·max|g''| with Δu = 1/2048
    assert np.all(_srrc_interp(np.array([-16.5, 16.01, 40.0]), 0.4, 16) == 0)  # truncated outside the span


def test_fft_doppler_bank_equals_direct_correlation():
    det = PilotDetector(CFG, 13736.142857, v_max_mps=5, sound_speed_mps=1500)
    rng = np.random.default_rng(1)
    r = rng.standard_normal(3000) + 1j * rng.standard_normal(3000)
    sample, best, peak = det._bank_power(r)
    fft_n = scipy.fft.next_fast_len(len(r))
    power = []
    for f in det.doppler_hz:
        m = round(f * fft_n / det.fs)  # the bank snaps each bin to a multiple of fs/N
        replica = det.template * np.exp(2j * np.pi * m * np.arange(det.length) / fft_n)
        power.append(np.abs(scipy.signal.correlate(r, replica, mode="valid")) ** 2)
    power = np.array(power)
    # single-precision FFTs: relative errors ≈ 1e-7 of the largest |c|² (≈ 4e3 here)
    scale = np.max(power)
    np.testing.assert_allclose(sample, power[:, ::4], rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(peak, np.max(power, axis=0), rtol=0, atol=1e-5 * scale)
    top2 = np.sort(power, axis=0)[-2:]
    clear = top2[1] - top2[0] > 1e-4 * scale  # where two bins tie within rounding, either may win
    np.testing.assert_array_equal(best[clear], np.argmax(power, axis=0)[clear])


def test_dichotomy_and_tone_ml_on_a_clean_tone():
    assert dichotomy_max(lambda x: -((x - 0.3) ** 2), -1.0, 1.0, tol=1e-9) == pytest.approx(0.3, abs=1e-9)
    fs = 1373.6
    t = np.arange(412) / fs
    w = np.ones_like(t)
    fit = tone_frequency_ml(0.7 * np.exp(2j * np.pi * 23.456 * t + 0.4j), t, w, search_hz=80, noise_bandwidth_hz=1.0)
    assert fit.offset_hz == pytest.approx(23.456, abs=1e-5)  # dichotomy tolerance 1 µHz, noise-free
    assert abs(fit.amplitude) == pytest.approx(0.7, rel=1e-6)


def test_streamed_detection_keeps_its_context_and_finds_what_one_pass_finds():
    """find() on a growing buffer (the stream's use: the context before the scan position kept from the
    previous call, not correlated again) gives the detections of one pass over the whole buffer."""
    rng = np.random.default_rng(4)
    det = PilotDetector(CFG, 13736.142857, v_max_mps=5, sound_speed_mps=1500)
    r = (rng.standard_normal(60_000) + 1j * rng.standard_normal(60_000)) / np.sqrt(2)
    starts = [9_000, 27_500, 46_123]
    for s in starts:
        r[s : s + det.length] += 0.5 * det.template
    whole, _ = PilotDetector(CFG, 13736.142857, v_max_mps=5, sound_speed_mps=1500).find(r, 0, 0, final=True)
    streamed, scan_from = [], 0
    for end in range(7_000, len(r) + 7_000, 7_000):
        found, scan_from = det.find(r[: min(end, len(r))], 0, scan_from, final=end >= len(r))
        streamed += found
    assert len(whole) == len(streamed) == 3
    for a, b in zip(whole, streamed):
        assert a.t_start_s == b.t_start_s and a.doppler_hz == b.doppler_hz
        assert abs(a.z - b.z) < 0.05 * a.z  # the noise median over differently sampled context lags
        assert abs(a.rho - b.rho) < 1e-5
    # the stream's context stays bounded: the kept lags span DETECTION_CONTEXT_S at most
    assert det._context_lags.min() >= len(r) - det.length - det.context - 7_000
