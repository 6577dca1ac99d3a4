"""The direct path's amplitude from frame to frame (``FrameMeasurer._frame_to_frame``).

A surface image riding waves beats with the direct path more slowly than a frame: within a frame its
log-amplitude rate is within the noise, from frame to frame the amplitude moves by ~10 %. That rate
(less the spreading's, v_r/R, and the noise's) is pooled as a slow fading's scale. On the corpus's far
family (fresh seed 14308882) v_r within 3σ went 0.933 → 0.953, worst 8.9σ → 4.5σ.
"""

from __future__ import annotations

import math

import numpy as np

from seamodem import get_preset
from seamodem.receive import Emissions
from seamodem.receive.frame import FrameMeasurer
from seamodem.receive.frontend import plan_front_end
from seamodem.receive.wholeframe import WholeFrameFit

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz


def _pooled_rate(amplitudes, ranges_m, v_mps, *, es_n0=1e4, n_ref=1800, t_s=None):
    rx = FrameMeasurer(CFG, plan_front_end(CFG, FS, v_max_mps=5.0, sound_speed_mps=1500.0),
                       emissions=Emissions(times_s=[0.0]))
    t_s = np.arange(len(amplitudes)) * 1.0 if t_s is None else t_s
    one = np.ones(1)
    for t, a, r in zip(t_s, amplitudes, ranges_m):
        wf = WholeFrameFit(delays_s=np.array([t]), amplitudes=np.array([a + 0j]), v_mps=np.array([v_mps]),
                           accel_mps2=0 * one, sigma_v_mps=1e-3 * one, crlb_v_mps=1e-3 * one, es_n0=es_n0 * one,
                           sigma_delay_s=1e-6 * one, n_reference=n_ref)
        rx._frame_to_frame(wf, 0, r)
    return rx._slow_fade_pool.rate_hz


def test_a_beat_slower_than_a_frame_gives_its_rate():
    # ±13 % over an 8-s wave: d ln A/dt has RMS 0.13·2π/8/√2 = 0.072 /s (differences 1 s apart: ×0.97)
    t = np.arange(12.0)
    amp = 1 + 0.13 * np.sin(2 * np.pi * t / 8 + 0.4)
    rate = _pooled_rate(amp, np.full(t.size, 800.0), 0.0, t_s=t)
    assert 0.055 < rate < 0.085, rate


def test_spherical_spreading_is_not_a_fading():
    # closing at 1.5 m/s from 20 m: the amplitude grows as 1/R, a log-amplitude rate v/R = 0.08–0.15 /s
    # that is geometry, not a phase wander
    t = np.arange(8.0)
    r = 20.0 - 1.5 * t
    assert _pooled_rate(1.0 / r, r, 1.5, t_s=t) == 0.0
    # the same amplitudes read as fading when the spreading is not taken out (the check can fail)
    assert _pooled_rate(1.0 / r, r, 0.0, t_s=t) > 0.07


def test_noise_alone_leaves_the_pool_near_zero():
    # amplitudes scattered only by their own noise 1/√(2 n Es/N0): the pool's mean less its noise
    # expectation stays at the noise's scale, well below a fading's
    rng = np.random.default_rng(3)
    es_n0, n_ref = 3.0, 1800
    sd = 1 / math.sqrt(2 * n_ref * es_n0)
    rates = [_pooled_rate(np.exp(sd * rng.standard_normal(6)), np.full(6, 500.0), 0.0, es_n0=es_n0, n_ref=n_ref)
             for _ in range(200)]
    assert np.median(rates) == 0.0
    assert np.percentile(rates, 95) < 3 * sd, (np.percentile(rates, 95), sd)


def test_frames_far_apart_are_not_compared():
    t = np.array([0.0, 10.0, 20.0, 30.0])
    assert _pooled_rate(np.array([1.0, 1.3, 1.0, 1.3]), np.full(4, 800.0), 0.0, t_s=t) == 0.0
