"""``seamodem demo``: the whole chain on a short mission, checked against the geometry it simulated."""

import csv
import json

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.demo import DemoConfig
from seamodem.errors import ConfigError


def _rows(path):
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return list(csv.DictReader(lines))


def test_short_demo_positions_the_vehicle_from_decoded_frames(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--duration", "12", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "frames: 4 emitted, 4 detected" in printed
    for name in ("summary.json", "demo_config.json", "measurements.csv", "imu.csv", "truth.csv",
                 "track_inertial.csv", "track_batch.csv", "track_proposed.csv", "track_rosb.csv", "map.png", "errors.png", "psd.png", "constellation.png"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    # frames at 0, 3, 6, 9 s, all above 9 dB in-band SNR: every one is found and its payload comes back
    assert summary["frames_emitted"] == summary["frames_detected"] == 4
    assert summary["payloads_correct"] == 4
    # independent of the channel code: slant range = |vehicle(t_arrival) − beacon| from truth.csv and the config
    cfg = json.loads((out / "demo_config.json").read_text())["demo"]
    truth = np.loadtxt(out / "truth.csv", delimiter=",", skiprows=1)
    meas = _rows(out / "measurements.csv")
    t_a = np.array([float(r["t_arrival_s"]) for r in meas])
    xy = np.c_[np.interp(t_a, truth[:, 0], truth[:, 1]), np.interp(t_a, truth[:, 0], truth[:, 2])]
    geometric = np.hypot(*(xy - cfg["beacon_xy_m"]).T)  # equal depths: slant = horizontal
    # 2 cm: the receiver's multipath bias (mm) plus linear interpolation of the 0.25 s track at 1 m/s (< 1 mm)
    np.testing.assert_allclose([float(r["range_m"]) for r in meas], geometric, atol=0.02)
    assert [r["payload_text"] for r in meas] == [f"seamodem demo frame {k}" for k in range(4)]
    # the filters start at the GNSS fix: after 12 s of IMU and 4 fixes they have drifted by less than a metre
    for source in ("waveform", "emulated"):
        for f in ("inertial", "batch", "proposed", "rosb"):
            assert summary["positioning"][source][f]["mean_error_m"] < 1.0, (source, f)


def test_demo_bad_options_are_one_line_errors(tmp_path, capsys):
    assert main(["demo", "--tcom", "0", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("seamodem demo: error:") and "tcom_s" in err and "\n" not in err
    assert main(["demo", "--duration", "1", "-o", str(tmp_path / "x")]) == 2
    assert "duration_s" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_demo_config_validates():
    with pytest.raises(ConfigError, match="n_lanes"):
        DemoConfig(n_lanes=1)
    with pytest.raises(ConfigError, match="depth_m"):
        DemoConfig(depth_m=30.0)
    assert DemoConfig().frame_count() == 51  # 151 s survey at T_com = 3 s: frames at 0 … 150 s


def test_demo_progress_names_each_stage_in_order(tmp_path, capsys):
    # the stage bar (on stderr, forced on here: by default it shows on a terminal only) names the stage that
    # is running, so a first run's minute of compiling is seen to be the filters'
    from seamodem.demo import run_demo

    run_demo(DemoConfig(duration_s=6.0), tmp_path / "demo", plots=False, progress=True)
    err = capsys.readouterr().err
    stages = ["demo: beacon and channel", "demo: receiver and decoder (2 frames)", "demo: filters",
              "demo: files and figures"]
    at = [err.find(s) for s in stages]
    assert -1 not in at and at == sorted(at), (at, err[-500:])
    assert "4/4" in err  # the last stage counted done
