"""The simulator against closed forms: waveforms, delays, amplitudes, noise level."""

import numpy as np
import pytest

from seamodem import build_frame, frame_waveform, get_preset
from seamodem.channel import (
    GaussianDopplerProcess,
    absorption_gain,
    in_band_power,
    parse_scenario,
    simulate,
    spreading_gain,
    thorp_absorption_db_per_km,
)

FS = 96_000.0
C = 1500.0
BAND = (23_000.0, 33_000.0)


def geometry(**overrides):
    data = {
        "mode": "geometry",
        "seed": 5,
        "environment": {"sound_speed_mps": C, "water_depth_m": 40.0, "spreading_exponent": 2.0},
        "beacon": {"position_m": [0.0, 0.0, -10.0]},
        "vehicle": {"start_m": [250.0, 30.0, -20.0], "velocity_mps": [-2.0, 0.5, 0.1]},
        "multipath": {"max_bounces": 0},
    }
    for key, value in overrides.items():
        data.setdefault(key, {}).update(value) if isinstance(value, dict) else data.__setitem__(key, value)
    return parse_scenario(data)


def test_single_moving_path_equals_the_analytic_received_tone_on_the_receiver_clock():
    # r(t) = a(t) cos(2π f (t − R(t)/c)), R(t) = |r0 + v t − b|, sampled at true times t_n = (n/fs − offset)/(1 + ppm)
    offset, ppm = 0.0031, 25.0
    scenario = geometry(clock={"offset_s": offset, "sample_rate_offset_ppm": ppm})
    f = 27_000.0
    x = np.cos(2 * np.pi * f * np.arange(int(2.0 * FS)) / FS)
    y = simulate(x, FS, scenario, band_hz=BAND).output
    t = (np.arange(y.size) / FS - offset) / (1 + ppm * 1e-6)
    r = np.array([250.0, 30.0, -20.0])[:, None] + np.array([-2.0, 0.5, 0.1])[:, None] * t
    R = np.linalg.norm(r - np.array([0.0, 0.0, -10.0])[:, None], axis=0)
    R0 = np.linalg.norm(np.array([250.0, 30.0, -20.0]) + np.array([-2.0, 0.5, 0.1]) * t[0] - [0.0, 0.0, -10.0])
    alpha = thorp_absorption_db_per_km(np.mean(BAND))
    amp = spreading_gain(R, 2.0) * absorption_gain(R, alpha) / (spreading_gain(R0, 2.0) * absorption_gain(R0, alpha))
    expected = amp * np.cos(2 * np.pi * f * (t - R / C))
    keep = (t - R / C > 0.01) & (t - R / C < 1.99)  # the input exists there, kernel edges excluded
    err = np.max(np.abs(y[keep] - expected[keep])) / np.max(np.abs(expected[keep]))
    assert 20 * np.log10(err) < -60


def test_no_motion_one_path_returns_the_input_delayed():
    cfg = get_preset("oceans2021")
    s = frame_waveform(build_frame(cfg, b"delay test"))
    fs = cfg.sample_rate_hz
    x = np.concatenate([np.zeros(2000), s, np.zeros(2000)])
    tau = 0.0123456789  # a fractional number of samples
    scenario = parse_scenario({"mode": "profile", "environment": {"sound_speed_mps": C},
                               "doppler": {"initial_range_m": C * tau,
                                           "components": [{"kind": "constant", "v_mps": 0.0}]}})
    y = simulate(x, fs, scenario, band_hz=cfg.data_band_hz).output
    # independent reference: an exact fractional delay by a phase ramp in the frequency domain
    n = 1 << int(np.ceil(np.log2(y.size + 4000)))
    spectrum = np.fft.rfft(x, n) * np.exp(-2j * np.pi * np.fft.rfftfreq(n, 1 / fs) * tau)
    ref = np.fft.irfft(spectrum, n)[: y.size]
    assert 10 * np.log10(np.sum((y - ref) ** 2) / np.sum(ref**2)) < -60


def test_output_is_long_enough_for_the_last_frame():
    res = simulate(np.ones(1000), FS, geometry(), band_hz=BAND)
    # independent: reception time of the last input sample, t − R(t)/c = 1000/fs, by bisection
    start, vel, b = np.array([250.0, 30.0, -20.0]), np.array([-2.0, 0.5, 0.1]), np.array([0.0, 0.0, -10.0])
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid - np.linalg.norm(start + vel * mid - b) / C < 1000 / FS else (lo, mid)
    assert res.output.size >= lo * FS
    assert res.output.size < lo * FS + 40  # plus the interpolator's half-length, no more
    assert res.channel["output"]["n_samples"] == res.output.size


