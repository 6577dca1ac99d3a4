"""A surface image merged with the direct path (Lloyd's mirror at long range, the ends near the surface).

The image, −0.9 of the direct path and Δ ≈ 18 µs behind it (Δ·B ≈ 0.16: one peak), makes the direct
path's channel 1 + b e^{−j2πfΔ}: the arrival is biased by Re(w)·Δ, w = b e/(1 + b e). One frame cannot
tell that bias from the arrival (its channel bends by 2–3 of its noise σ at 20 dB), but the bend's bound
(``WholeFrameFit.tilt_delay_s``: √|d²ln H/df²|/2π, whatever Δ, for |b| ≤ 1) pooled over frames
(``frame._CurvaturePool``) can. Before the bound and the pool: 12 mm off with σ 0.3 mm (40σ). Analytic
frames (tests/receive/analytic.py), nothing from the project's channel code.
"""

from __future__ import annotations

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.receive import Emissions, Receiver, ReceiverSettings

from analytic import multipath_recording

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
V = 0.6


@pytest.mark.parametrize("cycles", [0.0, 0.25, 0.5])
def test_the_bias_of_a_weaker_merged_echo_is_within_the_curvature_bound(cycles):
    # the inequality itself, on the channel 1 + b e^{−j2πfΔ} (|b| ≤ 1, Δ up to 1/B), no receiver involved:
    # group-delay error at the band's centre −(1/2π) d arg H/df against √|d² ln H/df²| / 2π
    rng = np.random.default_rng(7)
    for _ in range(2000):
        b = rng.uniform(0.05, 1.0) * np.exp(2j * np.pi * (cycles + rng.uniform(-0.1, 0.1)))
        delta = rng.uniform(1e-6, 1.0 / CFG.bandwidth_hz)
        h = 1e-3 / delta  # [Hz]: a step small against 1/Δ
        f = np.array([-h, 0.0, h])
        ln_h = np.log(1 + b * np.exp(-2j * np.pi * f * delta))
        bias = -np.imag(ln_h[2] - ln_h[0]) / (2 * h) / (2 * np.pi)
        curv = (ln_h[2] - 2 * ln_h[1] + ln_h[0]) / h**2
        assert abs(bias) <= np.sqrt(abs(curv)) / (2 * np.pi) * (1 + 1e-6), (b, delta, bias)


def _recording(seed: int, *, n_frames: int, snr_db: float, delta_s: float, image_gain: float, **settings):
    rng = np.random.default_rng(seed)
    payloads = [f"mirror {k}".encode() for k in range(n_frames)]
    t_emit = 0.1 + np.arange(n_frames) * 1.0
    # a track closing at V (a random start: the same draws as before, the first one used), which the
    # records' track check (RecordLookahead) finds consistent
    tof = 0.55 + rng.uniform(0, 0.002, n_frames)[0] - V * (t_emit - t_emit[0]) / C
    x = multipath_recording(CFG, payloads, t_emit, tof, [(0.0, 1.0), (delta_s, image_gain)], v_mps=V,
                            snr_db=snr_db, rng=rng)
    rx = Receiver(CFG, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=True, **settings),
                  payloads=payloads)
    records = {r.frame_index: r for r in rx.run([x], fs=FS)}
    assert sorted(records) == list(range(n_frames))
    return records, tof


@pytest.mark.parametrize("lookahead", [0, 5])
def test_a_merged_surface_image_is_covered_once_the_pool_has_frames(lookahead):
    # f0·Δ = 1/2 cycle: with the surface's −1, b = +0.9 — the image adds to the path, flattest bend, largest
    # bias for it (w ≈ 0.47: 0.47·Δ ≈ 12.6 mm)
    delta = 0.5 / CFG.carrier_hz
    records, tof = _recording(8101, n_frames=8, snr_db=12.0, delta_s=delta, image_gain=-0.9,
                              lookahead_frames=lookahead)
    errors = np.array([records[k].range_m - C * tof[k] for k in range(8)])
    sigmas = np.array([records[k].sigma_range_m for k in range(8)])
    # the bias is there, and consistent (what a filter cannot average away)
    assert np.all(errors > 0.006), errors
    # at 12 dB, from the second decoded frame on the pool stands out of its noise: every arrival within 3σ;
    # the first is covered only when its record waits for later frames (the default; a live receiver's is
    # 32σ off)
    covered = slice(0, 8) if lookahead else slice(1, 8)
    assert np.all(np.abs(errors[covered]) <= 3 * sigmas[covered]), (errors, sigmas)
    if not lookahead:
        assert abs(errors[0]) > 3 * sigmas[0], (errors, sigmas)
    # and σ is the bias's scale, not a blanket: at most 6 times the error
    assert np.all(sigmas <= 6 * np.abs(errors)), (errors, sigmas)


