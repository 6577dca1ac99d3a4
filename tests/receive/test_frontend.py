"""Front end: complex envelopes of analytic tones, block independence, any input rate."""

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.errors import ConfigError
from seamodem.receive.frontend import FrontEnd, plan_front_end

CFG = get_preset("jmse2024")


def _run(plan, x, chunk):
    fe = FrontEnd(plan)
    parts = [fe.push(x[i : i + chunk]) for i in range(0, len(x), chunk)] + [fe.flush()]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


@pytest.mark.parametrize("fs", [96153.0, 100000.0, 192000.0])
def test_envelopes_of_tones_in_both_branches(fs):
    plan = plan_front_end(CFG, fs, v_max_mps=5, sound_speed_mps=1500)
    n = int(3.1 * fs)
    t = np.arange(n) / fs
    x = np.cos(2 * np.pi * 29000.3 * t + 0.3) + 0.5 * np.cos(2 * np.pi * 20040.0 * t + 1.0)
    bb, tone = _run(plan, x, 200_001)
    assert len(bb) == -(-n // plan.data.decimation)
    assert len(tone) == -(-n // plan.tone.decimation)
    tb = np.arange(len(bb)) / plan.fs_data
    tt = np.arange(len(tone)) / plan.fs_tone
    edge_b, edge_t = int(0.02 * plan.fs_data), int(0.02 * plan.fs_tone)  # filter transients at the file's ends
    want_b = np.exp(1j * (2 * np.pi * 1000.3 * tb + 0.3))
    want_t = 0.5 * np.exp(1j * (2 * np.pi * 40.0 * tt + 1.0))
    # 90 dB Kaiser design: pass-band ripple and stop-band leakage ≈ 3e-5
    assert np.max(np.abs(bb - want_b)[edge_b:-edge_b]) < 1e-4
    assert np.max(np.abs(tone - want_t)[edge_t:-edge_t]) < 1e-4


def test_output_does_not_depend_on_how_input_is_split():
    plan = plan_front_end(CFG, CFG.sample_rate_hz, v_max_mps=5, sound_speed_mps=1500)
    x = np.random.default_rng(3).standard_normal(700_000)
    a = _run(plan, x, len(x))
    b = _run(plan, x, 77_777)
    # same arithmetic on the same blocks: equal to rounding
    np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-12)


def test_out_of_band_content_is_rejected():
    plan = plan_front_end(CFG, CFG.sample_rate_hz, v_max_mps=5, sound_speed_mps=1500)
    fs = CFG.sample_rate_hz
    t = np.arange(400_000) / fs
    # the tone must not leak into the data branch, nor the data band into the tone branch
    bb_tone, _ = _run(plan, np.cos(2 * np.pi * CFG.tone_hz * t), 400_000)
    _, tone_data = _run(plan, np.cos(2 * np.pi * 28000 * t), 400_000)
    mid = slice(1000, -1000)
    assert np.max(np.abs(bb_tone[mid])) < 1e-4  # ≥ 80 dB rejection (90 dB design)
    assert np.max(np.abs(tone_data[100:-100])) < 1e-4


def test_rate_that_cannot_hold_the_band_is_an_error():
    with pytest.raises(ConfigError, match="sample_rate_hz"):
        plan_front_end(CFG, 48000.0, v_max_mps=5, sound_speed_mps=1500)
