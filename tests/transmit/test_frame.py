import numpy as np
import pytest
import scipy.signal
from scipy.optimize import minimize_scalar

from seamodem import get_preset
from seamodem.dsp import pb2bb
from seamodem.transmit.frame import (
    build_frame,
    frame_baseband,
    frame_sample_count,
    frame_symbol_times,
    frame_waveform,
    tone_envelope,
)
from seamodem.transmit.pulse import srrc_matrix, srrc_pulse, srrc_taps, srrc_truncation_energy


def naive_frame(frame, tau):
    """Independent reference: eq 8 evaluated term by term with the analytic pulse."""
    cfg = frame.config
    T = cfg.symbol_period_s
    L = cfg.srrc_span_symbols // 2
    norm = np.sqrt(srrc_truncation_energy(cfg.rolloff, L))
    bb = np.zeros(tau.size, complex)
    for x, tk in zip(frame.symbols, frame_symbol_times(cfg)):
        d = tau - tk
        near = np.abs(d) <= L * T
        bb[near] += x * np.sqrt(T) * srrc_pulse(d[near], T, cfg.rolloff) / norm
    a_d = np.sqrt(2 * (1 - cfg.tone_power_share))
    a_t = np.sqrt(2 * cfg.tone_power_share)
    tone = a_t * tone_envelope(cfg, tau) * np.cos(2 * np.pi * cfg.tone_hz * tau)
    return a_d * np.real(bb * np.exp(2j * np.pi * cfg.carrier_hz * tau)) + tone


@pytest.mark.parametrize("offset", [0.0, 0.37 / 96153])
def test_waveform_matches_eq8_evaluated_naively(offset):
    cfg = get_preset("jmse2024").replace(n_data=200)
    fr = build_frame(cfg, b"x")
    s = frame_waveform(fr, offset_s=offset)
    tau = offset + np.arange(s.size) / cfg.sample_rate_hz
    assert tau[-1] < cfg.frame_duration_s <= tau[-1] + 1 / cfg.sample_rate_hz
    np.testing.assert_allclose(s, naive_frame(fr, tau), atol=1e-12)


def _evm_db(received, sent):
    return 10 * np.log10(np.mean(np.abs(received - sent) ** 2) / np.mean(np.abs(sent) ** 2))


@pytest.mark.parametrize("preset", ["jmse2024", "oceans2021"])
def test_loopback_passband_to_symbols_evm_below_minus_40_db(preset):
    # jmse2024 has 15.02 samples per symbol; the matched filter is sampled at the exact symbol times.
    cfg = get_preset(preset)
    fr = build_frame(cfg, b"loopback")
    s = frame_waveform(fr)
    fs = cfg.sample_rate_hz
    tone_offset = abs(cfg.tone_hz - cfg.carrier_hz)
    x_bb = pb2bb(s, fs, cfg.carrier_hz, passband_hz=cfg.bandwidth_hz / 2, stopband_hz=tone_offset - 200)
    tau = np.arange(s.size) / fs
    G = srrc_matrix(tau, frame_symbol_times(cfg), symbol_period_s=cfg.symbol_period_s, rolloff=cfg.rolloff,
                    span_symbols=cfg.srrc_span_symbols)
    z = (G.conj().T @ x_bb) / cfg.samples_per_symbol / np.sqrt(2 * (1 - cfg.tone_power_share))
    evm = _evm_db(z, fr.symbols)
    print(f"{preset}: {cfg.samples_per_symbol:.3f} samples/symbol, EVM {evm:.1f} dB")
    assert evm < -40