@pytest.mark.parametrize("snr_db, largest", [(20.0, 0.002), (30.0, 0.001)])
def test_without_an_image_the_pool_stays_silent(snr_db, largest):
    # the same frames on one path: the arrival's σ stays at the fit's (sub-millimetre at 20 and 30 dB). Each
    # sub-band's sum is its energy share times the channel, and the shares of the equal-energy split (whole
    # FFT bins) differ by ±0.2 % with the frame's symbols: read as the channel, they bent it by ±3e-11 s²,
    # which pooled gave the range at 30 dB a σ of 3.4 mm for errors of 0.05 mm
    records, tof = _recording(8102, n_frames=8, snr_db=snr_db, delta_s=0.0, image_gain=0.0)
    errors = np.array([records[k].range_m - C * tof[k] for k in range(8)])
    sigmas = np.array([records[k].sigma_range_m for k in range(8)])
    assert np.all(np.abs(errors) <= 3 * sigmas), (errors, sigmas)
    assert np.all(sigmas < largest), sigmas


def test_frames_read_from_the_tone_share_the_pooled_bend(monkeypatch):
    # frames whose whole-frame fit is missing (decisions not usable, a fit that failed) fall back to the
    # tone for v_r and to the pilot for the arrival, which the merged image biases alike: before, their
    # σ was the pilot's alone (0.3 mm at 20 dB against a 12 mm bias, 40σ)
    from seamodem.receive.frame import FrameMeasurer

    whole_frame = FrameMeasurer._whole_frame
    late = 5.0  # [s]: frames heard after it get no fit

    def fit_early_frames_only(self, m, dec, bb, t0_s, fs, image=None):
        return whole_frame(self, m, dec, bb, t0_s, fs, image) if m.pilot.t_start_s < late else None

    monkeypatch.setattr(FrameMeasurer, "_whole_frame", fit_early_frames_only)
    delta = 0.5 / CFG.carrier_hz
    records, tof = _recording(8101, n_frames=8, snr_db=20.0, delta_s=delta, image_gain=-0.9, lookahead_frames=0)
    tone_rows = [k for k in range(8) if records[k].v_r_source == "tone"]
    assert tone_rows == [5, 6, 7], [records[k].v_r_source for k in range(8)]
    errors = np.array([records[k].range_m - C * tof[k] for k in tone_rows])
    sigmas = np.array([records[k].sigma_range_m for k in tone_rows])
    assert np.all(errors > 0.006), errors
    assert np.all(np.abs(errors) <= 3 * sigmas), (errors, sigmas)
    assert np.all(sigmas <= 6 * np.abs(errors)), (errors, sigmas)


def _fit(bend: complex, noise: float):
    from types import SimpleNamespace

    # what the pool reads of a WholeFrameFit: c itself and its noise expectation
    return SimpleNamespace(curvature_noise_s4=np.array([noise]), curvature_s2=np.array([bend]))


def _noisy_bend(rng, bend: complex, noise: float) -> complex:
    return bend + np.sqrt(noise / 2) * complex(rng.standard_normal(), rng.standard_normal())


