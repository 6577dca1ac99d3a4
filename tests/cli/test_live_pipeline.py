"""Issue 27 end to end: ``producer | seamodem rx - | seamodem nav track - --follow --nmea udp://...``.

The producer writes a simulated recording (``seamodem tx`` → ``seamodem channel``, examples/scenarios/
straight_line.toml: 1.5 m/s east past a beacon) faster than real time; a UDP listener in the test receives
the NMEA sentences and checks each position against the scenario's truth. No timing is asserted.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.navigation.geometry import geodetic_to_local, local_to_geodetic

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 600  # s: numba compiles the filter on a first run, on a loaded 2-core machine
BEACON_LATLON = (43.1, 5.9)
START_XY, SPEED = (-200.0, 80.0), 1.5  # the scenario's vehicle at t = 0, east at 1.5 m/s

PRODUCER = """
import sys, time
data = open(sys.argv[1], 'rb').read()
speed, fs, step = float(sys.argv[2]), 96153 * 4, 1 << 14  # float32 mono: fs * 4 bytes per second
t0 = time.monotonic()
for i in range(0, len(data), step):
    sys.stdout.buffer.write(data[i:i + step])
    sys.stdout.buffer.flush()
    wait = t0 + (i + step) / fs / speed - time.monotonic()
    if wait > 0:
        time.sleep(wait)
