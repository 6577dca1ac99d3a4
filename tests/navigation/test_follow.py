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
from seamodem.navigation.logs import read_imu
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


def _records(rows):
    return [dict(zip(HEADER, map(float, r))) for r in rows]


def _offline(rows, imu, options, **smooth):
    meas = {k: np.array([r[i] for r in rows], dtype=float) for i, k in enumerate(HEADER)}
    return run_track(meas, imu, **options, **smooth)


def _state(pos):
    return [pos["x_m"], pos["y_m"], pos["heading_rad"], pos["speed_mps"], pos["var_x_m2"], pos["cov_xy_m2"],
            pos["var_y_m2"]]


def _offline_state(out, k):
    return [*out["state"][k, :4], out["cov"][k, 0, 0], out["cov"][k, 0, 1], out["cov"][k, 1, 1]]


@pytest.mark.parametrize("lag_s", [3.0, 10.0])
def test_each_position_is_the_offline_filters_and_fixed_lag_smoothers_at_that_record(mission, lag_s):
    """The filter is causal: stepped record by record (keeping its state), its state and covariance at each
    record's node are those of one offline run over the whole mission; the smoothed position written once the
    filter is lag_s past a record is the offline fixed-lag smoother's at that node (the last ones at the end,
    their lag shortened as offline)."""
    d, rows = mission
    options = dict(beacon_xy=BEACON, start_xy=(0.0, 0.0), start_speed_mps=1.0)
    tracker = FollowTracker(d / "imu.csv", options, lag_s=lag_s)
    live, seen = [], []
    for row in _records(rows):
        got = tracker.add(row)
        assert got[0]["estimate"] == "filter" and got[0]["t_s"] == row["t_arrival_s"]  # the filter's comes first
        for pos in got[1:]:  # written once the filter is lag_s past the record, not before
            assert pos["estimate"] == "smoothed" and pos["lag_s"] == lag_s and row["t_arrival_s"] >= pos["t_s"] + lag_s
        live += got
        seen.append(row["t_arrival_s"])
    live += tracker.finish()
    imu = read_imu(d / "imu.csv")
    filt = _offline(rows, imu, options)
    smooth = _offline(rows, imu, options, smooth="fixed-lag", lag_s=lag_s)
    assert not filt["run"].windows.any()  # no re-linearized window here: every number equals the offline one
    filtered = [p for p in live if p["estimate"] == "filter"]
    smoothed = [p for p in live if p["estimate"] == "smoothed"]
    assert [p["frame_index"] for p in filtered] == [p["frame_index"] for p in smoothed] == [r[0] for r in rows]
    for pos in filtered:
        k = int(np.flatnonzero(filt["t_s"] == pos["t_s"])[0])
        # same operations in the same order up to this node: equal to rounding (1e-9 m on ~100 m)
        np.testing.assert_allclose(_state(pos), _offline_state(filt, k), rtol=1e-12, atol=1e-9)
        assert pos["status"] == "accepted" and pos["lag_s"] == 0.0
    for pos in smoothed:
        k = int(np.flatnonzero(smooth["t_s"] == pos["t_s"])[0])
        np.testing.assert_allclose(_state(pos), _offline_state(smooth, k), rtol=1e-12, atol=1e-9)
        assert pos["lag_s"] == (lag_s if pos["t_s"] + lag_s <= imu["t_s"][-1] else imu["t_s"][-1] - pos["t_s"])
    # the smoother moved the positions (it is not the filter's again)
    assert max(abs(s["x_m"] - f["x_m"]) for s, f in zip(smoothed, filtered)) > 1e-3
    assert tracker.add({"t_arrival_s": 70.0, "range_m": math.nan}) == []  # no emission, no range: no position


def test_a_window_re_linearization_after_the_lag_is_the_only_difference_from_offline(mission):
    """A frame 0.4 m off makes the filter re-solve the last 120 s. The real-time position at each record is the
    offline run's online position exactly; its state and the smoothed one equal the offline ones except where
    that window, run after the record (after record + lag for the smoother), rewrote a node between them."""
    d, rows = mission
    rows = [list(r) for r in rows]
    rows[12][4] += 0.4
    options = dict(beacon_xy=BEACON, start_xy=(0.0, 0.0), start_speed_mps=1.0)
    lag = 6.0
    tracker = FollowTracker(d / "imu.csv", options, lag_s=lag)
    live = [p for row in _records(rows) for p in tracker.add(row)] + tracker.finish()
    imu = read_imu(d / "imu.csv")
    filt = _offline(rows, imu, options)
    smooth = _offline(rows, imu, options, smooth="fixed-lag", lag_s=lag)
    run = filt["run"]
    t_windows = filt["t_s"][np.flatnonzero(run.windows)]
    assert t_windows.size  # the scenario does what it is for
    window_s = run.config.window_s
    differ = 0
    for pos in live:
        k = int(np.flatnonzero(filt["t_s"] == pos["t_s"])[0])
        lag_k = 0.0 if pos["estimate"] == "filter" else lag
        if pos["estimate"] == "filter":
            np.testing.assert_allclose([pos["x_m"], pos["y_m"]], run.online_xy[k], rtol=0, atol=1e-9)
        rewritten = any(t_w > pos["t_s"] + lag_k and t_w - window_s <= pos["t_s"] + lag_k for t_w in t_windows)
        expected = _offline_state(filt if pos["estimate"] == "filter" else smooth, k)
        if rewritten:
            differ += not np.allclose(_state(pos), expected, rtol=1e-12, atol=1e-9)
        else:
            np.testing.assert_allclose(_state(pos), expected, rtol=1e-12, atol=1e-9)
    assert differ > 0


def test_the_imu_log_is_read_as_it_grows_and_a_record_waits_for_it(mission):
    """A record whose arrival the IMU log has not reached yet waits; it comes with the next record once the log
    has grown, and the positions equal those of the whole log."""
    d, rows = mission
    lines = (d / "imu.csv").read_text().splitlines(keepends=True)
    growing = d / "imu_growing.csv"
    growing.write_text("".join(lines[:30]))  # header + samples to t = 7.0 s
    options = dict(beacon_xy=BEACON, start_xy=(0.0, 0.0), start_speed_mps=1.0)
    tracker = FollowTracker(growing, options)
    reference = FollowTracker(d / "imu.csv", options)
    records = _records(rows)
    first = tracker.add(records[0]) + tracker.add(records[1])  # t = 3.1 and 6.1 s: the log reaches them
    assert [p["frame_index"] for p in first] == [0, 1]
    assert tracker.add(records[2]) == []  # 9.1 s waits for the log
    with open(growing, "a") as f:
        f.write("".join(lines[30:]))
    got = tracker.add(records[3])
    assert [p["frame_index"] for p in got] == [2, 3]
    want = [p for r in records[:4] for p in reference.add(r)]
    np.testing.assert_array_equal([_state(p) for p in first + got], [_state(p) for p in want])