def test_a_steady_bend_below_one_frames_noise_adds_up_coherently():
    from seamodem.receive.frame import CURVATURE_POOL_FRAMES, _CurvaturePool

    rng = np.random.default_rng(11)
    noise = 1e-20  # [s⁴]
    bend = 0.9 * np.sqrt(noise) * np.exp(0.7j)  # |c|² at 0.8 of one frame's noise expectation
    counted_coherent = counted_powers = 0
    for _ in range(200):
        pool = _CurvaturePool()
        for _ in range(CURVATURE_POOL_FRAMES):
            pool.add_fit(_fit(_noisy_bend(rng, bend, noise), noise), 0)
        counted_coherent += pool.coherent_s4() > 0
        counted_powers += pool.standing_mean(3.0) > 0
    # 10 frames: |c̄|² about 9 times its noise against a threshold of 4.6 (counted in 88 % of 200 pools);
    # the powers' mean 2.5 of its σ against 3 (22 %)
    assert counted_coherent >= 150, counted_coherent
    assert counted_powers <= 70, counted_powers
    # counted, the bound is the bend's: (|c|²)^(1/4)/√3 within a factor 1.5 on a typical pool
    pool = _CurvaturePool()
    for _ in range(CURVATURE_POOL_FRAMES):
        pool.add_fit(_fit(bend, noise), 0)  # noiseless draws: the mean is the bend
    assert pool.delay_s == pytest.approx((abs(bend) ** 2 - noise / CURVATURE_POOL_FRAMES) ** 0.25 / np.sqrt(3),
                                         rel=1e-9)


def test_noise_alone_rarely_counts_and_a_turning_bend_still_does():
    from seamodem.receive.frame import CURVATURE_POOL_FRAMES, _CurvaturePool

    rng = np.random.default_rng(12)
    noise = 1e-20
    false_alarms = 0
    n_pools = 20000
    for _ in range(n_pools):
        pool = _CurvaturePool()
        for _ in range(CURVATURE_POOL_FRAMES):
            pool.add_fit(_fit(_noisy_bend(rng, 0.0, noise), noise), 0)
        false_alarms += pool.coherent_s4() > 0
    # exponential |c̄|²/floor under noise: beyond ln(100) once in 100 (binomial 3σ: 158 … 242 in 20000)
    assert 158 <= false_alarms <= 242, false_alarms
    # a bend whose phase turns from frame to frame (a fading echo) cancels in the coherent mean; the
    # powers' mean still counts it
    pool = _CurvaturePool()
    for k in range(CURVATURE_POOL_FRAMES):
        pool.add_fit(_fit(_noisy_bend(rng, 3 * np.sqrt(noise) * np.exp(2j * np.pi * k / 5), noise), noise), 0)
    assert pool.standing_mean(3.0) > 0
    assert pool.delay_s > 0


def test_a_bound_once_counted_holds_over_the_standing_pools_frames_at_a_steady_range():
    # a bend near the tests' thresholds (a merged image at 1 km without the depths) counts on some frames and
    # not on their neighbours: with ``hold``, what was counted after each of the last FADE_POOL_FRAMES fits
    # at a steady range still counts; a range beyond the steady share ends it
    from seamodem.receive.frame import FADE_POOL_FRAMES, _CurvaturePool, steady_bend_range_share

    rng = np.random.default_rng(13)
    noise = 1e-20
    share = steady_bend_range_share(CFG)
    plain, held = _CurvaturePool(share), _CurvaturePool(share, hold=FADE_POOL_FRAMES)
    ranges = [1000.0 + 2.0 * k for k in range(24)] + [1200.0 + 2.0 * k for k in range(6)]
    bounds_plain, bounds_held = [], []
    for k, r in enumerate(ranges):
        # a fading bend 1.2 times the noise's root (its phase turning: the coherent mean does not add it)
        bend = _noisy_bend(rng, 1.2 * np.sqrt(noise) * np.exp(2j * np.pi * k / 5), noise)
        for pool, out in ((plain, bounds_plain), (held, bounds_held)):
            pool.add_fit(_fit(bend, noise), 0, range_m=r)
            out.append(pool.delay_s)
    bounds_plain, bounds_held = np.array(bounds_plain), np.array(bounds_held)
    for k in range(len(ranges)):
        steady = [j for j in range(max(0, k - FADE_POOL_FRAMES + 1), k + 1)
                  if abs(ranges[j] - ranges[k]) <= share * ranges[k]]
        assert bounds_held[k] == pytest.approx(bounds_plain[steady].max(), rel=1e-12)
    # the case it is for: frames the plain pool leaves at 0 next to frames it counted
    lapsed = (bounds_plain[:24] == 0) & (bounds_held[:24] > 0)
    assert lapsed.any() and (bounds_plain[:24] > 0).any(), bounds_plain
    # after the jump to 1.2 km the frames before it no longer count
    assert bounds_held[24] == bounds_plain[24]


