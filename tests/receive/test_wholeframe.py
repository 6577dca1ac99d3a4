"""Whole-frame path-resolved Doppler (receive/wholeframe.py) and impulse blanking (receive/impulse.py)
on analytic frames: paths summed directly, each its own exactly time-scaled copy of the transmitted
passband (tests/receive/analytic.py), clicks written at known positions."""

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive.frontend import FrontEnd, plan_front_end
from seamodem.receive.impulse import ImpulseBlanker, blank_impulses
from seamodem.receive.wholeframe import fit_whole_frame, known_signal_velocity_crlb_mps

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
FRAME = build_frame(CFG, b"whole frame")
V = 1.8
# deep water: a surface and a bottom echo 2 and 3.5 ms late, 5 and 9 cm/s slower than the direct path
PATHS = ((0.0, 1.0, 0.0), (2.0e-3, -0.8, -0.05), (3.5e-3, 0.6, -0.09))


def _received(seed, snr_db, clicks=0):
    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    total = int(0.5 * FS)
    t = np.arange(total) / FS
    x = np.zeros(total)
    for delay, gain, dv in PATHS:
        x += received_frame(FRAME, t, t_arrival_s=ta + delay, v_mps=V + dv, gain=gain)
    sigma = awgn_sigma(CFG, snr_db)
    x += sigma * rng.standard_normal(total)
    for k in rng.integers(int(0.1 * FS), int(0.45 * FS), clicks):
        # a snapping-shrimp-like click: a 0.1 ms damped wideband burst, 30 dB above the noise floor
        n = np.arange(40)
        x[k : k + 40] += 31.6 * sigma * np.exp(-n / 10) * np.cos(2 * np.pi * 0.3 * n + rng.uniform(0, 6.3))
    return x, ta


def _fit(x, ta):
    plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
    fe = FrontEnd(plan)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    return fit_whole_frame(
        bb, plan.fs_data, 0.0, config=CFG, symbols=FRAME.symbols, reference=np.ones(len(FRAME.symbols), bool),
        delays_s=[ta + d for d, _, _ in PATHS], v_mps=V + 0.05, sound_speed_mps=C,
    )


def test_each_paths_doppler_within_its_bound():
    truth = np.array([V + dv for _, _, dv in PATHS])
    errors, crlbs, sigmas = [], [], []
    for seed in range(4):
        fit = _fit(*_received(seed, 12.0))
        errors.append(fit.v_mps - truth)
        crlbs.append(fit.crlb_v_mps)
        sigmas.append(fit.sigma_v_mps)
    errors, crlbs, sigmas = map(np.array, (errors, crlbs, sigmas))
    # every path, every frame within 3.5 of its own σ, and σ never below the CRLB
    assert np.all(np.abs(errors) <= 3.5 * sigmas)
    assert np.all(sigmas >= crlbs)
    # RMS over 4 frames near the bound: 2× leaves room for the χ² scatter of 4 samples
    assert np.all(np.sqrt(np.mean(errors**2, axis=0)) <= 2.0 * np.mean(crlbs, axis=0))
    # the direct path's bound at 12 dB is about half a mm/s (SPEC §6: 0.5 mm/s at 10 dB, all power)
    assert 2e-4 < np.mean(crlbs[:, 0]) < 8e-4


def test_each_paths_delay_from_a_perturbed_start_within_its_sigma():
    # the pilot fit's delays are off by a few µs: the data-aided timing over the whole frame
    # brings each path back within its σ, and the direct path's σ is below the pilot's bound
    from seamodem.receive.bounds import delay_crlb_s

    rng = np.random.default_rng(9)
    errors, sigmas = [], []
    for seed in range(4):
        x, ta = _received(seed, 12.0)
        truth = np.array([ta + d for d, _, _ in PATHS])
        plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
        fe = FrontEnd(plan)
        bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
        fit = fit_whole_frame(
            bb, plan.fs_data, 0.0, config=CFG, symbols=FRAME.symbols, reference=np.ones(len(FRAME.symbols), bool),
            delays_s=truth + rng.normal(0, 5e-6, len(truth)), v_mps=V + 0.05, sound_speed_mps=C,
        )
        errors.append(fit.delays_s - truth)
        sigmas.append(fit.sigma_delay_s)
    errors, sigmas = np.array(errors), np.array(sigmas)
    assert np.all(np.abs(errors) <= 3.5 * sigmas)
    assert np.all(sigmas[:, 0] < float(delay_crlb_s(CFG, 12.0)))


