"""The direct path's channel bend (``WholeFrameFit.curvature_s2``) sees the direct path's own channel only.

Analytic frames (tests/receive/analytic.py): paths summed directly, nothing from the project's channel code.
The bend comes from four sub-bands B/4 wide, so (i) a path the fit does not model, several 1/B after the
direct one, ripples them, and is taken out first (``wholeframe.unmodelled_paths``: the receiver does so
when the ends' depths are given); (ii) the bend a merged surface image gives is what those sub-bands read
(``wholeframe.channel_bend_s2``), not the curvature at the carrier.
"""

from __future__ import annotations

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive.frontend import FrontEnd, plan_front_end
from seamodem.receive.wholeframe import (channel_bend_s2, fit_whole_frame, srrc_spectrum,
                                         unmodelled_paths)

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
V = 0.7
FRAME = build_frame(CFG, b"bend")
PLAN = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
# weak bottom paths below the pilot fit's 0.15 of the strongest, 2.4–4.6 symbols after the direct one
WEAK = ((265e-6, 0.14), (407e-6, -0.12), (533e-6, 0.11))


def _fit(seed, paths, snr_db, delays, clean=True, clean_lags_s=()):
    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    total = int(0.5 * FS)
    t = np.arange(total) / FS
    x = np.zeros(total)
    for delay, gain in paths:
        x += received_frame(FRAME, t, t_arrival_s=ta + delay, v_mps=V, gain=gain)
    x += awgn_sigma(CFG, snr_db) * rng.standard_normal(total)
    fe = FrontEnd(PLAN)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    fit = fit_whole_frame(bb, PLAN.fs_data, 0.0, config=CFG, symbols=FRAME.symbols,
                          reference=np.ones(len(FRAME.symbols), bool), delays_s=[ta + d for d in delays],
                          v_mps=V, sound_speed_mps=C, direct_s=ta, clean=clean, clean_lags_s=clean_lags_s)
    return fit, ta


def _bend_reading(channel_paths):
    """What the sub-bands read from the channel 1 + Σ b e^{−j2π(f₀ + f)Δ} of paths (Δ, real b) (noiseless)."""
    rs = CFG.symbol_rate_hz
    f = np.linspace(-(1 + CFG.rolloff) * rs / 2, (1 + CFG.rolloff) * rs / 2, 2001)
    h = 1 + sum(b * np.exp(-2j * np.pi * (CFG.carrier_hz + f) * d) for d, b in channel_paths)
    return channel_bend_s2(f, srrc_spectrum(f, CFG.symbol_period_s, CFG.rolloff) ** 2, h)[0]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_paths_the_fit_does_not_model_leave_the_direct_paths_bend_at_its_noise(seed):
    fit, _ = _fit(seed, ((0.0, 1.0),) + WEAK, 8.0, delays=[0.0])
    assert len(fit.delays_s) == 1
    noise = float(fit.curvature_noise_s4[0])
    # taken as the direct path's channel, the weak paths bend it far beyond its noise ...
    assert abs(_bend_reading(WEAK)) ** 2 > 30 * noise
    as_is, _ = _fit(seed, ((0.0, 1.0),) + WEAK, 8.0, delays=[0.0], clean=False)
    assert abs(complex(as_is.curvature_s2[0])) ** 2 > 30 * noise
    # ... taken out of the direct path's sub-bands first, the bend is noise's (|c|²/n exponential, mean 1)
    assert abs(complex(fit.curvature_s2[0])) ** 2 < 9 * noise


