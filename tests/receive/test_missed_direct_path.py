"""A direct path the pilot's fit missed is found in a decoded frame's whole-frame residual
(receive/wholeframe.py ``earlier_path``, receive/frame.py ``missed_direct_lag_s``), on analytic frames: paths
summed directly, each its own exactly time-scaled copy of the transmitted passband (tests/receive/analytic.py).

At long range the direct path and its surface image can nearly cancel (Lloyd's mirror); the pilot's 23 ms
then shows the bottom echo as the first path, and the range is that echo's, 0.4–0.6 m late. Nothing arrives
before the direct path, so a component the whole frame's residual holds before the path taken, far out of
its noise, is the direct path."""

import math

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive.frame import MISSED_DIRECT_Z2, earlier_fitted_direct, missed_direct_lag_s
from seamodem.receive.frontend import FrontEnd, plan_front_end
from seamodem.receive.wholeframe import earlier_path, fit_whole_frame

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
FRAME = build_frame(CFG, b"missed direct")
V = -0.8
LATE_S = 430e-6  # the bottom echo the pilot took, after the direct path [s]
PLAN = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
REACH = CFG.n_pilot * CFG.symbol_period_s


def _frame(seed, *, direct_gain, snr_db=4.0):
    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    total = int(1.4 * FS)
    t = np.arange(total) / FS
    x = received_frame(FRAME, t, t_arrival_s=ta + LATE_S, v_mps=V, gain=1.0)
    if direct_gain:
        x += received_frame(FRAME, t, t_arrival_s=ta, v_mps=V, gain=direct_gain)
    x += awgn_sigma(CFG, snr_db) * rng.standard_normal(total)
    fe = FrontEnd(PLAN)
    return np.concatenate([fe.push(x)[0], fe.flush()[0]]), ta


def _fit(bb, delays, direct):
    return fit_whole_frame(bb, PLAN.fs_data, 0.0, config=CFG, symbols=FRAME.symbols,
                           reference=np.ones(len(FRAME.symbols), bool), delays_s=delays, v_mps=V,
                           sound_speed_mps=C, direct_s=direct, earlier_reach_s=REACH)


@pytest.mark.parametrize("seed, gain", [(1, 0.25), (2, 0.5), (3, -0.3)])
def test_a_direct_path_left_out_of_the_fit_is_found_before_the_path_taken(seed, gain):
    bb, ta = _frame(seed, direct_gain=gain)
    fit = _fit(bb, [ta + LATE_S], ta + LATE_S)
    lag, amp, z2 = fit.earlier_path
    # at the direct path's lag (within a sample at fs_data), its gain relative to the path taken, far out
    # of the noise (the whole frame's energy: at 4 dB and 0.25, |c|²/var ≈ 2·n·Es/N0·0.25² ≈ 250)
    assert lag == pytest.approx(-LATE_S, abs=1.0 / PLAN.fs_data)
    assert abs(amp) / abs(fit.amplitudes[0]) == pytest.approx(abs(gain), rel=0.2)
    assert z2 > 100
    assert missed_direct_lag_s(fit, 0) == pytest.approx(-LATE_S, abs=1.0 / PLAN.fs_data)
    # fitted again with it, as the receiver does, the direct path's arrival is within its σ's reach
    refit = _fit(bb, [ta + lag + LATE_S, ta + LATE_S], ta + lag + LATE_S)
    assert refit.noise_var < fit.noise_var
    assert abs(refit.delays_s[0] - ta) < 4 * refit.sigma_delay_s[0] + 1e-6


def test_noise_before_a_lone_path_is_not_taken_for_one():
    # a single path in noise, its residual searched a pilot's length before it: the largest |c|²/var of a
    # few thousand lags of a complex Gaussian stays near ln(lags) ≈ 8, far below the threshold
    z2s = []
    for seed in range(12):
        bb, ta = _frame(100 + seed, direct_gain=0.0, snr_db=[-2.0, 6.0, 20.0][seed % 3])
        fit = _fit(bb, [ta + LATE_S], ta + LATE_S)
        z2s.append(fit.earlier_path[2])
        assert missed_direct_lag_s(fit, 0) is None
    assert max(z2s) < MISSED_DIRECT_Z2 / 2
    lags = int(REACH * PLAN.fs_data)
    assert 0.5 * math.log(lags) < np.median(z2s) < 2 * math.log(lags)


