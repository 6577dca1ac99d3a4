"""The two-carrier check (``frame.two_carrier_sigma_mps``) against closed forms.

The data band at f0 and the tone at f_t see a carrier-independent phase wander as speed errors in the
ratio f_t / f0, so the data band's error is f_t/(f_t − f0) times their gap. Echoes pull the tone's peak,
which the check counts as noise: beyond the tone's resolution by the envelope of the exact peak of a
rectangular tone plus one line, computed here by maximising its spectrum; within it by the phase rate
of the two phasors' sum.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from seamodem import get_preset
from seamodem.receive.frame import TONE_PULL_ENVELOPE, two_carrier_sigma_mps

CFG = get_preset("jmse2024")
C = 1500.0
RATIO = CFG.tone_hz / (CFG.tone_hz - CFG.carrier_hz)  # −2.5


def _fit(v_mps, amplitudes):
    return SimpleNamespace(v_mps=np.asarray(v_mps, float), amplitudes=np.asarray(amplitudes, complex))


def _rms_pull(x: float, a: float = 0.05) -> float:
    """RMS over the line's phase of the peak's shift [in units of a·Δf] of a rectangular tone of length T
    plus a line of relative amplitude a at Δf = x/T."""
    pulls = []
    for th in np.linspace(0, 2 * np.pi, 24, endpoint=False):
        r = minimize_scalar(lambda f: -abs(np.sinc(f) + a * np.exp(1j * th) * np.sinc(f - x)), bounds=(-0.4, 0.4),
                            method="bounded", options={"xatol": 1e-10})
        pulls.append(r.x)
    return float(np.sqrt(np.mean(np.square(pulls)))) / (a * x)


@pytest.mark.parametrize("x", [0.7, 1.0, 1.3, 1.9, 2.5, 3.5, 5.0])
def test_pull_beyond_the_resolution_is_within_the_envelope(x):
    # the check's weight for a path at Δf·T = x is min(1, (E/x²)²) of its power: its pull on the peak in RMS
    # over the phase must not exceed a·Δf·E/x² (the exact pull oscillates below it)
    assert _rms_pull(x) <= TONE_PULL_ENVELOPE / x**2 * 1.05


def test_pull_inside_the_resolution_is_below_the_centroid_model():
    # inside the resolution the check counts the path's full power: spread a·Δf against an exact 0.55–0.7
    for x in (0.1, 0.3, 0.5):
        assert 0.5 <= _rms_pull(x) <= 1.0


def test_a_carrier_independent_wander_is_measured_from_the_gap():
    # a single path whose phase wanders: the data band is e off, the tone f0/f_t·e; the gap gives e back
    e = 0.010
    v_true = 1.0
    v_data, v_tone = v_true + e, v_true + e * CFG.carrier_hz / CFG.tone_hz
    s = two_carrier_sigma_mps(_fit([v_data], [1.0]), 0, v_tone, 0.0005, 0.0005, CFG, sound_speed_mps=C)
    # its square less the noise expectation (2 × 0.5² mm²/s²), times 2.5
    gap = v_data - v_tone
    assert s == pytest.approx(abs(RATIO) * math.sqrt(gap**2 - 2 * 0.0005**2), rel=1e-9)
    assert s == pytest.approx(e, rel=0.02)


def test_a_weak_path_with_its_own_doppler_does_not_hide_the_wander():
    # a fitted path at 2 % amplitude, 0.47 m/s away (Δf·T = 1.9): its line stands apart from the tone's and
    # pulls it by ≲ 1 mm/s; counted with its full power it would be 9 mm/s of noise and hide a 10 mm/s error
    e = 0.010
    v_data, v_tone = 1.0 + e, 1.0 + e * CFG.carrier_hz / CFG.tone_hz
    s = two_carrier_sigma_mps(_fit([v_data, v_data - 0.47], [1.0, 0.02]), 0, v_tone, 0.0005, 0.0005, CFG,
                              sound_speed_mps=C)
    assert s >= 0.8 * e


def test_an_unresolved_echo_pulling_the_tone_is_not_read_as_wander():
    # an echo at 60 % amplitude 0.05 m/s away (Δf·T = 0.2, inside the resolution) pulls the tone by up to
    # ρ/(1 − ρ)·Δv = 75 mm/s near cancellation (the phase rate of 1 + ρe^{jψ}); no wander: a gap the echo can
    # make is not read as one
    v = 1.0
    for psi in np.linspace(0, 2 * np.pi, 13):
        w = 0.6 * np.exp(1j * psi) / (1 + 0.6 * np.exp(1j * psi))
        v_tone = v + (-0.05) * w.real  # the sum's phase rate, the echo's relative phase ψ still over the tone
        s = two_carrier_sigma_mps(_fit([v, v - 0.05], [1.0, 0.6]), 0, v_tone, 0.0005, 0.0005, CFG,
                                  sound_speed_mps=C)
        assert s == 0.0, (psi, v_tone - v)


def test_a_gap_beyond_what_the_echoes_can_make_is_wander():
    # the same echo, and a wander of 300 mm/s at the data carrier (420 at the tone): a gap of 120 mm/s,
    # beyond the 75 the echo can make
    e = 0.300
    s = two_carrier_sigma_mps(_fit([1.0 + e, 0.95 + e], [1.0, 0.6]), 0, 1.0 + e * CFG.carrier_hz / CFG.tone_hz,
                              0.0005, 0.0005, CFG, sound_speed_mps=C)
    reach = 0.6 / 0.4 * 0.05
    assert s == pytest.approx(abs(RATIO) * math.sqrt((0.4 * e) ** 2 - 2 * 0.0005**2 - reach**2), rel=1e-6)
