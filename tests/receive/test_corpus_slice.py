"""A fast slice of the channel corpus (benchmarks/corpus.py, issue 25 item 2): the record's σ is calibrated.

One recording of each family (steep circling, far with a merged surface echo,
Rician fading, impulsive noise), fixed seeds, through the default receiver
(decoding on) as ``benchmarks/bench_corpus.py`` runs it, scored against the
corpus's direct-path truth. The σ must cover the error: a σ that says nothing
of a fading or merged path (errors 10–60 of it before the unmodelled terms of
``seamodem.receive.frame.unmodelled_sigmas``) fails.

Not asserted, because not met (issue 25 item 2, open; benchmarks/results/bench_corpus.txt):
the far family's range (a surface echo ~8–36 µs behind the direct path, merged with it, biases the
arrival by +1–2 cm with no signature one frame shows; see docs/receiver.md: on seed 31001 the five
frames are 7.9–10.8σ off). The fading family's v_r is asserted since session 9 (its rate term less its
noise expectation and the two-carrier check: on seed 31002 the five frames were 3.4–5.3σ off before,
0.06–1.22σ now).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

#: (family, seed): seeds used neither by the report (2025…) nor in development (7…, 8…, 9…)
SLICE = (("steep", 31000), ("far", 31001), ("fading", 31002), ("impulsive", 31003))
FRAMES = 5


@pytest.fixture(scope="module")
def rows():
    from bench_corpus import run_recording

    out = []
    for family, seed in SLICE:
        out += [r for r in run_recording(family, seed, FRAMES) if r["detected"]]
    return out


def _z(rows, what):
    col, sig, truth = {"v_r": ("v_r_mps", "sigma_v_r_mps", "v_r_true_mps"),
                       "range": ("range_m", "sigma_range_m", "range_true_m")}[what]
    return np.array([abs(r[col] - r[truth]) / r[sig] for r in rows])


@pytest.mark.slow
def test_v_r_sigma_covers_the_error_in_every_family(rows):
    assert len(rows) >= 3 * FRAMES
    z = _z(rows, "v_r")
    assert np.all(np.isfinite(z))
    assert np.mean(z <= 3) >= 0.9, np.sort(z)[-5:]
    assert np.max(z) <= 6, np.sort(z)[-5:]


@pytest.mark.slow
def test_range_sigma_covers_the_error_off_the_far_family(rows):
    near = [r for r in rows if r["family"] != "far"]
    assert len(near) >= 2 * FRAMES
    z = _z(near, "range")
    assert np.all(np.isfinite(z))
    assert np.mean(z <= 3) >= 0.9, np.sort(z)[-5:]
    assert np.max(z) <= 6, np.sort(z)[-5:]


def test_a_frames_table_pooled_reports_what_its_run_reported(rows, tmp_path):
    # bench_corpus --pool reads runs' frames tables back: the same rows must give the same report (booleans,
    # numbers and empty cells as run_recording wrote them), and a table given twice is refused
    from bench_corpus import _pooled, _report, read_frames, write_frames

    path = tmp_path / "slice_frames.csv"
    write_frames(rows, path)
    back = read_frames(path)
    assert len(back) == len(rows)
    assert _report(back, "") == _report(rows, "")
    assert _pooled([path, path], None, "") == 2
    # a table that is not one of bench_corpus's is refused, not read into a traceback
    other = tmp_path / "other.csv"
    other.write_text("a,b\n1,2\n")
    assert _pooled([other], None, "") == 2
