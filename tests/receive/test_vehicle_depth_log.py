"""A vehicle that changes depth: its depth log in the receiver's settings (``ReceiverSettings.vehicle_depth_log``,
``rx --vehicle-depth-log``), each frame's merged surface image predicted at the depth of its arrival.

On a far corpus recording (benchmarks/corpus.py, independent of seamodem.channel) whose vehicle dives from 1.5 m
at 0.3 m/s, the image's delay 2·z_b·z_v/(R·c) grows with the depth: given its depth at the start alone, the
receiver takes out the bias of an image that is no longer there and its σ stops covering the error as the
vehicle goes down; given the log, every frame's range is within 3σ."""

import sys
from pathlib import Path

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.receive.settings import ReceiverSettings

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def test_the_depth_at_a_time_is_the_logs_between_its_samples_and_its_ends_outside():
    s = ReceiverSettings(vehicle_depth_log=([0.0, 10.0, 20.0], [2.0, 4.0, 4.0]))
    assert [s.vehicle_depth_at(t) for t in (-5.0, 0.0, 5.0, 15.0, 99.0)] == [2.0, 2.0, 3.0, 4.0, 4.0]
    assert ReceiverSettings(vehicle_depth_m=7.0).vehicle_depth_at(3.0) == 7.0
    assert ReceiverSettings().vehicle_depth_at(3.0) is None
    assert ReceiverSettings.from_dict(s.to_dict()) == s


@pytest.mark.parametrize("log, words", [
    (([0.0, 0.0], [1.0, 2.0]), "increase strictly"),
    (([0.0, 1.0], [1.0]), "as many depths as times"),
    (([0.0], [-1.0]), ">= 0"),
    (([0.0], [float("nan")]), "finite"),
    ("deep", "two sequences"),
])
def test_a_log_that_cannot_be_one_is_refused(log, words):
    with pytest.raises(ConfigError, match=words):
        ReceiverSettings(vehicle_depth_log=log)
    with pytest.raises(ConfigError, match="not both"):
        ReceiverSettings(vehicle_depth_m=3.0, vehicle_depth_log=([0.0], [3.0]))


def test_a_diving_vehicles_ranges_are_covered_with_its_depth_log_and_not_with_its_start_depth(monkeypatch):
    import bench_corpus
    import corpus

    def diving(family, seed):
        sc = corpus.draw_scenario(family, seed)
        sc.track["z"], sc.track["climb_mps"] = -1.5, -0.3
        return sc

    made = {}  # the recording synthesized once for both receivers
    synthesized = bench_corpus.recording

    def once(*args):
        if args not in made:
            made[args] = synthesized(*args)
        return made[args]

    monkeypatch.setattr(bench_corpus, "draw_scenario", diving)
    monkeypatch.setattr(bench_corpus, "recording", once)
    z = {}
    for log in (True, False):
        rows = bench_corpus.run_recording("far", 31001, 9, depths=True, depth_log=log)
        assert all(r["detected"] for r in rows)
        z[log] = np.array([(r["range_m"] - r["range_true_m"]) / r["sigma_range_m"] for r in rows])
    assert len(made) == 1
    assert np.all(np.abs(z[True]) <= 3), z[True]
    assert np.max(np.abs(z[False])) > 3, z[False]  # measured: errors 3.8 → 11.7 mm as it dives, frame 8 at 3.4σ
