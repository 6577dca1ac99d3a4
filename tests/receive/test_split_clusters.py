"""An echo that is two paths fitted as one is split (receive/wholeframe.py, ``split_clusters``), on analytic
frames: paths summed directly, each its own exactly time-scaled copy of the transmitted passband
(tests/receive/analytic.py). At long range a bottom path and its surface image arrive 1/B apart; fitted as
one echo, its misfit bends the direct path's channel, which the receiver would read as a merged echo of the
direct path's (the bend bound)."""

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive.frontend import FrontEnd, plan_front_end
from seamodem.receive.wholeframe import fit_whole_frame

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
FRAME = build_frame(CFG, b"cluster")
V = 0.7
B_S = 400e-6  # the bottom path, after the direct one [s]
BS_S = 514e-6  # its surface image, 1.02/B later, 3 cm/s faster (the waves)
PLAN = plan_front_end(CFG, FS, v_max_mps=5, sound_speed_mps=C)


def _fit(seed, *, split, image_gain, cluster=True):
    rng = np.random.default_rng(seed)
    ta = 0.1 + rng.uniform(0, 0.01)
    total = int(0.5 * FS)
    t = np.arange(total) / FS
    x = received_frame(FRAME, t, t_arrival_s=ta, v_mps=V, gain=1.0)
    x += received_frame(FRAME, t, t_arrival_s=ta + B_S, v_mps=V, gain=0.7)
    if cluster:
        x += received_frame(FRAME, t, t_arrival_s=ta + BS_S, v_mps=V + 0.03, gain=image_gain)
    x += awgn_sigma(CFG, 15.0) * rng.standard_normal(total)
    fe = FrontEnd(PLAN)
    bb = np.concatenate([fe.push(x)[0], fe.flush()[0]])
    # the pilot's fit had one echo for the pair, between them
    start = [ta, ta + (0.5 * (B_S + BS_S) if cluster else B_S)]
    fit = fit_whole_frame(bb, PLAN.fs_data, 0.0, config=CFG, symbols=FRAME.symbols,
                          reference=np.ones(len(FRAME.symbols), bool), delays_s=start, v_mps=V,
                          sound_speed_mps=C, direct_s=ta, split=split, echo_bends=True)
    bends = np.abs(fit.curvature_s2) ** 2 / fit.curvature_noise_s4
    return fit, bends, ta


@pytest.mark.parametrize("seed, image_gain", [(1, -0.7), (2, -0.25), (3, 0.4), (4, -0.65)])
def test_a_bottom_path_and_its_image_fitted_as_one_are_split_back(seed, image_gain):
    one, bends_one, _ = _fit(seed, split=0, image_gain=image_gain)
    # fitted as one, the echo's own channel bends far beyond its noise (noise alone: |c|²/n exponential, mean 1)
    assert len(one.delays_s) == 2 and bends_one[1] > 30
    fit, bends, ta = _fit(seed, split=2, image_gain=image_gain)
    # split: both paths found within 15 µs (an eighth of 1/B), and no channel bent beyond 3 noise σ's worth
    assert len(fit.delays_s) == 3
    np.testing.assert_allclose(fit.delays_s - ta, [0.0, B_S, BS_S], atol=15e-6)
    assert np.all(bends[np.isfinite(bends)] < 9)
    assert fit.noise_var < one.noise_var


def test_a_resolved_echo_and_a_lone_path_are_not_split():
    fit, bends, ta = _fit(5, split=2, image_gain=0.0, cluster=False)
    assert len(fit.delays_s) == 2
    np.testing.assert_allclose(fit.delays_s - ta, [0.0, B_S], atol=5e-6)
    assert np.all(bends < 9)