def test_waiting_for_later_frames_changes_only_the_sigmas():
    import dataclasses

    delta = 0.5 / CFG.carrier_hz
    now, _ = _recording(8103, n_frames=6, snr_db=12.0, delta_s=delta, image_gain=-0.9, lookahead_frames=0)
    held, _ = _recording(8103, n_frames=6, snr_db=12.0, delta_s=delta, image_gain=-0.9, lookahead_frames=5)
    grew = 0
    for k in range(6):
        assert held[k].sigma_range_m >= now[k].sigma_range_m  # (the v_r σ's fading term is settled, up or down)
        grew += held[k].sigma_range_m > now[k].sigma_range_m
        assert dataclasses.replace(held[k], sigma_range_m=now[k].sigma_range_m,
                                   sigma_v_r_mps=now[k].sigma_v_r_mps) == now[k]
    assert grew >= 1


def _rew_bias(delta_s: float, rho: float, theta: float) -> float:
    """The closed form of a weak merge (δ·B ≪ 1): the group delay Re(w)·δ, w = z/(1 + z)."""
    z = -rho * np.exp(-1j * theta)
    return float((z / (1 + z)).real * delta_s)


def test_the_predicted_bias_is_the_closed_form_of_a_weak_merge():
    from seamodem.receive.frame import (DEPTH_SIGMA_M, SURFACE_REFLECTION, WAVE_AMPLITUDE_M,
                                        merged_image_bias_s, merged_image_delay_s)

    # ends 3 m deep, 672 m apart: δ = 17.9 µs (δ·B = 0.16), f₀δ = 1/2 cycle: the image adds to the path,
    # farthest from the null
    zb = zv = 3.0
    r = 2 * zb * zv / (C * 0.5 / CFG.carrier_hz)
    delta = merged_image_delay_s(r, zb, zv, config=CFG, sound_speed_mps=C)
    assert CFG.carrier_hz * delta == pytest.approx(0.5, abs=0.01)
    bias, sigma = merged_image_bias_s(r, zb, zv, config=CFG, sound_speed_mps=C)[:2]
    # the closed form Re(w)·δ' (the group delay, not the matched filter's peak) over a fine grid of what is
    # not known: the waves move the image's path by ±2·a·sin θ (its delay and phase together), the depths'
    # error δ ∝ z_b·z_v by two of its σ, and ρ
    wave = 2 * WAVE_AMPLITUDE_M * (zb + zv) / r / C + 2 * delta * DEPTH_SIGMA_M * np.hypot(1 / zb, 1 / zv)
    closed = np.array([_rew_bias(d, rho, 2 * np.pi * CFG.carrier_hz * d)
                       for d in delta + wave * np.linspace(-1, 1, 201)
                       for rho in np.linspace(*SURFACE_REFLECTION, 21)])
    assert bias == pytest.approx(np.mean(closed), abs=0.05 * delta), (bias, np.mean(closed))
    assert sigma == pytest.approx(np.std(closed), rel=0.15), (sigma, np.std(closed))
    assert sigma < 0.2 * delta


def test_near_the_null_the_prediction_says_it_does_not_know():
    from seamodem.receive.frame import merged_image_bias_s, merged_image_delay_s

    # f₀δ a whole number of cycles: the paths cancel, and the arrival's peak is anywhere within ~δ
    zb = 4.0
    r = 2 * zb * zb / (C * 1.0 / CFG.carrier_hz)  # δ = 1/f₀ = 35.7 µs (δ·B = 0.32)
    delta = merged_image_delay_s(r, zb, zb, config=CFG, sound_speed_mps=C)
    assert CFG.carrier_hz * delta == pytest.approx(1.0, abs=0.01)
    sigma = merged_image_bias_s(r, zb, zb, config=CFG, sound_speed_mps=C).sigma_s
    assert sigma > 0.5 * delta
    # a resolved image, or no geometry: nothing predicted
    for none in (merged_image_bias_s(300.0, 10.0, 10.0, config=CFG, sound_speed_mps=C),
                 merged_image_bias_s(float("nan"), 3.0, 3.0, config=CFG, sound_speed_mps=C)):
        assert none.bias_s == none.sigma_s == none.re_w == none.wave_doppler_mps == 0.0


