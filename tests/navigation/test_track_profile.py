"""``nav track --sound-speed-profile``: travel times through a thermocline become horizontal ranges along the ray."""

import csv
import json

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.navigation.models import closing_speed
from seamodem.water import RayTracer, SoundSpeedProfile, TravelTimeTable

BEACON, BEACON_DEPTH, VEHICLE_DEPTH = (50.0, 300.0), 25.0, 5.0


def _write(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    """A straight leg at 1 m/s, 300 m from a beacon 25 m deep; the vehicle at 5 m; travel times traced."""
    d = tmp_path_factory.mktemp("thermocline")
    _write(d / "svp.csv", ["depth_m", "c_mps"], [(0, 1530), (15, 1530), (35, 1490), (60, 1490)])
    tracer = RayTracer(SoundSpeedProfile([0, 15, 35], [1530, 1530, 1490]), water_depth_m=60.0)
    rng = np.random.default_rng(4)
    t_imu = np.arange(0, 150.0001, 0.25)
    _write(d / "imu.csv", ["t_s", "heading_rad", "omega_rad_s", "accel_mps2"],
           [(t, 0.002 * rng.normal(), 0.002 * rng.normal(), 0.002 * rng.normal()) for t in t_imu])
    _write(d / "truth.csv", ["t_s", "x_m", "y_m"], [(t, t, 0.0) for t in t_imu])
    t_meas = np.arange(3.0, 150.0, 3.0)
    horizontal = np.hypot(t_meas - BEACON[0], BEACON[1])
    table = TravelTimeTable(tracer, BEACON_DEPTH, [VEHICLE_DEPTH], np.arange(290.0, 330.0, 0.5))
    tof = table.travel_time(VEHICLE_DEPTH, horizontal) + 2e-6 * rng.normal(size=t_meas.size)  # 3 mm of noise
    rows = [(k, t - tt, t, tt, 1500.0 * tt, float(closing_speed(t, 0.0, 0.0, 1.0, BEACON)), 15.0, 0.01, 0.01)
            for k, (t, tt) in enumerate(zip(t_meas, tof))]
    _write(d / "meas.csv", ["frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db",
                            "sigma_range_m", "sigma_v_r_mps"], rows)
    return d


def _error(d, *extra):
    out = d / f"track{len(extra)}.csv"
    code = main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--beacon", f"{BEACON[0]},{BEACON[1]}",
                 "--start", "0,0", "--start-speed", "1", "--truth", str(d / "truth.csv"), "--depth",
                 str(VEHICLE_DEPTH), str(BEACON_DEPTH), "--filter", "inertial-range", "-o", str(out), *extra])
    assert code == 0
    return json.loads(out.with_suffix(".json").read_text())["mean_error_m"]


def test_the_profile_removes_the_range_bias_of_a_wrong_sound_speed(mission):
    wrong = _error(mission)  # range_m = 1500 m/s × tof: about 1.3 % (4 m) short of the truth at 300 m
    right = _error(mission, "--sound-speed-profile", str(mission / "svp.csv"))
    assert right < 0.25 * wrong, (right, wrong)


def test_a_profile_without_depths_is_a_one_line_error(mission, capsys):
    code = main(["nav", "track", str(mission / "meas.csv"), "--imu", str(mission / "imu.csv"), "--beacon", "50,300",
                 "--start", "0,0", "--sound-speed-profile", str(mission / "svp.csv"), "-o", str(mission / "x.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "depth" in err and len(err.strip().splitlines()) == 1


def test_a_bad_profile_file_is_a_one_line_error_naming_it(mission, capsys):
    bad = mission / "bad.csv"
    bad.write_text("depth_m,c_mps\n0,1500\n10,1500\n5,1500\n")
    code = main(["nav", "track", str(mission / "meas.csv"), "--imu", str(mission / "imu.csv"), "--beacon", "50,300",
                 "--start", "0,0", "--depth", "5", "25", "--sound-speed-profile", str(bad), "-o", str(mission / "y.csv")])
    err = capsys.readouterr().err
    assert code == 2 and str(bad) in err and "increase strictly" in err and len(err.strip().splitlines()) == 1


def test_the_vehicle_depth_can_come_from_its_depth_sensor_log(mission):
    _write(mission / "depth.csv", ["t_s", "depth_m"], [(t, VEHICLE_DEPTH) for t in np.arange(0.0, 151.0, 0.5)])
    out = mission / "track_log.csv"
    code = main(["nav", "track", str(mission / "meas.csv"), "--imu", str(mission / "imu.csv"), "--beacon",
                 f"{BEACON[0]},{BEACON[1]}", "--start", "0,0", "--start-speed", "1", "--truth", str(mission / "truth.csv"),
                 "--depth-log", str(mission / "depth.csv"), "--beacon-depth", str(BEACON_DEPTH), "--filter",
                 "inertial-range", "--sound-speed-profile", str(mission / "svp.csv"), "-o", str(out)])
    assert code == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    # the same ranges as with --depth 5 25: the same track
    assert sidecar["mean_error_m"] == pytest.approx(_error(mission, "--sound-speed-profile", str(mission / "svp.csv")),
                                                    abs=1e-6)
    assert sidecar["inputs"]["sound_speed_profile"].endswith("svp.csv")