def test_the_search_is_linear_not_circular():
    # a component at the end of the residual is no component before its start (zero-padded correlation)
    n = 4000
    rng = np.random.default_rng(0)
    template = np.zeros(n, complex)
    template[300:800] = np.exp(2j * np.pi * rng.uniform(size=500))  # random phases: a sharp autocorrelation
    resid = np.zeros(n, complex)
    resid[n - 520:n - 20] = template[300:800]
    resid += 1e-3 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    lag, amp, z2 = earlier_path(resid, template, PLAN.fs_data, CFG, reach_s=REACH)
    assert z2 < 30
    # ... while the same component 200 samples before the template is found there
    resid2 = np.zeros(n, complex)
    resid2[100:600] = template[300:800]
    resid2 += 1e-3 * rng.standard_normal(n)
    lag2, amp2, z22 = earlier_path(resid2, template, PLAN.fs_data, CFG, reach_s=REACH)
    assert lag2 * PLAN.fs_data == pytest.approx(-200, abs=0.5) and abs(amp2) == pytest.approx(1, rel=0.05)
    assert z22 > 1e3  # (its noise expectation is the residual power, the component in it: n/500)


def test_the_corpus_frame_whose_pilot_took_the_bottom_echo_ranges_the_direct_path():
    # benchmarks/corpus.py's far recording 6920412408 (its own channel, not seamodem.channel): 1 km, a
    # surface image −0.92 at 33 µs behind the direct path, 4 dB. On frame 3 the pair was near its null over
    # the pilot, whose fit took the bottom echo 0.42 ms late: 622 mm off with σ 69 mm (9σ) before
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_corpus import run_recording

    rows = run_recording("far", 6920412408, 4)
    err = np.array([r["range_m"] - r["range_true_m"] for r in rows])
    sigma = np.array([r["sigma_range_m"] for r in rows])
    assert all(r["crc_ok"] for r in rows)
    assert abs(err[3]) < 0.2, err
    assert np.all(np.abs(err) <= 3 * sigma), err / sigma


def test_a_weaker_path_before_the_one_taken_is_the_direct_path_when_the_whole_frame_shows_it():
    # the pilot's fit found the weak direct path but took the stronger echo (the earliest at least 0.3 of the
    # strongest); fitted over the decoded frame, the weak one stands far out of its noise
    bb, ta = _frame(4, direct_gain=0.25)
    fit = _fit(bb, [ta, ta + LATE_S], ta + LATE_S)
    first = int(np.argmin(np.abs(fit.delays_s - (ta + LATE_S))))
    q = earlier_fitted_direct(fit, first, CFG)
    assert q is not None and abs(fit.delays_s[q] - ta) < 4 * fit.sigma_delay_s[q] + 1e-6
    assert fit.n_reference * fit.es_n0[q] > 100


def test_a_path_the_pilot_saw_in_noise_before_the_direct_one_is_not_taken():
    # a "path" 8.3 ms before a lone one (what the pilot's fit of the corpus's far recording 6920412038 had at
    # 0.18 of the strongest): over the whole frame it is noise
    for seed in range(5):
        bb, ta = _frame(200 + seed, direct_gain=0.0, snr_db=[0.0, 10.0, 20.0][seed % 3])
        fit = _fit(bb, [ta + LATE_S - 8.3e-3, ta + LATE_S], ta + LATE_S)
        assert earlier_fitted_direct(fit, 1, CFG) is None
        assert fit.n_reference * fit.es_n0[0] < MISSED_DIRECT_Z2 / 2


def test_the_corpus_frame_whose_range_sigma_covered_a_noise_path_before_the_direct_one():
    # the corpus's far recording 6920412038, 14 dB: frame 9's pilot fit had a path 8.3 ms early, 0.18 of the
    # strongest, and the arrival's σ covered the gap: 12.4 m for an error of 7.9 mm before
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_corpus import run_recording

    rows = run_recording("far", 6920412038, 10)
    last = rows[9]
    assert last["crc_ok"] and last["v_r_source"] == "whole_frame"
    assert last["sigma_range_m"] < 0.2
    assert abs(last["range_m"] - last["range_true_m"]) <= 3 * last["sigma_range_m"]