def test_with_the_depths_the_merged_image_is_taken_out_of_the_range():
    from seamodem.receive.frame import merged_image_delay_s

    # ends 3 m deep, 825 m apart (tof 0.55 s): the image −0.9 of the direct path, δ = 14.5 µs behind
    zb = zv = 3.0
    delta = merged_image_delay_s(C * 0.55, zb, zv, config=CFG, sound_speed_mps=C)
    kwargs = dict(n_frames=6, snr_db=12.0, delta_s=delta, image_gain=-0.9)
    blind, tof = _recording(8104, **kwargs)
    told, _ = _recording(8104, beacon_depth_m=zb, vehicle_depth_m=zv, **kwargs)
    err_blind = np.array([blind[k].range_m - C * tof[k] for k in range(6)])
    err = np.array([told[k].range_m - C * tof[k] for k in range(6)])
    sigmas = np.array([told[k].sigma_range_m for k in range(6)])
    # without the depths the range is long by about 0.45 δ·c (9.8 mm), frame after frame
    assert np.all(err_blind > 0.3 * delta * C), err_blind
    # with them, the bias is predicted from the geometry and taken out: within 3σ, σ at the fit's scale
    # (not the image's delay, 22 mm, which the σ was before)
    assert np.all(np.abs(err) <= 3 * sigmas), (err, sigmas)
    assert np.all(np.abs(err) < 0.1 * delta * C), err
    assert np.all(sigmas < 0.15 * delta * C), sigmas


def test_the_bend_a_taken_out_image_explains_is_not_counted_again():
    from types import SimpleNamespace

    from seamodem.receive.frame import CURVATURE_POOL_FRAMES, MergedImage, _CurvaturePool, channel_shape_delay_s

    rng = np.random.default_rng(13)
    noise = 1e-20  # [s⁴]
    image = MergedImage(bias_s=7e-6, sigma_s=2e-6, curvature_s2=complex(-4e-10, 1e-10), curvature_var_s4=noise)
    explained, more = _CurvaturePool(), _CurvaturePool()
    blind = _CurvaturePool()
    for _ in range(CURVATURE_POOL_FRAMES):
        bend = _noisy_bend(rng, image.curvature_s2, noise)
        explained.add_fit(_fit(bend, noise), 0, image)
        blind.add_fit(_fit(bend, noise), 0)
        more.add_fit(_fit(bend + 3e-10, noise), 0, image)  # another bend besides the image's
    assert blind.delay_s > 0  # the image's bend, counted when nothing explains it
    assert explained.delay_s == 0.0
    assert more.delay_s > 0
    # the frame's own tilt the same way (its noise beyond 3σ, the image's variance added to it)
    fit = SimpleNamespace(curvature_s2=np.array([image.curvature_s2]), curvature_noise_s4=np.array([noise]),
                          tilt_delay_s=np.array([5e-6]))
    assert channel_shape_delay_s(fit, 0) == 5e-6
    assert channel_shape_delay_s(fit, 0, image=image) == 0.0
    fit.curvature_s2 = np.array([image.curvature_s2 + 1e-9])
    assert channel_shape_delay_s(fit, 0, image=image) == pytest.approx(
        (1e-18 - 9 * 2 * noise) ** 0.25 / np.sqrt(3), rel=1e-9)