def test_unmodelled_paths_explains_the_paths_a_residual_holds_and_finds_none_in_noise():
    fs = PLAN.fs_data
    n = 4096
    k = np.fft.fftfreq(n) * n
    bw = CFG.symbol_rate_hz * (1 + CFG.rolloff)
    for seed in range(4):
        rng = np.random.default_rng(seed)
        # a template shaped as the data band's pulse (SRRC), white noise at −10 dB of it per sample (the
        # correlation's σ 0.005 of a unit path)
        spec = np.fft.fft(rng.standard_normal(n) + 1j * rng.standard_normal(n))
        spec *= srrc_spectrum(k / n * fs, CFG.symbol_period_s, CFG.rolloff)
        template = np.fft.ifft(spec)
        scale = np.sqrt(np.mean(np.abs(template) ** 2) / 20)
        noise = scale * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        paths = sum(b * np.fft.ifft(spec * np.exp(-2j * np.pi * k * d * fs / n)) for d, b in WEAK)
        found_sum, found = unmodelled_paths(paths + noise, template, fs, CFG)
        # the paths 1.1–1.3/B apart overlap: one at a time, each lands up to ~0.4/B off, and what is left
        # is below the noise's 4.5 σ; together they hold all but 5–8 % of the paths' energy
        assert np.sum(np.abs(paths - found_sum) ** 2) < 0.15 * np.sum(np.abs(paths) ** 2)
        assert len(found) >= 3 and all(lag >= 1.5 / bw for lag, _ in found)
        assert unmodelled_paths(noise, template, fs, CFG)[1] == []
        # a modelled image's pulses projected out first (the direct path at −5 µs, the image at 25 µs): the
        # paths 2.4–4.8/B after it are found as well
        found_sum, found = unmodelled_paths(paths + noise, template, fs, CFG, known_lags_s=(-5e-6, 25e-6))
        assert np.sum(np.abs(paths - found_sum) ** 2) < 0.15 * np.sum(np.abs(paths) ** 2)


def test_the_bend_read_is_the_sub_bands_not_the_curvature_at_the_carrier():
    from seamodem.receive.frame import merged_image_bias_s

    # a surface image −0.9 at 33 µs, f₀δ 0.92 cycles (near the null): ln H is no parabola over the band. The
    # ends 4 m deep, 646 m apart, as the receiver has them: the image's pulses (the direct path at −bias, the
    # image at δ − bias) are projected out before the paths left in the residual are sought, whose misfit
    # otherwise reads as components out to 1.8–1.9/B (taken out from 1.5/B: the bend read 28 % off)
    image = merged_image_bias_s(646.0, 4.0, 4.0, config=CFG, sound_speed_mps=C)
    delta = image.delay_s
    assert delta == pytest.approx(33e-6, abs=0.5e-6)
    fit, _ = _fit(5, ((0.0, 1.0), (delta, -0.9)), 35.0, delays=[0.0],
                  clean_lags_s=(-image.bias_s, delta - image.bias_s))
    read = _bend_reading([(delta, -0.9)])
    z = -0.9 * np.exp(-2j * np.pi * CFG.carrier_hz * delta)
    w = z / (1 + z)
    at_carrier = -(delta**2) * w * (1 - w)
    measured = complex(fit.curvature_s2[0])
    assert abs(measured - read) < 0.1 * abs(read)
    assert abs(measured - at_carrier) > 0.3 * abs(at_carrier)


