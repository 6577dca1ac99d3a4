"""The array and reference receivers read a stream (``seamodem rx -``) as they read the file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from seamodem.cli import main

from array_recording import write_array_recording

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 300


def _run(args, stdin_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    with open(stdin_path, "rb") as f:
        return subprocess.run([sys.executable, "-m", "seamodem", "rx", *map(str, args)], stdin=f,
                              capture_output=True, env=env, timeout=TIMEOUT)


def _same(a: Path, b: Path):
    pd.testing.assert_frame_equal(pd.read_csv(a), pd.read_csv(b))


def _close(a: Path, b: Path):
    """Live (2^13-sample FFT blocks) against the file (2^16): the bounds of docs/live.md, "Same answers"."""
    off, live = pd.read_csv(a), pd.read_csv(b)
    assert list(off["frame_index"]) == list(live["frame_index"]) and list(off.columns) == list(live.columns)
    for c in ("t_arrival_s", "tof_s", "range_m", "v_r_mps"):
        pd.testing.assert_series_equal(off[c], live[c], rtol=1e-9, atol=0)
    for c in ("azimuth_body_rad", "elevation_body_rad"):  # 1e-6 rad: 0.06 mdeg, against σ ≈ 3 mrad here
        pd.testing.assert_series_equal(off[c], live[c], rtol=0, atol=1e-6)
    assert (off["snr_db"] - live["snr_db"]).abs().max() < 0.01
    for c in ("sigma_range_m", "sigma_v_r_mps"):
        pd.testing.assert_series_equal(off[c], live[c], rtol=1e-3, atol=0)
    for c in ("crc_ok", "payload_hex"):
        if c in off:
            assert list(off[c].astype(str)) == list(live[c].astype(str))


def test_array_from_a_stream_equals_the_file(tmp_path):
    # tests/array/test_array_cli.py's recording, shorter: two frames on a 4-element tetrahedron
    write_array_recording(tmp_path, 2)
    p = _run(["-", "--config", tmp_path / "rx.json", "--array", "tetra:0.08", "-o", tmp_path / "live.csv"],
             tmp_path / "rx.wav")
    assert p.returncode == 0, p.stderr.decode()
    # the file's records as a live run gives them, each at once (--lookahead 0: no later frames' pools)
    assert main(["rx", str(tmp_path / "rx.wav"), "--array", "tetra:0.08", "--lookahead", "0", "-q",
                 "-o", str(tmp_path / "off0.csv")]) == 0
    _close(tmp_path / "off0.csv", tmp_path / "live.csv")


def test_reference_pings_from_a_stream_equal_the_file(tmp_path):
    assert main(["tx", "--reference", "lfm:19000-29000:0.05", "--count", "3", "--period", "1", "--start", "0.3",
                 "-o", str(tmp_path / "pings.wav")]) == 0
    # a stream has no sidecar beside it: the emission times are given
    emit = ["--emit-start", "0.3", "--emit-period", "1"]
    assert main(["rx", str(tmp_path / "pings.wav"), "--reference", str(tmp_path / "pings.json"), *emit, "-o",
                 str(tmp_path / "off.csv")]) == 0
    p = _run(["-", "--reference", tmp_path / "pings.json", *emit, "-o", tmp_path / "live.csv"],
             tmp_path / "pings.wav")
    assert p.returncode == 0, p.stderr.decode()
    _same(tmp_path / "off.csv", tmp_path / "live.csv")
