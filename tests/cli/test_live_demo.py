"""Issue 27: the demo mission's recording streamed through the live pipeline ends with the demo's errors.

``seamodem demo --keep-audio`` (45 s of the default survey) keeps its hydrophone recording. Streamed into
``seamodem rx -`` and on into ``seamodem nav track - --follow``, it gives the records the demo measured
from the file, and positions equal to the offline filter's on them; ``nav track --truth`` on the streamed
records reports the demo's position errors (the demo's own summary takes them at the IMU instants,
``nav track`` at every state: the mean and RMS can differ in the last digit, the final error cannot).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from seamodem.cli import main

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 600  # s: numba compiles on a first run, on a loaded 2-core machine
NAV = ["--imu", "imu.csv", "--beacon", "45,-25", "--start", "0,0", "--start-speed", "1"]  # docs/guide.md's


def _cli(*args) -> list[str]:
    return [sys.executable, "-c", "import sys; from seamodem.cli import main; sys.exit(main())", *args]


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    d = tmp_path_factory.mktemp("live_demo")
    assert main(["demo", "--duration", "45", "--keep-audio", "--no-plots", "-q", "-o", str(d)]) == 0
    return d


def test_the_demo_recording_streamed_live_gives_the_demo_errors(demo):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    rx = ["rx", "-", "--emit-start", "0", "--emit-period", "3", "-q"]
    with open(demo / "received.wav", "rb") as wav:
        producer = subprocess.Popen(_cli(*rx, "-o", "-"), stdin=wav, stdout=subprocess.PIPE, cwd=demo, env=env)
        nav = subprocess.run(_cli("nav", "track", "-", "--follow", *NAV, "-o", "follow.csv"), stdin=producer.stdout,
                             cwd=demo, env=env, capture_output=True, text=True, timeout=TIMEOUT)
        producer.stdout.close()
        assert producer.wait(timeout=TIMEOUT) == 0
    assert nav.returncode == 0, nav.stderr
    with open(demo / "received.wav", "rb") as wav:
        subprocess.run(_cli(*rx, "-o", "stream.csv"), stdin=wav, cwd=demo, env=env, check=True, timeout=TIMEOUT)

    # the stream's records are the file's (the demo's), to the stream-versus-file tolerances
    streamed, offline = pd.read_csv(demo / "stream.csv"), pd.read_csv(demo / "measurements.csv")
    assert list(streamed.frame_index) == list(offline.frame_index) == list(range(15))
    np.testing.assert_allclose(streamed.tof_s, offline.tof_s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(streamed.v_r_mps, offline.v_r_mps, rtol=0, atol=1e-7)

    # the following filter's positions are the offline filter's at the records
    assert main(["nav", "track", str(demo / "stream.csv"), *[str(demo / a) if a == "imu.csv" else a for a in NAV],
                 "--truth", str(demo / "truth.csv"), "-o", str(demo / "off.csv")]) == 0
    follow, track = pd.read_csv(demo / "follow.csv"), pd.read_csv(demo / "off.csv")
    follow = follow[follow.estimate == "filter"]
    assert len(follow) == 15
    at = pd.merge_asof(follow[["t_s"]], track, on="t_s", direction="nearest", tolerance=1e-6)
    np.testing.assert_allclose(follow.x_m, at.x_m, rtol=0, atol=1e-6)
    np.testing.assert_allclose(follow.y_m, at.y_m, rtol=0, atol=1e-6)

    # and the errors against the truth are the demo's
    summary = json.loads((demo / "summary.json").read_text())["positioning"]["waveform"]["inertial"]
    errors = json.loads((demo / "off.json").read_text())
    assert errors["final_error_m"] == pytest.approx(summary["final_error_m"], abs=1e-3)
    assert errors["mean_error_m"] == pytest.approx(summary["mean_error_m"], abs=0.01)
    assert errors["rms_error_m"] == pytest.approx(summary["rms_error_m"], abs=0.01)