def test_an_image_adding_to_the_path_moves_the_phase_where_the_amplitude_stays_flat():
    from seamodem.receive.frame import MergedImage, image_doppler_sigma_mps

    to_mps = C / (2 * np.pi * CFG.carrier_hz)
    # w = 0.49 + 0.02j (f₀δ ≈ ½): a Doppler Δv of the image moves the phase rate by 0.49·Δv and the
    # log-amplitude rate by 0.02·Δv. The fading term reads the amplitude's 0.02·Δv as a phase rate; the
    # image's term brings it to 0.49·Δv, up to what the waves can give (0.49 × 11 mm/s)
    image = MergedImage(7e-6, 2e-6, 0j, 0.0, re_w=0.49, im_w=0.02, wave_doppler_mps=0.011)
    dv = 0.004  # [m/s]
    amp_rate = 0.02 * dv / to_mps
    got = image_doppler_sigma_mps(image, amp_rate, CFG, sound_speed_mps=C)
    assert np.hypot(got, 0.02 * dv) == pytest.approx(0.49 * dv, rel=1e-9)
    # a faster amplitude than the waves allow: the waves' bound
    got = image_doppler_sigma_mps(image, 100 * amp_rate, CFG, sound_speed_mps=C)
    assert np.hypot(got, 2 * dv) == pytest.approx(max(0.49 * 0.011, 2 * dv), rel=1e-9)
    # w nearly imaginary: the amplitude shows the image's Doppler at least as much as the phase, nothing to add
    image = MergedImage(7e-6, 2e-6, 0j, 0.0, re_w=0.1, im_w=0.5, wave_doppler_mps=0.011)
    assert image_doppler_sigma_mps(image, amp_rate, CFG, sound_speed_mps=C) == 0.0


def test_a_bend_far_below_one_frames_noise_is_counted_on_a_long_steady_recording():
    # a merged image at 5 dB bends one frame's channel by a quarter of its noise σ: ten frames cannot show it
    # (|c̄|² ≈ 10/16 of its floor), 120 frames at the same range can (7.5 times it, against 4.6); the range
    # moving beyond B/(8 f₀) of the newest frame's leaves the older frames out (the bend's phase turns there)
    from seamodem.receive.frame import (CURVATURE_POOL_FRAMES, CURVATURE_POOL_MAX_FRAMES, _CurvaturePool,
                                        steady_bend_range_share)

    rng = np.random.default_rng(13)
    noise = 1e-20
    bend = 0.25 * np.sqrt(noise) * np.exp(1.1j)
    share = steady_bend_range_share(CFG)
    counted_short = counted_long = counted_moving = counted_noise = 0
    for _ in range(100):
        short, long, moving, quiet = (_CurvaturePool(share) for _ in range(4))
        for k in range(CURVATURE_POOL_MAX_FRAMES):
            fit = _fit(_noisy_bend(rng, bend, noise), noise)
            long.add_fit(fit, 0, range_m=900.0 + 0.01 * k)
            moving.add_fit(fit, 0, range_m=900.0 + 2.0 * k)  # 240 m over the run: 10 % at its start
            quiet.add_fit(_fit(_noisy_bend(rng, 0.0, noise), noise), 0, range_m=900.0)
            if k < CURVATURE_POOL_FRAMES:
                short.add_fit(fit, 0, range_m=900.0)
        counted_short += short.coherent_s4() > 0
        counted_long += long.coherent_s4() > 0
        counted_moving += moving.coherent_s4() > 0
        counted_noise += quiet.coherent_s4() > 0
    # (100 runs: 5 short pools counted, 82 long, 20 moving, 1 of noise alone)
    assert counted_short <= 20, counted_short
    assert counted_long >= 70, counted_long
    # moving: only the frames within 4 % of the newest range (≈ 19 of them) pool with it
    assert counted_moving < counted_long - 30, (counted_moving, counted_long)
    # noise alone: two tests of 1 % each
    assert counted_noise <= 7, counted_noise
    # without ranges (or without the share) the pool is the last ten frames, as before
    plain = _CurvaturePool()
    for _ in range(CURVATURE_POOL_MAX_FRAMES):
        plain.add_fit(_fit(bend, noise), 0, range_m=900.0)  # noiseless: |c̄|² = 1/16 of one frame's noise
    assert plain.coherent_s4() == 0.0
    steady = _CurvaturePool(share)
    for _ in range(CURVATURE_POOL_MAX_FRAMES):
        steady.add_fit(_fit(bend, noise), 0, range_m=900.0)
    assert steady.coherent_s4() == pytest.approx(abs(bend) ** 2 - noise / CURVATURE_POOL_MAX_FRAMES, rel=1e-9)


