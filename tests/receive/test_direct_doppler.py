"""Pilot (filter-bank) Doppler of the direct path among echoes with their own Doppler (receive/multipath.py)."""

import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.receive import Emissions, Receiver

from analytic import awgn_sigma, received_frame

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
FRAME = build_frame(CFG, b"direct doppler")
V = 3.0


def _bank_errors_mps(paths, snr_db=40.0, n=3):
    """v_r_bank − V of n frames; paths = (extra delay s, gain, Doppler factor), the first the direct one."""
    arrivals = 0.2 + 0.6 * np.arange(n)
    total = int((0.6 * n + 0.2) * FS)
    t = np.arange(total) / FS
    x = np.zeros(total)
    for ta in arrivals:
        for delay, gain, factor in paths:
            lo, hi = int((ta + delay - 0.006) * FS), int((ta + delay + CFG.frame_duration_s + 0.01) * FS)
            x[lo:hi] += received_frame(FRAME, t[lo:hi], t_arrival_s=ta + delay, v_mps=V * factor, gain=gain)
    x += awgn_sigma(CFG, snr_db) * np.random.default_rng(1).standard_normal(total)
    rx = Receiver(CFG, emissions=Emissions(start_s=0.0, period_s=0.6))
    recs = list(rx.run([x], fs=FS))
    assert [r.frame_index for r in recs] == list(range(n))
    return np.array([r.v_r_bank_mps for r in recs]) - V


@pytest.mark.parametrize(
    "paths",
    [
        # steep echoes, resolved, slower by 2 % and 5 % (v cos θ); the 4 ms one lies beyond the arrival fit's window
        ((0.0, 1.0, 1.0), (1.5e-3, -1.4, 0.98), (4e-3, 0.5, 0.95)),
        # shallow water: a stronger inverted surface echo 0.29 ms (1.9 symbols) late, unresolved
        ((0.0, 1.0, 1.0), (0.29e-3, -1.4, 0.999), (1.2e-3, 0.5, 0.996)),
    ],
    ids=["steep", "unresolved"],
)
def test_bank_doppler_is_the_direct_paths(paths):
    # at 40 dB the pilot CRLB is 0.6 mm/s; the echoes' pilots alone biased the bank by 40–70 mm/s,
    # and a common-Doppler fit (no per-echo drift) by −40 mm/s in the steep case
    err = _bank_errors_mps(paths)
    assert np.max(np.abs(err)) < 0.008


def _decisions_fit_record(v_fit, sigma_fit, v_bank, v_tone, *, snr_db=6.0, c_n0_dbhz=30.0, es_n0=1.0, follow=0.8):
    """FrameMeasurer._doppler's choice for a frame whose CRC failed and whose decisions fit is given (``follow``:
    its λ, how far it follows a tilt of its reference, ``frame.decisions_follow``)."""
    from types import SimpleNamespace

    from seamodem.receive.frame import FrameMeasurer, _WholeFrame
    from seamodem.receive.frontend import plan_front_end
    from seamodem.receive.wholeframe import WholeFrameFit

    one = np.ones(1)
    wf = WholeFrameFit(delays_s=np.array([0.1]), amplitudes=one + 0j, v_mps=np.array([v_fit]), accel_mps2=0 * one,
                       sigma_v_mps=np.array([sigma_fit]), crlb_v_mps=np.array([sigma_fit]), es_n0=es_n0 * one,
                       sigma_delay_s=np.array([1e-6]), n_reference=1000)
    rx = FrameMeasurer(CFG, plan_front_end(CFG, FS, v_max_mps=5.0, sound_speed_mps=1500.0),
                       emissions=Emissions(times_s=[0.0]))
    rx._whole_frame = lambda *a: _WholeFrame(wf, 0, "whole_frame_decisions", lambda: follow, 0, None)
    tone = SimpleNamespace(c_n0_hz=10 ** (c_n0_dbhz / 10), spread_hz=0.0, amp_rate_hz=0.0,
                           amp_rate_terms=np.zeros((2, 2)))
    m = SimpleNamespace(v_tone_ml_mps=v_tone, tone=tone,
                        pilot=SimpleNamespace(snr_db=snr_db, v_mps=v_bank, t_start_s=0.1), paths=SimpleNamespace(delays_s=one))
    # a lone path: the direct path has the whole SNR; Es/N0 = 10^0.6 · 1.4 = 5.6 expected, the fit's 1 (0.18 of it)
    return rx._doppler(m, object(), None, 0.0, 1.0, 1.0, snr_db)