def test_loopback_with_independent_integer_rate_matched_filter():
    # oceans2021 has exactly 12 samples/symbol: matched-filter with scipy's convolution of sampled
    # SRRC taps (no srrc_matrix on the receive side) and decimate at the symbol instants.
    cfg = get_preset("oceans2021")
    assert cfg.samples_per_symbol == 12
    fr = build_frame(cfg, b"independent")
    s = frame_waveform(fr)
    x_bb = pb2bb(s, cfg.sample_rate_hz, cfg.carrier_hz, passband_hz=6000, stopband_hz=11800)
    h = srrc_taps(12, cfg.srrc_span_symbols, cfg.rolloff)
    y = scipy.signal.fftconvolve(x_bb, h[::-1])[h.size // 2 :]  # zero-delay matched filter
    idx = 12 * (cfg.n_guard + np.arange(cfg.n_pilot + cfg.n_data))
    z = y[idx]
    z = z / np.sqrt(2 * (1 - cfg.tone_power_share)) / np.sqrt(12)
    assert _evm_db(z, fr.symbols) < -40


def test_data_power_in_band_and_out_of_band_level():
    cfg = get_preset("jmse2024").replace(tone_power_share=0.0)
    s = frame_waveform(build_frame(cfg, b"spectrum"))
    n_fft = 1 << 22
    spec = np.abs(np.fft.rfft(s, n_fft)) ** 2
    f = np.fft.rfftfreq(n_fft, 1 / cfg.sample_rate_hz)
    lo, hi = cfg.data_band_hz
    in_band = (f >= lo) & (f <= hi)
    fraction = spec[in_band].sum() / spec.sum()
    assert fraction >= 0.99
    # out of band: mean level 1 kHz and more outside the band edges, relative to the in-band mean
    far = (f < lo - 1000) | (f > hi + 1000)
    oob_db = 10 * np.log10(spec[far].mean() / spec[in_band].mean())
    print(f"in-band data power {100 * fraction:.3f} %, out-of-band level {oob_db:.1f} dB")
    assert oob_db < -50  # SRRC truncated at ±16 symbols: sidelobes far below the band


def _dtft_peak(x, fs, f_guess, half_width):
    n = np.arange(x.size)

    def neg_power(f):
        return -np.abs(np.sum(x * np.exp(-2j * np.pi * f * n / fs))) ** 2

    res = minimize_scalar(neg_power, bounds=(f_guess - half_width, f_guess + half_width), method="bounded",
                          options={"xatol": 1e-6})
    return res.x


@pytest.mark.parametrize("preset", ["jmse2024", "oceans2021"])
def test_tone_frequency_within_10_mHz(preset):
    cfg = get_preset(preset)
    s = frame_waveform(build_frame(cfg, b"tone"))
    f_hat = _dtft_peak(s, cfg.sample_rate_hz, cfg.tone_hz, 1.0)
    print(f"{preset}: tone at {f_hat:.6f} Hz, error {1e3 * (f_hat - cfg.tone_hz):.3f} mHz")
    assert abs(f_hat - cfg.tone_hz) < 0.01


def test_power_split_between_tone_and_data():
    cfg = get_preset("jmse2024").replace(tone_power_share=0.2, tone_ramp_s=0.0)
    fr = build_frame(cfg, b"power")
    s = frame_waveform(fr)
    tau = np.arange(s.size) / cfg.sample_rate_hz
    tone = np.sqrt(2 * 0.2) * np.cos(2 * np.pi * cfg.tone_hz * tau)
    data = s - tone
    active = (tau > cfg.pilot_start_s) & (tau < cfg.frame_duration_s - cfg.pilot_start_s)
    assert np.mean(tone[active] ** 2) == pytest.approx(0.2, rel=1e-3)
    # random data: power 0.8 within a few per cent (finite frame, pilots)
    assert np.mean(data[active] ** 2) == pytest.approx(0.8, rel=0.03)


def test_frame_length_and_guards():
    cfg = get_preset("jmse2024")
    assert cfg.n_symbols == 1920
    assert cfg.frame_duration_s == pytest.approx(0.3)
    assert frame_sample_count(cfg) == int(np.ceil(0.3 * 96153))
    bb = frame_baseband(build_frame(cfg, b""))
    # the data signal is silent before the first pulse's support starts (Ng − span/2 symbols)
    quiet = int((cfg.n_guard - cfg.srrc_span_symbols // 2) * cfg.samples_per_symbol)
    assert np.all(bb[:quiet] == 0)
    assert np.all(bb[-quiet:] == 0)