def _track_record(k: int):
    import math

    from seamodem.receive.records import MeasurementRecord

    t = 0.2 + k + 0.6  # arrival at 900 m, closing at 1 m/s
    r = 900.0 - 1.0 * t
    return MeasurementRecord(frame_index=k, t_emit_s=t - r / C, t_arrival_s=t, tof_s=r / C, range_m=r, v_r_mps=1.0,
                             snr_db=5.0, v_r_tone_eq9_mps=math.nan, v_r_bank_mps=1.0, detection_z=100.0,
                             detection_rho=0.5, sigma_range_m=0.001, sigma_v_r_mps=0.001,
                             sigma_v_r_bank_mps=0.01, tone_c_n0_dbhz=60.0)


def _lookahead(frames: int):
    from types import SimpleNamespace

    from seamodem.receive.frame import RecordLookahead

    # what the look-ahead reads of its measurer: the pool's bound changes between pushes
    meas = SimpleNamespace(config=CFG, settings=SimpleNamespace(sound_speed_mps=C), pooled_merge_delay_s=0.0,
                           pooled_fade_rate_hz=0.0, last_shape=(0.0, C, None, 0.0))
    return meas, RecordLookahead(meas, frames)


@pytest.mark.parametrize("n_records, counts_from", [(14, 7), (6, 5)])
def test_a_files_first_records_wait_for_the_curvature_pool(n_records, counts_from):
    # the pool's coherent mean counts a surface image's bend from the 8th frame on (a far recording at 6 dB:
    # its second frame, 18 mm off, had been given out with σ 1.2 mm five frames after it, before the pool
    # counted): a file's records wait until ten frames are in (or the stream ends), then take its bound
    import dataclasses

    from seamodem.receive.frame import CURVATURE_POOL_FRAMES

    meas, look = _lookahead(5)
    bound = 10e-6
    out = []
    for k in range(n_records):
        if k == counts_from:
            meas.pooled_merge_delay_s = bound
        out += look.push(_track_record(k))
        # nothing is given out before the pool has had its frames (or the stream its end)
        assert out == [] or k + 1 >= CURVATURE_POOL_FRAMES
    out += look.flush()
    assert [r.frame_index for r in out] == list(range(n_records))
    for r in out:
        assert r.sigma_range_m == pytest.approx(np.hypot(0.001, C * bound), rel=1e-9)
        assert dataclasses.replace(r, sigma_range_m=0.001) == _track_record(r.frame_index)
    # a live receiver (no look-ahead) gives each record out at once, as measured
    meas, live = _lookahead(0)
    assert live.push(_track_record(0)) == [_track_record(0)]


@pytest.mark.parametrize("range_m, z_b, z_v", [(800.0, 3.0, 3.0), (600.0, 1.5, 5.0), (700.0, 2.0, 4.0),
                                                (400.0, 2.0, 2.0)])
def test_the_image_a_bend_shows_has_the_geometrys_doppler_term(range_m, z_b, z_v):
    # without the depths, the Doppler term of the image a pooled bend shows (bend_image) against the one the
    # depths give (merged_image_bias_s), for images away from the null (|Re w| ≈ 0.47): the bend of the
    # geometry's image, pooled (its bound's σ |c|^½/√3), gives the same term within the unknown phase's
    # and depths' share (measured 0.77–0.92 of it)
    from seamodem.receive.frame import bend_image, merged_image_bias_s

    image = merged_image_bias_s(range_m, z_b, z_v, config=CFG, sound_speed_mps=C)
    assert image.re_w > 0.4
    pooled = abs(image.curvature_s2) ** 0.5 / np.sqrt(3)
    shown = bend_image(pooled, range_m, config=CFG, sound_speed_mps=C)
    assert shown.from_bend and shown.bias_s == 0.0 and shown.curvature_s2 == 0
    ratio = (shown.re_w * shown.wave_doppler_mps) / (image.re_w * image.wave_doppler_mps)
    assert 0.6 < ratio < 1.5, ratio
    assert shown.delay_s == pytest.approx(image.delay_s, rel=0.3)