def test_white_noise_meets_the_in_band_snr():
    cfg = get_preset("jmse2024")
    fs = cfg.sample_rate_hz
    frame = frame_waveform(build_frame(cfg, b"snr"))
    x = np.zeros(int(2.0 * fs))
    starts = [int(0.2 * fs), int(1.0 * fs)]
    for s0 in starts:
        x[s0 : s0 + frame.size] = frame
    kwargs = dict(t_emit_s=[s0 / fs for s0 in starts], frame_duration_s=cfg.frame_duration_s, band_hz=cfg.data_band_hz)
    clean = simulate(x, fs, geometry(), **kwargs)
    noisy = simulate(x, fs, geometry(noise={"kind": "white", "snr_db": 6.0}), **kwargs)
    noise = noisy.output - clean.output
    n_band = in_band_power(noise, fs, cfg.data_band_hz)
    p_sig = np.mean([row["signal_power_in_band"] for row in noisy.truth])
    # one realisation of ~190k samples: the in-band noise power is within ±3 % of its expectation
    assert 10 * np.log10(p_sig / n_band) == pytest.approx(6.0, abs=0.15)
    assert noisy.channel["noise"]["noise_power_in_band"] == pytest.approx(n_band, rel=0.03)
    # per-frame SNR: both frames see nearly the same range, so nearly the requested SNR
    assert [row["snr_db"] for row in noisy.truth] == pytest.approx([6.0, 6.0], abs=0.1)
    assert clean.truth[0]["snr_db"] is None


@pytest.mark.parametrize("kind,extra", [("ambient", {"shipping": 0.8, "wind_mps": 10.0}),
                                        ("gaussian_mixture", {}), ("alpha_stable", {"alpha": 2.0})])
def test_other_noise_kinds_meet_the_in_band_snr(kind, extra):
    x = np.cos(2 * np.pi * 28_000 * np.arange(int(1.0 * FS)) / FS)
    clean = simulate(x, FS, geometry(), band_hz=BAND).output
    noisy = simulate(x, FS, geometry(noise={"kind": kind, "snr_db": 10.0, **extra}), band_hz=BAND).output
    snr = 10 * np.log10(in_band_power(clean, FS, BAND) / in_band_power(noisy - clean, FS, BAND))
    assert snr == pytest.approx(10.0, abs=0.35)  # the mixture's rare impulses make one realisation vary most


def test_same_seed_same_output_and_different_seed_differs():
    x = np.cos(2 * np.pi * 28_000 * np.arange(20_000) / FS)
    args = dict(noise={"kind": "white", "snr_db": 0.0}, fluctuation={"doppler_spread_hz": 1.0}, multipath={"max_bounces": 1})
    a = simulate(x, FS, geometry(**args), band_hz=BAND).output
    b = simulate(x, FS, geometry(**args), band_hz=BAND).output
    c = simulate(x, FS, geometry(seed=6, **args), band_hz=BAND).output
    assert np.array_equal(a, b) and not np.allclose(a, c)


def test_fluctuation_process_statistics():
    spread = 2.0
    proc = GaussianDopplerProcess(spread, -300.0, 0.0, 2000.0, np.random.default_rng(3))
    t = np.arange(0.0, 2000.0, 0.01)
    z = proc(t)
    # K = -300 dB: purely diffuse, unit power (4000 coherence times: ±5 % on the power)
    assert np.mean(np.abs(z) ** 2) == pytest.approx(1.0, rel=0.05)
    lag = 0.1  # s
    k = int(lag / 0.01)
    rho = np.mean(z[k:] * np.conj(z[:-k])) / np.mean(np.abs(z) ** 2)
    assert rho.real == pytest.approx(np.exp(-2 * np.pi**2 * spread**2 * lag**2), abs=0.05)
    steady = GaussianDopplerProcess(spread, np.inf, 0.0, 10.0, np.random.default_rng(3))
    assert np.allclose(steady(np.linspace(0, 10, 50)), 1.0)


def test_fluctuating_echo_keeps_its_mean_power():
    # a fully diffuse echo (K = -100 dB) on a tone: on average it adds its power to the direct path's
    f = 28_000.0
    x = np.cos(2 * np.pi * f * np.arange(int(20 * FS)) / FS)
    data = {"mode": "profile", "environment": {"sound_speed_mps": C},
            "doppler": {"initial_range_m": 15.0, "components": [{"kind": "constant", "v_mps": 0.0}]},
            "multipath": {"paths": [{"delay_s": 0.003, "gain": 0.7}]},
            "fluctuation": {"doppler_spread_hz": 2.0, "k_factor_db": -100.0}}
    y = simulate(x, FS, parse_scenario(data), band_hz=BAND).output[int(FS) : int(19 * FS)]
    p = np.mean(y**2)
    # direct 1 and echo 0.7 add incoherently on average: (1 + 0.49)/2; 36 s·2 Hz ≈ 70 coherence times → ±10 %
    assert p == pytest.approx((1 + 0.49) / 2, rel=0.1)
