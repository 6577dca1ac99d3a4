"""A direct path weaker than an echo that lies more than the arrival fit's ±12 symbols behind it.

The detector locks on the strongest correlation peak, the echo's. Before the precursor search
(``multipath.find_precursors``) the arrival fit looked ±12 symbols around it and took the echo as the
direct path: c·δ off (3.3 m for δ = 2.2 ms) with a σ of millimetres. Analytic frames (tests/receive/
analytic.py), nothing from the project's channel code.
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
V = 0.8


def _recording(rng, *, direct_gain: float, echo_delay_s: float, snr_db: float, n_frames: int = 4):
    payloads = [f"precursor {k}".encode() for k in range(n_frames)]
    t_emit = 0.1 + np.arange(n_frames) * 1.0
    tof = 0.2 + rng.uniform(0, 0.01, n_frames)
    x = multipath_recording(CFG, payloads, t_emit, tof, [(0.0, direct_gain), (echo_delay_s, 1.0)], v_mps=V,
                            snr_db=snr_db, rng=rng)
    return x, t_emit, tof, payloads


def _received(seed: int, direct_gain: float, echo_delay_s: float):
    """The records of every frame (all must be found) by frame index, and the true times of flight."""
    x, t_emit, tof, payloads = _recording(np.random.default_rng(seed), direct_gain=direct_gain,
                                          echo_delay_s=echo_delay_s, snr_db=15.0)
    rx = Receiver(CFG, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=True),
                  payloads=payloads)
    records = {r.frame_index: r for r in rx.run([x], fs=FS)}
    assert sorted(records) == list(range(len(t_emit)))
    return records, tof


@pytest.mark.parametrize("direct_gain,echo_delay_s", [(0.6, 2.2e-3), (0.35, 2.2e-3), (0.35, 6.0e-3)])
def test_the_direct_path_before_a_stronger_late_echo_is_the_range(direct_gain, echo_delay_s):
    records, tof = _received(4101, direct_gain, echo_delay_s)
    for k, r in records.items():
        err = r.range_m - C * tof[k]
        # the echo is c·δ = 3.3 / 9 m behind: the direct path's range, and a σ that covers it
        assert abs(err) < 0.05, (k, err, r.sigma_range_m)
        assert abs(err) <= 3 * r.sigma_range_m, (k, err, r.sigma_range_m)


def test_a_direct_path_below_the_first_path_share_leaves_the_echo_with_a_sigma_that_covers_it():
    # at 0.22 of the echo the direct path is below the first-path share (0.3): the echo is the range, but the
    # precursor found before it sets the arrival's σ (frame.earlier_path_gap_s) — before the search, 3.3 m
    # off with σ of millimetres
    records, tof = _received(4102, 0.22, 2.2e-3)
    for k, r in records.items():
        err = r.range_m - C * tof[k]
        assert abs(err) <= 3 * r.sigma_range_m, (k, err, r.sigma_range_m)


def test_a_noise_peak_a_pilot_length_early_is_not_taken_for_the_arrival():
    # the corpus's steep family, one path at −2.8 dB (benchmarks/corpus.py, seed 5839417481): frame 5's
    # precursor search found a noise peak 0.35 of the path 106 symbols early and took it as the arrival —
    # before its emission, so the record went to frame 4, 1.47 km off with σ 22 mm. The search's noise test
    # now counts the lags it searches (multipath._PRECURSOR_NOISE_DEVIATIONS)
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_corpus import run_recording

    rows = {r["frame"]: r for r in run_recording("steep", 5839417481, 6, echoes=False)}
    assert rows[5]["detected"] and rows[4]["detected"]
    for k in (4, 5):
        err = rows[k]["range_m"] - rows[k]["range_true_m"]
        assert abs(err) <= 3 * rows[k]["sigma_range_m"], (k, err, rows[k]["sigma_range_m"])


def test_the_direct_path_refitted_with_its_echoes_is_not_its_own_precursor():
    # the echoes' search fits the direct path again and keeps the arrival fit's first_s: its own delay moves by
    # up to a few µs, and read against first_s a direct path refitted earlier counted as a path before itself,
    # its gap the range's σ (the corpus's steep family: 0.05–3.1 mm on ranges within 1.5 mm)
    from types import SimpleNamespace

    from seamodem.receive.frame import earlier_path_gap_s
    from seamodem.receive.multipath import PathFit

    t0 = 0.2
    refitted = PathFit(delays_s=np.array([t0 - 1.2e-6, t0 + 3.1e-3]), amplitudes=np.ones(2, complex), first_s=t0)
    assert earlier_path_gap_s(SimpleNamespace(echoes=refitted, paths=None)) == 0.0
    # a path 0.4 ms before the direct one is a precursor: its gap stays (from the direct path's own delay)
    early = PathFit(delays_s=np.array([t0 - 4e-4, t0 - 1.2e-6, t0 + 3.1e-3]), amplitudes=np.ones(3, complex),
                    first_s=t0)
    assert earlier_path_gap_s(SimpleNamespace(echoes=early, paths=None)) == pytest.approx(4e-4 - 1.2e-6, rel=1e-12)
