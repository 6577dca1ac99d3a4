"""``rx - --array`` and ``rx - --reference`` write each record during the stream (docs/live.md).

The whole-recording receivers run on a stream in overlapping segments (seamodem.batch.live): every frame is
written once, none missed, each record as the whole file gives it up to what the segments change, and the
first record reaches stdout while the producer is still writing.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import soundfile as sf

from seamodem.cli import main

from array_recording import write_array_recording

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 300
EMIT = ["--emit-start", "0.3", "--emit-period", "1"]


def _env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}


def _rx(args) -> list[str]:
    return [sys.executable, "-m", "seamodem", "rx", *map(str, args)]


@pytest.fixture(scope="module")
def array_recording(tmp_path_factory):
    """Ten jmse2024 frames, one a second, on a 4-element tetrahedron (as tests/cli/test_rx_live_receivers.py)."""
    return write_array_recording(tmp_path_factory.mktemp("array"), 10)


@pytest.fixture(scope="module")
def ping_recording(tmp_path_factory):
    """Fourteen LFM pings, one a second, in white noise (about 31 dB in band)."""
    d = tmp_path_factory.mktemp("pings")
    assert main(["tx", "--reference", "lfm:19000-29000:0.05", "--count", "14", "--period", "1", "--start", "0.3",
                 "-o", str(d / "clean.wav"), "-q"]) == 0
    x, fs = sf.read(d / "clean.wav")
    sf.write(d / "pings.wav", x + 0.02 * np.random.default_rng(1).standard_normal(x.shape), fs, subtype="FLOAT")
    (d / "clean.json").rename(d / "pings.json")
    assert main(["rx", str(d / "pings.wav"), "--reference", str(d / "pings.json"), *EMIT, "-o",
                 str(d / "off.csv")]) == 0
    return d


def _close(off: pd.DataFrame, live: pd.DataFrame, *, angles: bool):
    """Each frame once, none missed; the stream's records as the file's, to what segmenting changes.

    The bounds (docs/live.md): arrival and time of flight to 1e-8 s, range to 1e-5 m (measured: 3e-9 s, 4 µm),
    v_r to 1e-4 m/s, the direction to 3e-4 rad (σ ≈ 3 mrad), SNR to 0.6 dB and the σ's to 20 %: each segment
    starts the front end, the impulse blanker and the noise estimates afresh.
    """
    assert list(live["frame_index"]) == list(off["frame_index"])
    assert list(live.columns) == list(off.columns)
    for c in ("t_arrival_s", "tof_s"):
        pd.testing.assert_series_equal(off[c], live[c], rtol=0, atol=1e-8)
    pd.testing.assert_series_equal(off["range_m"], live["range_m"], rtol=0, atol=1e-5)
    pd.testing.assert_series_equal(off["v_r_mps"], live["v_r_mps"], rtol=0, atol=1e-4)
    if angles:
        for c in ("azimuth_body_rad", "elevation_body_rad"):
            pd.testing.assert_series_equal(off[c], live[c], rtol=0, atol=3e-4)
    assert (off["snr_db"] - live["snr_db"]).abs().max() < 0.6
    pd.testing.assert_series_equal(off["sigma_range_m"], live["sigma_range_m"], rtol=0.2, atol=0)
    for c in ("crc_ok", "payload_hex"):
        if c in off:
            assert list(off[c].astype(str)) == list(live[c].astype(str))


def test_array_records_from_a_stream_in_segments_equal_the_file(array_recording):
    d = array_recording
    with open(d / "rx.wav", "rb") as f:
        p = subprocess.run(_rx(["-", "--config", d / "rx.json", "--array", "tetra:0.08", "--segment", "1.5",
                                "-o", d / "live.csv", "--no-status"]), stdin=f, capture_output=True, env=_env(),
                           timeout=TIMEOUT)
    assert p.returncode == 0, p.stderr.decode()
    _close(pd.read_csv(d / "off.csv"), pd.read_csv(d / "live.csv"), angles=True)
    assert json.loads((d / "live.csv.json").read_text())["complete"] is True


def test_reference_records_from_a_stream_in_segments_equal_the_file(ping_recording):
    d = ping_recording
    with open(d / "pings.wav", "rb") as f:
        p = subprocess.run(_rx(["-", "--reference", d / "pings.json", *EMIT, "--segment", "2", "-o",
                                d / "live.csv", "--no-status"]), stdin=f, capture_output=True, env=_env(),
                           timeout=TIMEOUT)
    assert p.returncode == 0, p.stderr.decode()
    off, live = pd.read_csv(d / "off.csv"), pd.read_csv(d / "live.csv")
    assert len(off) == 14
    _close(off, live, angles=False)
    assert list(live["reference"]) == list(off["reference"])


def _lines(stream, out: queue.Queue):
    for line in stream:
        out.put(line)
    out.put(None)


@pytest.mark.parametrize("kind", ["array", "reference"])
def test_the_first_record_is_written_before_the_stream_ends(kind, array_recording, ping_recording):
    if kind == "array":
        wav, args = array_recording / "rx.wav", ["--config", array_recording / "rx.json", "--array", "tetra:0.08"]
    else:
        wav, args = ping_recording / "pings.wav", ["--reference", ping_recording / "pings.json", *EMIT]
    data = wav.read_bytes()
    half = int(0.45 * len(data))  # the header and the first 4.6 s (array) or 6.4 s (pings) of the stream
    p = subprocess.Popen(_rx(["-", *args, "--segment", "1", "-o", "-", "--no-status"]), stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env(), text=False)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=_lines, args=(p.stdout, lines), daemon=True).start()
    try:
        p.stdin.write(data[:half])  # and the pipe stays open
        p.stdin.flush()
        header = json.loads(lines.get(timeout=TIMEOUT))
        assert header["complete"] is False
        first = json.loads(lines.get(timeout=TIMEOUT))  # a record, while the producer has not finished
        assert first["frame_index"] == 0 and p.poll() is None
        p.stdin.write(data[half:])
        p.stdin.close()
        rest = []
        while (line := lines.get(timeout=TIMEOUT)) is not None:
            rest.append(json.loads(line))
        assert p.wait(timeout=TIMEOUT) == 0, p.stderr.read().decode()
    finally:
        p.kill()
        p.wait()
    records = [first, *rest]
    assert [r["frame_index"] for r in records] == list(range(10 if kind == "array" else 14))