def test_no_bend_no_image_and_its_delay_stays_merged():
    from seamodem.receive.frame import bend_image

    assert bend_image(0.0, 800.0, config=CFG, sound_speed_mps=C) is None
    assert bend_image(5e-6, float("nan"), config=CFG, sound_speed_mps=C) is None
    # a bend bound far beyond a merged echo's: the delay stops at the resolution 1/B
    wide = bend_image(1e-3, 800.0, config=CFG, sound_speed_mps=C)
    assert wide.delay_s == pytest.approx(1 / CFG.bandwidth_hz)


def test_in_a_thin_waveguide_a_bend_the_noise_hides_still_counts():
    # without the depths, at low SNR, a merged image's bend (second order in its delay) stays below the pooled
    # noise while its bias (first order) is several times the arrival's σ: where the fits show a waveguide thin
    # against the range, the bound is that of the largest steady bend the coherent mean would not count
    from seamodem.receive.frame import _COHERENT_THRESHOLD, CURVATURE_POOL_FRAMES, _CurvaturePool

    rng = np.random.default_rng(14)
    noise = np.linspace(0.5, 1.5, CURVATURE_POOL_FRAMES) * 1e-19
    thin, plain = _CurvaturePool(), _CurvaturePool()
    bounds = []
    for k in range(CURVATURE_POOL_FRAMES):
        bend = _noisy_bend(rng, 0.0, noise[k])
        thin.add_fit(_fit(bend, noise[k]), 0, thin=True)
        plain.add_fit(_fit(bend, noise[k]), 0)
        bounds.append(thin.delay_s)
        floor = 1.0 / np.sum(1.0 / noise[: k + 1])
        if plain.delay_s == 0:  # nothing counted: the hidden bend's bound, its floor the frames' so far
            assert thin.delay_s == pytest.approx((_COHERENT_THRESHOLD * floor) ** 0.25 / np.sqrt(3), rel=1e-9)
        assert thin.delay_s >= plain.delay_s
        assert thin.shown_delay_s == plain.delay_s  # the image's Doppler reads the counted bends alone
    # the bound shrinks as the frames add up (the floor as 1/K, the bound as K^(-1/4))
    assert bounds[-1] < 0.7 * bounds[0]
    # a fit or two of ten in a thin waveguide is not one: the majority of the pooled frames must be
    mixed = _CurvaturePool()
    for k in range(CURVATURE_POOL_FRAMES):
        mixed.add_fit(_fit(_noisy_bend(rng, 0.0, noise[k]), noise[k]), 0, thin=k < 2)
    assert mixed.hidden_s4() == 0.0


def test_a_thin_waveguide_is_a_near_echo_travelling_with_the_direct_path():
    from types import SimpleNamespace

    from seamodem.receive.frame import thin_waveguide

    def fit(lag_s, gain, dv, sigma_v=0.005):
        return SimpleNamespace(delays_s=np.array([0.0, lag_s]), amplitudes=np.array([1.0, gain * np.exp(1j)]),
                               v_mps=np.array([0.5, 0.5 + dv]), sigma_v_mps=np.array([0.003, sigma_v]),
                               sigma_delay_s=np.array([1e-6, 1e-6]))

    one_b = 1 / CFG.bandwidth_hz
    assert thin_waveguide(fit(2.2 * one_b, 0.4, 0.01), 0, CFG)  # the far family: a bottom image 250 µs behind
    assert not thin_waveguide(fit(4e-3, 0.9, 0.01), 0, CFG)  # a steep channel's surface echo, ms behind
    assert not thin_waveguide(fit(2.2 * one_b, 0.4, 0.3), 0, CFG)  # near, but not grazing: its own Doppler
    assert thin_waveguide(fit(2.2 * one_b, 0.4, 0.3, sigma_v=0.1), 0, CFG)  # ... unless its Doppler is that vague
    assert not thin_waveguide(fit(2.2 * one_b, 0.05, 0.0), 0, CFG)  # a fit's weak path is its noise