def test_a_decisions_fit_far_from_the_pilot_bank_grows_its_sigma_and_yields_to_the_tone():
    from seamodem.receive.bounds import pilot_velocity_crlb_mps

    sigma_bank = float(pilot_velocity_crlb_mps(CFG, 6.0, sound_speed_mps=1500.0))
    # agreeing with the bank (within 3 of its σ): the fit and its σ as they are
    rec, timing = _decisions_fit_record(1.003, 0.002, 1.0 + 2 * sigma_bank, 1.0)
    assert rec["v_r_source"] == "whole_frame_decisions" and rec["sigma_v_r_mps"] == 0.002 and timing.sigma_s == 1e-6
    # 0.3 m/s from the bank (wrong decisions in runs), 0.15 m/s from a tone that is itself 0.15 m/s off the
    # bank (σ 0.12 m/s with that gap): its own σ (0.02) would pass the tone's test; grown to the gap beyond
    # 3 σ_bank (0.29) it does not: the tone is the estimate, with the pilot's arrival
    rec, timing = _decisions_fit_record(1.3, 0.02, 1.0, 1.15)
    assert rec["v_r_source"] == "tone" and timing is None
    # no tone to referee: the fit is kept, with its σ (and its timing's) grown by the gap
    rec, timing = _decisions_fit_record(1.3, 0.02, 1.0, float("nan"))
    grown = np.sqrt(0.02**2 + 0.3**2 - 9 * sigma_bank**2)
    assert rec["v_r_source"] == "whole_frame_decisions"
    assert rec["sigma_v_r_mps"] == pytest.approx(grown) and timing.sigma_s == pytest.approx(1e-6 * grown / 0.02)


def test_a_decisions_fit_that_does_not_explain_the_frame_gets_the_tones_sigma_rule():
    """Es/N0 of the fit 0.01 of what the SNR gives the path (decisions mostly wrong): its bias is unobservable,
    its σ² is its own + its gap to the bank² + σ_bank² (as the tone's among echoes), and the smaller σ wins."""
    from seamodem.receive.bounds import pilot_velocity_crlb_mps

    sigma_bank = float(pilot_velocity_crlb_mps(CFG, 6.0, sound_speed_mps=1500.0))
    # 0.01 m/s from the bank, the tone 0.2 m/s off it (single path: σ_tone the gap beyond 3 σ_bank)
    rec, _ = _decisions_fit_record(1.01, 0.002, 1.0, 1.2, es_n0=0.056)
    assert rec["v_r_source"] == "whole_frame_decisions"
    assert rec["sigma_v_r_mps"] == pytest.approx(np.sqrt(0.002**2 + 0.01**2 + sigma_bank**2))
    # the same fit with a good Es/N0 keeps its own σ (within 3 σ_bank of the bank)
    rec, _ = _decisions_fit_record(1.01, 0.002, 1.0, 1.2, es_n0=1.0)
    assert rec["sigma_v_r_mps"] == 0.002
    # ... unless it moves further than a tilt of its reference (λ beyond 1.5, or against it): the same rule
    for follow in (2.0, -0.5, float("nan")):
        rec, _ = _decisions_fit_record(1.01, 0.002, 1.0, 1.2, es_n0=1.0, follow=follow)
        assert rec["sigma_v_r_mps"] == pytest.approx(np.sqrt(0.002**2 + 0.01**2 + sigma_bank**2)), follow
    # 0.5 m/s from the bank with the tone on it: the tone's σ is the smaller, the tone is the estimate
    rec, timing = _decisions_fit_record(1.5, 0.002, 1.0, 1.0, es_n0=0.056)
    assert rec["v_r_source"] == "tone" and timing is None
