"""A fit on decisions that moves further than a tilt of its reference is not used as a measurement
(``frame.decisions_follow``, ``FrameMeasurer._doppler``).

The equaliser's outputs are turned by a phase ramp (±Δ of speed, π/4 at the data's ends for BPSK) and
decided again; λ is how far the fit's speed moves per Δ. On analytic single-path frames the fit on good
decisions barely follows (λ ≈ 0.2, from the confident-decision mask only) and at −6 dB it follows but
stays a smooth function of its reference (λ 0.65–0.9): neither is flagged. On the corpus (fading and
impulsive families) fits beyond [0, 1.5] had RMS err/σ 1.7 with their own σ: recording 2718001's frame 1,
a DFE that had locked onto noise (raw BER 0.43), was 174 mm/s off with σ 24 mm/s (7.2σ).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive.demodulate import decode_received
from seamodem.receive.frame import _DECISIONS_MAX_FOLLOW, confident_decisions, decisions_follow
from seamodem.receive.frontend import FrontEnd, plan_front_end
from seamodem.receive.wholeframe import fit_whole_frame

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
V = 1.2
FRAME = build_frame(CFG, b"follow")
PILOT = FRAME.symbols[: CFG.n_pilot]


def _follow(seed: int, snr_db: float) -> tuple[bool, float, float]:
    """(CRC passed, share of wrong confident decisions, λ) of one analytic frame, the DFE's decisions."""
    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    t = np.arange(int(0.5 * FS)) / FS
    x = received_frame(FRAME, t, t_arrival_s=ta, v_mps=V) + awgn_sigma(CFG, snr_db) * rng.standard_normal(t.size)
    plan = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)
    fe = FrontEnd(plan)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    dec = decode_received(bb, plan.fs_data, 0.0, config=CFG, pilot=PILOT, t_start_s=ta, v_mps=V + 0.02,
                          sound_speed_mps=C, passes=1)
    soft = np.asarray(dec.equalized)[: CFG.n_data]

    def speed(data, trusted):
        try:
            wf = fit_whole_frame(bb, plan.fs_data, 0.0, config=CFG, symbols=np.concatenate([PILOT, data]),
                                 reference=np.concatenate([np.ones(CFG.n_pilot, bool), trusted]), delays_s=[ta],
                                 v_mps=V + 0.02, sound_speed_mps=C, direct_s=ta)
        except ValueError:
            return math.nan
        return float(wf.v_mps[0])

    data, trusted = confident_decisions(soft, CFG.modulation)
    wrong = float(np.mean(data[trusted] != FRAME.symbols[CFG.n_pilot:][trusted]))
    return dec.crc_ok, wrong, decisions_follow(soft, CFG, speed, sound_speed_mps=C)


def test_good_decisions_barely_follow_the_tilt_and_noisy_ones_follow_it_smoothly():
    good = [_follow(seed, 10.0) for seed in range(2)]
    noisy = [_follow(seed, -6.0) for seed in range(3)]
    assert all(ok and wrong == 0 for ok, wrong, _ in good)
    assert all(0 <= lam < 0.4 for *_, lam in good), good  # measured 0.20–0.21
    assert all(not ok and wrong > 0.02 for ok, wrong, _ in noisy)  # CRC failed, 5–7 % wrong
    lams = [lam for *_, lam in noisy]
    # following more than good decisions do, and still not flagged (measured 0.65–0.90)
    assert all(0.5 < lam <= _DECISIONS_MAX_FOLLOW for lam in lams), lams


@pytest.mark.slow
def test_a_fit_on_decisions_of_a_dfe_locked_onto_noise_is_not_trusted():
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_corpus import run_recording

    rows = [r for r in run_recording("fading", 2718001, 10) if r["detected"]]
    z = np.array([(r["v_r_mps"] - r["v_r_true_mps"]) / r["sigma_v_r_mps"] for r in rows])
    assert len(rows) == 10
    assert np.all(np.abs(z) <= 3), z  # frame 1 was at 7.2σ
    # not a blanket widening: the other frames' σ still of their errors' order (measured RMS 0.7)
    assert np.sqrt(np.mean(z**2)) > 0.4, z


@pytest.mark.slow
def test_frames_not_decoded_take_the_pilot_arrival_gaps_their_decoded_neighbours_showed():
    # corpus recording 2348336521 (impulsive, α-stable, a surface echo −0.93 at 107 µs ≈ 1/B): frames 2–4
    # decoded, their fits resolved the echo; the later frames' ranges are their pilot's arrivals, 16–47 mm
    # short with σ 7–8 mm (frame 8 at 5.7σ); the decoded frames' pilot arrivals were 5–20 mm off their fits
    # beyond both σ's, which now widens the pilot's arrival of the frames after them
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_corpus import run_recording

    rows = {r["frame"]: r for r in run_recording("impulsive", 2348336521, 10) if r["detected"]}
    # (frame 9 decodes too since session 22's further passes through the echoes, and frame 7 since session 26's
    # per-symbol noise variance in the decoder's LLRs)
    assert [k for k, r in rows.items() if r["v_r_source"] == "whole_frame"] == [2, 3, 4, 7, 9]
    z = {k: (r["range_m"] - r["range_true_m"]) / r["sigma_range_m"] for k, r in rows.items()}
    assert max(abs(v) for v in z.values()) < 4.0, z  # frame 8: 5.7σ before, 3.6σ now
    # the σ grew by the pool (about 10 mm), not beyond: errors still of the σ's order
    sigmas = [rows[k]["sigma_range_m"] for k in (5, 6, 8)]
    assert all(0.011 < s < 0.04 for s in sigmas), sigmas  # 7–8 mm before