def _fading_echo_fit(seed, echoes, fitted, snr_db, **kw):
    """A frame through the direct path and ``echoes`` (lag [s], gain, fading rate [Hz] or 0), each fading one's
    gain 0.6 + 0.8 e^{j2π(rate·t + φ)} (its modulus 0.2–1.4 over a cycle); fitted with paths at ``fitted``."""
    from scipy.signal import hilbert

    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    n = int((ta + CFG.frame_duration_s + 0.05) * FS)
    t = np.arange(n) / FS
    x = received_frame(FRAME, t, t_arrival_s=ta, v_mps=V)
    for lag, gain, rate in echoes:
        e = received_frame(FRAME, t, t_arrival_s=ta + lag, v_mps=V, gain=gain)
        if rate:
            e = np.real(hilbert(e) * (0.6 + 0.8 * np.exp(2j * np.pi * (rate * t + rng.uniform()))))
        x = x + e
    x += awgn_sigma(CFG, snr_db) * rng.standard_normal(n)
    fe = FrontEnd(PLAN)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    fit = fit_whole_frame(bb, PLAN.fs_data, 0.0, config=CFG, symbols=FRAME.symbols,
                          reference=np.ones(len(FRAME.symbols), bool), delays_s=[ta + d for d in fitted],
                          v_mps=V, sound_speed_mps=C, direct_s=ta, **kw)
    i = int(np.argmin(np.abs(fit.delays_s - ta)))
    return abs(complex(fit.curvature_s2[i])) ** 2 / float(fit.curvature_noise_s4[i]), float(fit.delays_s[i] - ta)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_echo_fading_within_the_frame_leaves_the_direct_paths_bend_at_its_noise(seed):
    # an echo 0.9 at 500 µs (4.5/B: resolved over the band, not in a B/4 sub-band) whose gain turns at 1.5 Hz;
    # the fit models it. Taken out at one gain, its fading stays in the residual and bends the direct path's
    # sub-bands; segment by segment, it does not
    # (echo_misfit off: the fading's residual near the echo would be taken out as its misfit too)
    echo = ((500e-6, 0.9, 1.5),)
    bent, arrival = _fading_echo_fit(seed, echo, [0.0, 500e-6], 15.0, segment_gains=False, echo_misfit=None)
    flat, arrival_2 = _fading_echo_fit(seed, echo, [0.0, 500e-6], 15.0, echo_misfit=None)
    assert bent > 9 and flat < 9  # |c|²/noise: exponential of mean 1 on a channel without curvature
    # the arrival is the same (and right: the echo is resolved over the whole band), the bend was spurious
    assert arrival == arrival_2 and abs(arrival) * C < 1.5e-3


def test_a_cluster_fitted_as_one_echo_leaves_the_direct_paths_bend_at_its_noise():
    # two echoes 80 µs apart (0.7/B), −0.8 and 0.6, which the fit models as one path: its misfit ripples the
    # direct path's sub-bands; taken out within 2/B of the echo's lag (echo_misfit), the bend is noise's
    # (a near-cancelling pair, 0.8 and −0.7 90 µs apart, is only partly: 22–41 → 4–12 times the noise)
    cluster = ((480e-6, -0.8, 0.0), (560e-6, 0.6, 0.0))
    misfit = [_fading_echo_fit(s, cluster, [0.0, 500e-6], 15.0, echo_misfit=None)[0] for s in range(3)]
    cleaned = [_fading_echo_fit(s, cluster, [0.0, 500e-6], 15.0, echo_misfit="out")[0] for s in range(3)]
    assert np.mean(misfit) > 9 and max(cleaned) < 9
    # the receiver's default reads both and keeps the larger (without the depths, a merged image's bend may
    # be the one the misfit masked)
    larger = [_fading_echo_fit(s, cluster, [0.0, 500e-6], 15.0)[0] for s in range(3)]
    assert np.allclose(larger, np.maximum(misfit, cleaned))


def test_an_echo_the_pilot_missed_is_recalled_from_the_last_decoded_frame():
    from seamodem.receive.frame import RECALL_MIN_GAIN, with_recalled_echoes

    one_b = 1 / CFG.bandwidth_hz
    first = 0.2
    pilot = np.array([first, first + 322e-6, first + 1.2e-3])
    # the last decoded frame: 380 µs (within 1/B of the pilot's 322), 495 (beyond), a weak one, and one
    # nearer the direct path than 1.5/B (a merged echo's misfit, not a path)
    lags = np.array([380e-6, 495e-6, 2.0e-3, 1.2 * one_b])
    gains = np.array([0.4, 0.96, RECALL_MIN_GAIN / 2, 0.5])
    out = with_recalled_echoes(pilot, first, (lags, gains), CFG)
    assert np.allclose(out, np.sort(np.append(pilot, first + 495e-6)))
    assert np.array_equal(with_recalled_echoes(pilot, first, None, CFG), pilot)