def test_known_signal_bound_is_the_tone_bound_with_the_data_band():
    # SPEC §6: C/N0 = R·Es/N0; 1856 symbols (0.29 s) at Es/N0 = 10 dB → c/f0·√(3/(2π²·64000·0.29³))
    sigma = known_signal_velocity_crlb_mps(CFG, 10.0, 1856, sound_speed_mps=C)
    expected = C / CFG.carrier_hz * np.sqrt(3 / (2 * np.pi**2 * 64000 * (1856 / 6400) ** 3))
    assert sigma == pytest.approx(expected, rel=1e-12)


def test_clicks_at_known_positions_do_not_move_the_estimate_beyond_its_sigma():
    x, ta = _received(7, 12.0)
    clean = _fit(x, ta)
    xc, _ = _received(7, 12.0, clicks=60)  # same noise, 200 clicks per second over 0.3 s
    raw = _fit(xc, ta)
    blanked, fraction = blank_impulses(xc)
    fit = _fit(blanked, ta)
    # 60 clicks blanked while above 2.5σ and as long again (≈ 50 samples each) in 48 000 samples: at most 72 each
    assert 0 < fraction <= 60 * 72 / len(xc)
    # blanked: within the clean frame's σ of the clean estimate, for the direct path
    assert abs(fit.v_mps[0] - clean.v_mps[0]) <= clean.sigma_v_mps[0]
    # without blanking the clicks cost (what the blanker is for): a larger σ
    assert raw.sigma_v_mps[0] > 1.5 * fit.sigma_v_mps[0]



def test_pilot_noise_excess_sees_impulses_on_the_pilot_only():
    # white noise: the pilot's outputs' mean over their median-implied power is 1 within its scatter
    x, ta = _received(11, 12.0)
    assert 1.0 <= _fit(x, ta).pilot_noise_excess < 1.3
    # clicks 20 dB above the noise on the pilot's 23 ms only (none in the data after it): its outputs'
    # noise is heavy-tailed, the rest of the frame's is not
    rng = np.random.default_rng(3)
    sigma = awgn_sigma(CFG, 12.0)
    xc = x.copy()
    n = np.arange(40)
    pilot_span = CFG.n_pilot * CFG.symbol_period_s
    for k in rng.integers(int((ta + 0.002) * FS), int((ta + pilot_span) * FS), 8):
        xc[k : k + 40] += 10 * sigma * np.exp(-n / 10) * np.cos(2 * np.pi * 0.3 * n + rng.uniform(0, 6.3))
    assert _fit(xc, ta).pilot_noise_excess > 1.5
    late = x.copy()
    for k in rng.integers(int((ta + 0.1) * FS), int((ta + 0.25) * FS), 8):
        late[k : k + 40] += 10 * sigma * np.exp(-n / 10) * np.cos(2 * np.pi * 0.3 * n + rng.uniform(0, 6.3))
    assert _fit(late, ta).pilot_noise_excess < 1.3

