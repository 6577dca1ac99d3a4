"""Following records as they arrive: a growing file, a stream; each position equals the offline filter's."""

import csv
import json
import math
import os
import threading
import time

import numpy as np
import pytest

from seamodem.errors import InputFileError
from seamodem.navigation.follow import FollowTracker, RecordFollower
from seamodem.navigation.models import closing_speed
from seamodem.navigation.track import run_track
from seamodem.receive.records import STREAM_HEADER_PREFIX

BEACON = (50.0, 30.0)
HEADER = ["frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db", "sigma_range_m",
          "sigma_v_r_mps"]


@pytest.fixture
def mission(tmp_path):
    """Straight leg at 1 m/s along x past the beacon, IMU at 4 Hz, one frame every 3 s (as tests/navigation/test_track)."""
    rng = np.random.default_rng(8)
    t_imu = np.arange(0, 60.0001, 0.25)
    with open(tmp_path / "imu.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "heading_rad", "omega_rad_s", "accel_mps2"])
        w.writerows((t, 0.01 * rng.normal(), 0.01 * rng.normal(), 0.01 * rng.normal()) for t in t_imu)
    rows = []
    for k, t in enumerate(np.arange(3.1, 60.0, 3.0)):
        d = math.hypot(t - BEACON[0], -BEACON[1])
        vr = float(closing_speed(t, 0.0, 0.0, 1.0, BEACON))
        rows.append([k, t - d / 1500, t, d / 1500, d + 0.05 * rng.normal(), vr + 0.05 * rng.normal(), 12.0, 0.05,
                     0.05])
    return tmp_path, rows


def test_a_growing_file_is_followed_until_its_sidecar_says_complete(mission):
    d, rows = mission
    path, side = d / "m.csv", d / "m.csv.json"
    side.write_text(json.dumps({"format": "seamodem.measurements/2", "complete": False}))
    f = open(path, "w", newline="")
    w = csv.writer(f)
    w.writerow(HEADER)
    f.flush()

    def writer():
        for r in rows:
            w.writerow(r)
            f.flush()
            time.sleep(0.01)
        f.close()
        side.write_text(json.dumps({"format": "seamodem.measurements/2", "complete": True}))

    th = threading.Thread(target=writer)
    th.start()
    got = list(RecordFollower(str(path), poll_s=0.005))
    th.join()
    assert [int(g["frame_index"]) for g in got] == [r[0] for r in rows]
    assert all(g["range_m"] == pytest.approx(r[4], rel=1e-15) for g, r in zip(got, rows))


def test_a_stream_with_its_sidecar_line_first_csv_and_jsonl(mission, monkeypatch):
    d, rows = mission
    for kind in ("csv", "jsonl"):
        r_fd, w_fd = os.pipe()
        if kind == "csv":
            text = STREAM_HEADER_PREFIX + json.dumps({"format": "x", "sound_speed_mps": 1500}) + "\n"
            text += ",".join(HEADER) + "\n" + "".join(",".join(map(str, r)) + "\n" for r in rows)
        else:
            text = json.dumps({"format": "x", "sound_speed_mps": 1500}) + "\n"
            text += "".join(json.dumps(dict(zip(HEADER, r))) + "\n" for r in rows)
        os.write(w_fd, text.encode())
        os.close(w_fd)
        monkeypatch.setattr(os, "dup", lambda fd, r=r_fd: r)  # stdin is the pipe
        follower = RecordFollower("-")
        got = list(follower)
        assert follower.metadata["sound_speed_mps"] == 1500 and follower.end_reason == "end of stream"
        assert [g["t_arrival_s"] for g in got] == [r[2] for r in rows]
        follower.close()


def test_stall_timeout_ends_a_stream_that_stays_open(monkeypatch):
    r_fd, w_fd = os.pipe()
    monkeypatch.setattr(os, "dup", lambda fd: r_fd)
    follower = RecordFollower("-", idle_timeout_s=0.3)
    assert list(follower) == [] and follower.end_reason == "stalled"
    os.close(w_fd)
    follower.close()


def test_bad_inputs_are_one_line_errors(tmp_path):
    with pytest.raises(InputFileError, match="measurement file not found"):
        RecordFollower(str(tmp_path / "none.csv"))
    (tmp_path / "m.txt").write_text("x")
    with pytest.raises(InputFileError, match="must end in .csv or .jsonl"):
        RecordFollower(str(tmp_path / "m.txt"))


def test_each_position_is_the_offline_filters_state_at_that_record(mission):
    """The filter is causal: run once over the whole mission, its state at each record's node is what the
    follower, which saw only the records and IMU up to then, reports."""
    d, rows = mission
    options = dict(beacon_xy=BEACON, start_xy=(0.0, 0.0), start_speed_mps=1.0)
    tracker = FollowTracker(d / "imu.csv", options)
    live = [tracker.add(dict(zip(HEADER, map(float, r)))) for r in rows]
    from seamodem.navigation.logs import read_imu

    meas = {k: np.array([r[i] for r in rows], dtype=float) for i, k in enumerate(HEADER)}
    offline = run_track(meas, read_imu(d / "imu.csv"), **options)
    for pos in live:
        k = int(np.flatnonzero(offline["t_s"] == pos["t_s"])[-1])
        # same operations in the same order up to this node: equal to rounding (1e-9 m on ~100 m)
        np.testing.assert_allclose([pos["x_m"], pos["y_m"]], offline["state"][k, :2], rtol=0, atol=1e-9)
        assert pos["status"] == "accepted"
    assert tracker.add({"t_arrival_s": 70.0, "range_m": math.nan}) is None  # no emission, no range: no position