"""


def _env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("pipeline")
    assert main(["tx", "--preset", "jmse2024", "--count", "5", "--period", "3", "-o", str(d / "beacon.wav")]) == 0
    assert main(["channel", str(d / "beacon.wav"), "--scenario", str(ROOT / "examples/scenarios/straight_line.toml"),
                 "-o", str(d / "rec.wav")]) == 0
    t = np.arange(0.0, 20.0001, 0.25)  # the vehicle's AHRS: heading east (0 rad), no turn, no acceleration
    (d / "imu.csv").write_text("t_s,heading_rad,omega_rad_s,accel_mps2\n" + "".join(f"{x:.2f},0,0,0\n" for x in t))
    return d


def _nmea(datagram: bytes) -> list[str]:
    text = datagram.decode("ascii")
    assert text.startswith("$") and text.endswith("\r\n")
    body, cs = text[1:-2].split("*")
    value = 0
    for ch in body:
        value ^= ord(ch)
    assert int(cs, 16) == value
    return body.split(",")


def _degrees(field: str, hemisphere: str, digits: int) -> float:
    value = int(field[:digits]) + float(field[digits:]) / 60.0
    return -value if hemisphere in "SW" else value


def test_pipe_to_positions_over_udp_match_the_truth(recording):
    d = recording
    start = ",".join(f"{float(v):.10f}" for v in local_to_geodetic(*START_XY, *BEACON_LATLON))
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", 0))
    listener.settimeout(TIMEOUT)
    port = listener.getsockname()[1]
    rx = [sys.executable, "-m", "seamodem", "rx", "-", "--config", str(d / "rec.json"), "-o", "-"]
    nav = [sys.executable, "-m", "seamodem", "nav", "track", "-", "--follow", "--imu", str(d / "imu.csv"),
           "--geodetic", "--beacon", ",".join(map(str, BEACON_LATLON)), "--start", start, "--start-speed",
           str(SPEED), "--depth", "5", "10", "--utc-start", "2026-11-26T00:00:00Z", "--nmea",
           f"udp://127.0.0.1:{port}", "-o", str(d / "track.jsonl")]
    env = _env()
    producer = subprocess.Popen([sys.executable, "-c", PRODUCER, str(d / "rec.wav"), "4"], stdout=subprocess.PIPE,
                                env=env)
    receiver = subprocess.Popen(rx, stdin=producer.stdout, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    producer.stdout.close()
    follower = subprocess.Popen(nav, stdin=receiver.stdout, stderr=subprocess.PIPE, env=env)
    receiver.stdout.close()
    sentences = []
    try:
        while len(sentences) < 10:  # 5 frames: a GGA and an RMC each
            sentences.append(_nmea(listener.recv(4096)))
    finally:
        listener.close()
    assert follower.wait(TIMEOUT) == 0, follower.stderr.read().decode()
    assert receiver.wait(TIMEOUT) == 0 and producer.wait(TIMEOUT) == 0
    gga = [s for s in sentences if s[0] == "GPGGA"]
    rmc = [s for s in sentences if s[0] == "GPRMC"]
    assert len(gga) == len(rmc) == 5
    for g in gga:
        t = int(g[1][:2]) * 3600 + int(g[1][2:4]) * 60 + float(g[1][4:])  # the stream's time (utc-start midnight)
        x, y = geodetic_to_local(_degrees(g[2], g[3], 2), _degrees(g[4], g[5], 3), *BEACON_LATLON)
        truth = (START_XY[0] + SPEED * t, START_XY[1])
        # ranges good to mm, a 1-m start σ, an exact AHRS: well inside 0.5 m; NMEA's 1e-6' is ≈ 2 mm
        assert np.hypot(x - truth[0], y - truth[1]) < 0.5, (t, x, y)
        assert g[6] == "1" and g[9] == "-5.00"
    for r in rmc:
        assert r[2] == "A" and float(r[7]) == pytest.approx(SPEED * 3600 / 1852, abs=0.05) and r[8] == "90.0"
    track = [json.loads(line) for line in (d / "track.jsonl").read_text().splitlines()]
    assert [p["frame_index"] for p in track] == [0, 1, 2, 3, 4]
    side = json.loads((d / "track.json").read_text())
    assert side["complete"] and side["ended"] == "end of stream" and side["positions"] == 5


@pytest.mark.parametrize("extra, message", [
    (["--nmea", "udp://127.0.0.1:5"], "nmea: NMEA positions are latitude, longitude: give --geodetic"),
    (["--geodetic", "--beacon", "43.1,5.9", "--nmea", "tcp://x:1"], "nmea: must be udp://HOST:PORT"),
    (["--smooth"], "smooth: not with --follow"),
    (["--filter", "proposed"], "filter: --follow runs the inertial filters"),
])
def test_follow_bad_options_are_one_line_exit_2(recording, capsys, extra, message):
    d = recording
    argv = ["nav", "track", str(d / "m.csv"), "--follow", "--imu", str(d / "imu.csv"), "--beacon", "0,0",
            "--start", "0,0", "-o", str(d / "t.csv"), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (d / "t.csv").exists()


def _nav_follow(d, *extra):
    return [sys.executable, "-m", "seamodem", "nav", "track", "-", "--follow", "--imu", str(d / "imu.csv"),
            "--beacon", "0,0", "--start=-200,80", "--start-speed", "1.5", *extra]


def _record_line(k: int) -> bytes:
    t = 3.0 * k + 0.14
    x = START_XY[0] + SPEED * t
    r = float(np.hypot(x, START_XY[1]))
    return (json.dumps({"frame_index": k, "t_emit_s": 3.0 * k, "t_arrival_s": t, "tof_s": r / 1500, "range_m": r,
                        "v_r_mps": -SPEED * x / r, "snr_db": 15.0, "sigma_range_m": 0.01,
                        "sigma_v_r_mps": 0.01}) + "\n").encode()


def test_follow_stalled_input_exit_3_and_ctrl_c_exit_130(recording, tmp_path):
    d = recording
    for extra, action, code, reason in ((["--stall-timeout", "2"], None, 3, "stalled"),
                                        ([], signal.SIGINT, 130, "interrupted")):
        out = tmp_path / f"{reason}.csv"
        proc = subprocess.Popen(_nav_follow(d, *extra, "-o", str(out)), stdin=subprocess.PIPE,
                                stderr=subprocess.PIPE, env=_env())
        proc.stdin.write(_record_line(0) + _record_line(1))
        proc.stdin.flush()
        deadline = time.monotonic() + TIMEOUT
        while (time.monotonic() < deadline and proc.poll() is None
               and (not out.exists() or out.read_text().count("\n") < 3)):
            time.sleep(0.2)  # both positions written (header + 2 rows), the pipe still open
        if action is not None:
            proc.send_signal(action)
        assert proc.wait(TIMEOUT) == code, proc.stderr.read().decode()
        proc.stdin.close()
        err = proc.stderr.read().decode()
        assert reason in err and "Traceback" not in err
        side = json.loads(out.with_suffix(".json").read_text())
        assert side["ended"] == reason and side["positions"] == 2


def test_follow_with_fixed_lag_writes_the_filter_and_the_smoother_as_offline(recording, tmp_path):
    """``--follow --fixed-lag 4`` on a stream of records: each record's filter row as it comes, its smoothed row
    once the filter is 4 s past it, the last ones at the end; the smoothed rows are what ``nav track
    --fixed-lag 4`` writes at those times from the complete file."""
    d = recording
    lines = b"".join(_record_line(k) for k in range(6))
    (tmp_path / "m.jsonl").write_bytes(lines)
    out = tmp_path / "live.csv"
    proc = subprocess.run(_nav_follow(d, "--fixed-lag", "4", "-o", str(out)), input=lines, capture_output=True,
                          env=_env(), timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr.decode()
    assert "6 positions and 6 smoothed (4 s lag) written" in proc.stderr.decode()
    rows = list(csv.DictReader(out.open()))
    # frame k arrives at 3k + 0.14 s: the smoothed row of k comes after the filter row of k + 2 (6 s > 4 s later)
    order = [(r["estimate"], int(r["frame_index"])) for r in rows]
    assert order[:5] == [("filter", 0), ("filter", 1), ("filter", 2), ("smoothed", 0), ("filter", 3)]
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["fixed_lag_s"] == 4.0 and side["smoothed_positions"] == 6 and "smoothed" in side["estimates"]
    offline = tmp_path / "offline.csv"
    assert main(["nav", "track", str(tmp_path / "m.jsonl"), "--imu", str(d / "imu.csv"), "--beacon", "0,0",
                 "--start=-200,80", "--start-speed", "1.5", "--fixed-lag", "4", "-o", str(offline)]) == 0
    track = {float(r["t_s"]): r for r in csv.DictReader(offline.open())}
    for r in rows:
        if r["estimate"] == "smoothed":
            want = track[float(r["t_s"])]  # the offline file rounds to 1e-9
            for c in ("x_m", "y_m", "heading_rad", "speed_mps"):
                assert float(r[c]) == pytest.approx(float(want[c]), abs=2e-9), c
            assert float(r["lag_s"]) == (4.0 if float(r["t_s"]) + 4.0 <= 20.0 else pytest.approx(20.0 - float(r["t_s"])))