def test_pilot_es_n0_is_the_direct_paths_own_whatever_the_echoes_and_the_decisions():
    # three paths, the direct one at 12 dB (Es/N0 = SNR·(1 + α)): over its pilot, the echoes' models taken
    # out, its Es/N0 is its own; a reference whose data decisions are wrong in a third of the symbols leaves
    # it so, where the whole frame's Es/N0 (amplitude and residual over every symbol) collapses
    expected = 10 ** (12.0 / 10) * (1 + CFG.rolloff)
    plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
    n_data = CFG.n_data
    own, whole, wrong_own, wrong_whole = [], [], [], []
    for seed in range(3):
        x, ta = _received(seed, 12.0)
        fe = FrontEnd(plan)
        bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
        for flip, out_own, out_whole in ((0.0, own, whole), (1 / 3, wrong_own, wrong_whole)):
            symbols = np.array(FRAME.symbols, complex)
            rng = np.random.default_rng(100 + seed)
            symbols[CFG.n_pilot:][rng.random(n_data) < flip] *= -1
            fit = fit_whole_frame(
                bb, plan.fs_data, 0.0, config=CFG, symbols=symbols, reference=np.ones(len(symbols), bool),
                delays_s=[ta + d for d, _, _ in PATHS], v_mps=V + 0.05, sound_speed_mps=C,
            )
            out_own.append(fit.pilot_es_n0 / expected)
            out_whole.append(fit.es_n0[0] / expected)
    # 150 outputs: the noise's estimate scatters by 1/√150 ≈ 8 %; each echo's is its gain² of the direct's
    own = np.array(own)
    assert np.all((own[:, 0] > 0.75) & (own[:, 0] < 1.3))
    gains2 = np.array([g**2 for _, g, _ in PATHS])
    assert np.all(np.abs(own[:, 1:] / gains2[1:] - 1) < 0.3)
    # on wrong decisions the fit itself strays (a Doppler 0.17 m/s off, the pilot's Es/N0 then 0.73 of it)
    wrong_own = np.array(wrong_own)
    assert np.all((wrong_own[:, 0] > 0.6) & (wrong_own[:, 0] < 1.3))
    assert np.all(np.array(whole) > 0.75)
    # (1 − 2/3)² of the amplitude's power, and the wrong third's in the residual: about a tenth of it
    assert np.all(np.array(wrong_whole) < 0.2)


def test_blanker_zeroes_an_impulse_and_its_stretch_only():
    x = np.random.default_rng(0).standard_normal(20_000)
    x[5000] = 80.0
    b = ImpulseBlanker()
    y = np.concatenate([b.push(x[:7000]), b.push(x[7000:]), b.flush()])
    assert len(y) == len(x)
    # a lone impulse sample: it, the envelope's ±1 neighbours (none above 2.5σ here) and a one-sample tail
    assert np.all(np.abs(x[4998:5003]) < 2.5 * np.array([1, 1, 80, 1, 1]))
    assert np.all(y[4999:5003] == 0.0)
    untouched = np.ones(len(x), bool)
    untouched[4999:5003] = False
    np.testing.assert_array_equal(y[untouched], x[untouched])
    assert b.blanked_fraction(0, 20_000) == pytest.approx(4 / 20_000)
    # with a guard, that many more either side, whatever the block boundaries
    g = ImpulseBlanker(guard=16)
    y = np.concatenate([g.push(x[:5002]), g.push(x[5002:]), g.flush()])
    assert np.all(y[4983:5019] == 0.0) and y[4982] == x[4982] and y[5019] == x[5019]


def test_blanker_stretch_covers_a_ringing_click_and_not_beyond():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(20_000)
    n = np.arange(60)
    click = 31.6 * np.exp(-n / 10) * np.cos(2 * np.pi * 0.3 * n + 1.0)
    x[8000:8060] += click
    y, _ = blank_impulses(x)
    blanked = np.flatnonzero(y == 0.0)
    # one stretch, from the onset to where the decay falls below ≈ 2.5σ (31.6·e^(−n/10) = 2.5 at n ≈ 25),
    # and as long again for the tail
    assert blanked[0] >= 7999 and np.all(np.diff(blanked) == 1)
    assert 36 <= len(blanked) <= 60
    # what is left of the click is below the noise (31.6·e^(−3.6) ≈ 0.9σ)
    assert np.max(np.abs(click[blanked[-1] - 8000 + 1 :])) < 1.0


