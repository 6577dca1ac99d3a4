"""The channel corpus with another frame than jmse2024 (``bench_corpus.py --preset``).

The receiver's unmodelled-σ constants were measured on the corpus with the jmse2024 frame; the
corpus run with oceans2021 (8 kBd, α 0.5, 12 kHz of band at 23 kHz, 2518 data symbols) checks that
they carry over (benchmarks/results/bench_corpus_oceans2021_fresh_*.txt). Here one steep recording of
that frame: every frame found and decoded, its range and v_r within 3σ of the corpus's truth.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def test_the_corpus_runs_the_oceans2021_frame_and_its_sigma_covers_the_error():
    from bench_corpus import recording, run_recording

    cfg, _, _, rec = recording("steep", 31000, 1, preset="oceans2021")
    assert cfg.name == "oceans2021" and rec.fs == cfg.sample_rate_hz
    rows = run_recording("steep", 31000, 3, preset="oceans2021")
    assert [r["detected"] and r["crc_ok"] for r in rows] == [True] * 3
    for col, sig, truth in (("range_m", "sigma_range_m", "range_true_m"), ("v_r_mps", "sigma_v_r_mps", "v_r_true_mps")):
        z = np.array([abs(r[col] - r[truth]) / r[sig] for r in rows])
        assert np.all(z <= 3), (col, z)


def test_the_corpus_keeps_the_paths_asked_for_and_the_rest_of_the_recording():
    import pytest
    from bench_corpus import recording

    _, _, _, full = recording("far", 31001, 1)
    _, _, _, some = recording("far", 31001, 1, paths=("D", "B"))
    assert [p[0] for p in some.truth[0]["paths"]] == ["D", "B"]
    by_name = {p[0]: p for p in full.truth[0]["paths"]}
    for p in some.truth[0]["paths"]:  # the same geometry, gains and Doppler: the other paths only left out
        assert p == by_name[p[0]]
    with pytest.raises(ValueError, match="include D"):
        recording("far", 31001, 1, paths=("S", "B"))