def test_blanker_leaves_white_noise_and_a_frame_onset_alone():
    # a Gaussian sample beyond 5σ: p = 5.7e-7, so ≈ 33 · 5.7e-7 = 2e-5 of white noise is blanked
    rng = np.random.default_rng(3)
    x = rng.standard_normal(2_000_000)
    _, fraction = blank_impulses(x)
    assert fraction < 1e-4
    # a strong frame (40 dB) starting after silence-level noise: its onset is not an impulse
    t = np.arange(int(0.5 * FS)) / FS
    s = received_frame(FRAME, t, t_arrival_s=0.1003) + awgn_sigma(CFG, 40.0) * rng.standard_normal(len(t))
    _, fraction = blank_impulses(s)
    assert fraction == 0.0


def test_decisions_collapsed_to_one_symbol_leave_no_curvature_and_no_warning():
    # an equaliser stuck on one output decides every data symbol alike: the reference's spectrum is then a
    # line at 0 Hz holding most of its energy, and two of the four equal-energy sub-bands get none (a
    # corpus recording hit it: log(0) warnings and a NaN bend). The fit still runs; the curvature is NaN
    # (the bend pools skip it), its other outputs finite
    import warnings

    x, ta = _received(3, 12.0)
    plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
    fe = FrontEnd(plan)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    symbols = FRAME.symbols.copy()
    symbols[CFG.n_pilot:] = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_whole_frame(bb, plan.fs_data, 0.0, config=CFG, symbols=symbols,
                              reference=np.ones(len(symbols), bool), delays_s=[ta + d for d, _, _ in PATHS],
                              v_mps=V + 0.05, sound_speed_mps=C)
    assert np.isnan(fit.curvature_s2[0]) and np.isnan(fit.curvature_noise_s4[0])
    assert fit.tilt_delay_s[0] == 0.0
    assert np.all(np.isfinite(fit.v_mps)) and np.all(np.isfinite(fit.delays_s))


def test_lone_path_delay_sigma_is_its_bound_at_high_snr_and_covers_its_errors():
    # the segments' timing scatter gives the delay's σ; the known symbols' intersymbol terms in each segment's
    # derivative outputs telescope to its two ends and cancel between neighbours in the frame's mean, so they
    # are no error of the arrival. Left in the scatter, a lone path at 25 dB had σ 2.7–3.3 times its CRLB,
    # its errors at the CRLB (the corpus's steep family with its echoes removed, 8–17 dB: σ 1.4–1.5 times the
    # CRLB, errors 0.95 of it)
    frame = build_frame(CFG, b"lone path")
    plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
    # the delay's CRLB with the whole frame's energy (SPEC §6: the SRRC's Gabor bandwidth β)
    beta = CFG.symbol_rate_hz * np.sqrt((1 + CFG.rolloff**2 * (3 - 24 / np.pi**2)) / 12)
    ratios, z = [], []
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        ta = 0.1 + rng.uniform(0, 0.01)
        t = np.arange(int(0.5 * FS)) / FS
        x = received_frame(frame, t, t_arrival_s=ta, v_mps=V) + awgn_sigma(CFG, 25.0) * rng.standard_normal(len(t))
        fe = FrontEnd(plan)
        bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
        fit = fit_whole_frame(bb, plan.fs_data, 0.0, config=CFG, symbols=frame.symbols,
                              reference=np.ones(len(frame.symbols), bool), delays_s=[ta + rng.normal(0, 2e-6)],
                              v_mps=V, sound_speed_mps=C)
        crlb = 1 / (2 * np.pi * beta * np.sqrt(2 * fit.n_reference * fit.es_n0[0]))
        ratios.append(fit.sigma_delay_s[0] / crlb)
        z.append((fit.delays_s[0] - ta) / fit.sigma_delay_s[0])
    ratios, z = np.array(ratios), np.array(z)
    assert 0.95 <= np.median(ratios) <= 1.15
    # 12 frames: RMS err/σ from a χ² of 12 degrees of freedom, 0.6–1.4 at 98 %
    assert 0.6 <= np.sqrt(np.mean(z**2)) <= 1.4
