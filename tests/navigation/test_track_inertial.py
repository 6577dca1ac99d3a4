"""``nav track`` on the inertial filter: accuracy and covariance calibration on an analytic mission,
gated frames reported, GNSS fixes, irregular IMU time stamps, the command line's outputs."""

import csv
import json
import math

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.navigation.inertial import InertialConfig
from seamodem.navigation.track import CHI2_2DOF_95, run_track

BEACON = (40.0, 25.0)
SPEED = 1.0
SIGMA_OMEGA, SIGMA_ACCEL, SIGMA_HEADING = 0.01, 0.01, math.radians(0.5)  # per IMU sample
BIAS = math.radians(1.5)  # constant heading-sensor bias the filter has to find
SIGMA_RANGE, SIGMA_VR = 0.05, 0.05


def truth(t):
    """Straight east for 40 s, a 90° left turn at 0.05 rad/s (31.4 s), then straight north: (x, y, ψ, ω)."""
    t = np.asarray(t, dtype=float)
    t1, w = 40.0, 0.05
    t2 = t1 + (math.pi / 2) / w
    R = SPEED / w
    x = np.where(t <= t1, SPEED * t, np.where(t <= t2, t1 + R * np.sin(w * (t - t1)), t1 + R))
    y = np.where(t <= t1, 0.0, np.where(t <= t2, R * (1 - np.cos(w * (t - t1))), R + SPEED * (t - t2)))
    psi = np.where(t <= t1, 0.0, np.where(t <= t2, w * (t - t1), math.pi / 2))
    omega = np.where((t > t1) & (t <= t2), w, 0.0)
    return x, y, psi, omega


def mission(seed, *, imu_t=None, t_end=120.0, tcom=3.0, outlier=None):
    rng = np.random.default_rng(seed)
    if imu_t is None:
        imu_t = np.arange(0.0, t_end + 1e-9, 0.25)
    x, y, psi, omega = truth(imu_t)
    # The sample at t covers the interval before it: its rate is the truth's mean rate over that interval.
    dpsi = np.diff(psi, prepend=0.0)
    dt = np.diff(imu_t, prepend=imu_t[0] - 0.25)
    rate = np.where(dt > 0, dpsi / dt, omega)
    imu = {"t_s": imu_t, "heading_rad": psi + BIAS + SIGMA_HEADING * rng.standard_normal(imu_t.size),
           "omega_rad_s": rate + SIGMA_OMEGA * rng.standard_normal(imu_t.size),
           "accel_mps2": SIGMA_ACCEL * rng.standard_normal(imu_t.size)}
    tf = np.arange(1.5, t_end, tcom)
    fx, fy, fpsi, _ = truth(tf)
    dx, dy = fx - BEACON[0], fy - BEACON[1]
    d = np.hypot(dx, dy)
    vr = -(dx * SPEED * np.cos(fpsi) + dy * SPEED * np.sin(fpsi)) / d
    n = tf.size
    meas = {"frame_index": np.arange(n, dtype=float), "t_emit_s": tf - d / 1500, "t_arrival_s": tf,
            "tof_s": d / 1500, "range_m": d + SIGMA_RANGE * rng.standard_normal(n),
            "v_r_mps": vr + SIGMA_VR * rng.standard_normal(n), "snr_db": np.full(n, 12.0),
            "sigma_range_m": np.full(n, SIGMA_RANGE), "sigma_v_r_mps": np.full(n, SIGMA_VR)}
    if outlier is not None:
        meas["range_m"][outlier] += 50.0
    return meas, imu


def config(dt=0.25):
    return InertialConfig(gyro_arw=SIGMA_OMEGA * math.sqrt(dt), accel_vrw=SIGMA_ACCEL * math.sqrt(dt),
                          heading_sigma_rad=SIGMA_HEADING)


def errors(out):
    x, y, _, _ = truth(out["t_s"])
    e = out["state"][:, :2] - np.c_[x, y]
    P = out["cov"][:, :2, :2]
    nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(P), e)
    return np.hypot(*e.T), nees, np.sqrt(P[:, 0, 0] + P[:, 1, 1])


def track(meas, imu, **kw):
    kw.setdefault("config", config())
    return run_track(meas, imu, beacon_xy=BEACON, start_xy=(0.0, 0.0), start_speed_mps=SPEED, **kw)


@pytest.mark.parametrize("smooth", [None, "batch", "fixed-lag"])
def test_accuracy_and_covariance_calibration(smooth):
    """Over 8 missions: the error stays within what the covariance says, and the 95 % ellipse holds the truth.

    Bound: with σ_d = σ_vr = 5 cm every 3 s and a 1-m start, the reported position σ (√trace P) settles
    at decimetres; a consistent filter's error is within 3 × that σ at ≥ 95 % of the states, and its mean
    position NEES is ≈ 2 (χ² with 2 dof). Loose limits (NEES mean in [0.5, 4], 95 %-ellipse coverage
    ≥ 85 %) because the errors of one mission are correlated in time.
    """
    inside, nees_all, mean_err = [], [], []
    for seed in range(8):
        meas, imu = mission(seed)
        out = track(meas, imu, smooth=smooth, lag_s=6.0 if smooth == "fixed-lag" else None)
        assert (out["frames"]["status"] == "accepted").all()
        err, nees, sigma = errors(out)
        assert np.mean(err <= 3 * sigma) >= 0.95
        inside.append(np.mean(nees <= CHI2_2DOF_95))
        nees_all.append(nees.mean())
        mean_err.append(err.mean())
    assert 0.5 <= np.mean(nees_all) <= 4.0, nees_all
    assert np.mean(inside) >= 0.85, inside
    # accuracy: decimetres for the filter, better smoothed (the start's 1-m σ alone is 1.4 m in 2-D)
    assert np.mean(mean_err) < (0.5 if smooth is None else 0.3), mean_err


def test_range_only_and_paper_filters_run_on_the_same_mission():
    meas, imu = mission(1)
    ranged = track(meas, imu, filter="inertial-range")
    assert np.isnan(ranged["frames"]["sigma_v_r_mps"]).all()
    assert errors(ranged)[0].mean() < 1.0
    paper = track(meas, imu, filter="proposed", config=None)
    assert paper["state"].shape[1] == 6 and "run" not in paper


def test_outlier_frame_is_gated_reported_and_does_not_move_the_track():
    k = 15
    meas, imu = mission(3, outlier=k)
    out = track(meas, imu)
    status = out["frames"]["status"]
    assert status[k] == "gated" and (np.delete(status, k) == "accepted").all()
    assert out["frames"]["nis"][k] > 1e4
    # the same mission without that frame: the same track (the gated frame only adds a node)
    clean = {c: np.delete(v, k) for c, v in meas.items()}
    ref = track(clean, imu)
    on_imu = np.isin(out["t_s"], ref["t_s"])
    assert np.max(np.abs(out["state"][on_imu, :2] - ref["state"][:, :2])) < 0.01
    assert errors(out)[0].max() < 2.0


def test_a_later_fix_pulls_the_track_and_shrinks_the_covariance():
    meas, imu = mission(4)
    kw = dict(filter="inertial-range", sigma_range_m=2.0)  # weak ranges: the fix matters
    without = track(meas, imu, **kw)
    x, y, _, _ = truth(80.0)
    fixes = {"t_s": np.array([80.0]), "x_m": np.array([x]), "y_m": np.array([y]), "sigma_m": np.array([0.3])}
    with_fix = track(meas, imu, fixes=fixes, **kw)
    i = int(np.flatnonzero(with_fix["t_s"] == 80.0)[0])
    trace = lambda out: out["cov"][i, 0, 0] + out["cov"][i, 1, 1]  # noqa: E731
    assert trace(with_fix) < 0.5 * trace(without)
    assert trace(with_fix) < 2 * 0.3**2 + 1e-9
    err_with, err_without = errors(with_fix)[0][i], errors(without)[0][i]
    assert err_with <= max(err_without, 3 * 0.3)
    assert with_fix["settings"]["fixes_used"] == 1


def test_irregular_imu_time_stamps():
    rng = np.random.default_rng(7)
    steps = rng.uniform(0.05, 0.45, 600)
    imu_t = np.cumsum(np.r_[0.0, steps])
    imu_t = imu_t[imu_t <= 120.0]
    meas, imu = mission(5, imu_t=imu_t)
    mean_dt = float(np.mean(np.diff(imu_t)))
    out = track(meas, imu, config=config(mean_dt))
    err, nees, sigma = errors(out)
    assert (out["frames"]["status"] == "accepted").all()
    assert err.mean() < 0.5 and np.mean(err <= 3 * sigma) >= 0.9


def test_sigma_floor_and_override():
    meas, imu = mission(2)
    meas["sigma_range_m"] = np.full(meas["range_m"].size, 1e-4)
    meas["sigma_v_r_mps"][3] = np.nan
    out = track(meas, imu)
    f = out["frames"]
    assert np.all(f["sigma_range_m"] == 0.01)  # the floor
    assert f["sigma_v_r_mps"][3] == 0.05 and f["sigma_v_r_mps"][0] == 0.05
    assert "1 without" in out["settings"]["r"]["v_r_source"]
    given = track(meas, imu, sigma_range_m=0.2)
    assert np.all(given["frames"]["sigma_range_m"] == 0.2) and given["settings"]["r"]["range_source"] == "command line"
    del meas["sigma_range_m"], meas["sigma_v_r_mps"]
    none = track(meas, imu)
    assert np.all(none["frames"]["sigma_range_m"] == 0.05)


def test_fixed_lag_needs_an_inertial_filter_and_a_lag():
    from seamodem.errors import ConfigError

    meas, imu = mission(0, t_end=30.0)
    with pytest.raises(ConfigError, match="fixed-lag"):
        track(meas, imu, filter="rosb", smooth="fixed-lag", lag_s=5.0, config=None)
    with pytest.raises(ConfigError, match="lag_s"):
        track(meas, imu, smooth="fixed-lag")


# ------------------------------------------------------------------------------------------------ CLI


def write(path, columns: dict, comment=None):
    with open(path, "w", newline="") as f:
        if comment:
            f.write(f"# {comment}\n")
        w = csv.writer(f)
        w.writerow(columns)
        w.writerows(zip(*columns.values()))


@pytest.fixture
def files(tmp_path):
    meas, imu = mission(6, outlier=10)
    meas["range_m"] = np.hypot(meas["range_m"], 12.0 - 2.0)  # slant: vehicle at 12 m, beacon at 2 m
    imu_cols = dict(imu)
    write(tmp_path / "meas.csv", meas, comment='format: "seamodem.measurements/1"')
    write(tmp_path / "imu.csv", imu_cols)
    t = np.arange(0.0, 120.01, 0.25)
    x, y, _, _ = truth(t)
    write(tmp_path / "truth.csv", {"t_s": t, "x_m": x, "y_m": y})
    write(tmp_path / "depth.csv", {"t_s": np.array([0.0, 60.0, 120.0]), "depth_m": np.array([12.0, 12.0, 12.0])})
    fx, fy, _, _ = truth(np.array([119.0]))
    write(tmp_path / "fixes.csv", {"t_s": [119.0], "x_m": fx, "y_m": fy, "sigma_m": [0.5]})
    return tmp_path


def cli(d, *extra, out="track.csv"):
    return main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--beacon", "40,25",
                 "--start", "0,0", "--start-speed", "1", "--truth", str(d / "truth.csv"), "--gyro-arw",
                 str(SIGMA_OMEGA * 0.5), "--accel-vrw", str(SIGMA_ACCEL * 0.5), "--heading-sigma-deg", "0.5",
                 *extra, "-o", str(d / out)])


def test_cli_writes_track_frames_plot_and_sidecar(files, capsys):
    d = files
    assert cli(d, "--depth-log", str(d / "depth.csv"), "--beacon-depth", "2", "--fixes", str(d / "fixes.csv")) == 0
    text = capsys.readouterr().out
    assert "1 gated" in text and "track_frames.csv" in text
    with open(d / "track.csv") as f:
        assert next(csv.reader(f)) == ["t_s", "x_m", "y_m", "heading_rad", "speed_mps", "bias_rad", "var_x_m2",
                                       "cov_xy_m2", "var_y_m2"]
    with open(d / "track_frames.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[:4] == ["frame_index", "t_arrival_s", "status", "nis"]
    assert [r["status"] for r in rows].count("gated") == 1 and rows[10]["status"] == "gated"
    side = json.loads((d / "track.json").read_text())
    assert side["filter"] == "inertial" and side["smoother"] is None and side["fixes_used"] == 1
    assert side["inertial_config"]["heading_sigma_rad"] == pytest.approx(math.radians(0.5))
    assert side["r"]["range_floor_m"] == 0.01 and side["r"]["range_source"] == "records"
    assert side["command"].startswith("seamodem nav track") and side["frames"]["gated"] == 1
    assert side["mean_error_m"] < 0.5  # slant ranges made horizontal with the depth log
    assert (d / "track.png").stat().st_size > 1000


@pytest.mark.parametrize("extra, smoother", [(["--smooth"], "batch"), (["--fixed-lag", "6"], "fixed-lag"),
                                             (["--filter", "proposed", "--smooth"], "rts")])
def test_cli_smoothers(files, extra, smoother):
    d = files
    assert cli(d, "--depth", "12", "2", *extra) == 0
    side = json.loads((d / "track.json").read_text())
    assert side["smoother"] == smoother and side["smoothed"]


def test_cli_without_depth_the_slant_ranges_are_worse(files):
    d = files
    assert cli(d, "--depth", "12", "2", out="h.csv") == 0
    assert cli(d, out="s.csv") == 0
    h, s = (json.loads((d / n).read_text()) for n in ("h.json", "s.json"))
    assert h["mean_error_m"] < s["mean_error_m"]


def test_cli_imu_nan_row_is_one_warning_line(files, capsys):
    d = files
    lines = (d / "imu.csv").read_text().splitlines()
    parts = lines[20].split(",")
    parts[2] = "nan"
    lines[20] = ",".join(parts)
    (d / "imu.csv").write_text("\n".join(lines) + "\n")
    assert cli(d, "--depth", "12", "2") == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "IMU file" in err[0] and "skipped 1 of" in err[0] and "omega_rad_s 1" in err[0]


def test_cli_fixes_in_lat_lon_without_geodetic_is_one_line_error(files, capsys):
    d = files
    write(d / "geo_fixes.csv", {"t_s": [100.0], "lat_deg": [48.38], "lon_deg": [-4.4]})
    assert cli(d, "--fixes", str(d / "geo_fixes.csv")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--geodetic" in err


def _with_bearings(meas, seed, sigma_rad, *, every=1):
    """The records plus a hydrophone array's body-frame azimuth of the beacon (bearing.py's model), every
    ``every``-th frame (the others empty)."""
    from seamodem.navigation.bearing import bearing_body

    rng = np.random.default_rng(100 + seed)
    x, y, psi, _ = truth(meas["t_arrival_s"])
    az = bearing_body(x, y, psi, BEACON) + sigma_rad * rng.standard_normal(x.size)
    az[np.arange(x.size) % every != 0] = np.nan
    return {**meas, "azimuth_body_rad": az, "sigma_azimuth_body_rad": np.where(np.isfinite(az), sigma_rad, np.nan)}


def test_array_bearings_are_used_and_pin_a_poor_range_track():
    """With 2-m ranges the track is metres off; a 1° body-frame bearing per frame brings it back, and the
    covariance still holds the truth (error ≤ 3σ at ≥ 95 % of the states)."""
    plain, with_b = [], []
    for seed in range(4):
        meas, imu = mission(seed)
        meas["range_m"] = meas["range_m"] + 2.0 * np.random.default_rng(seed).standard_normal(meas["range_m"].size)
        meas["sigma_range_m"] = np.full(meas["range_m"].size, 2.0)
        a = track(meas, imu)
        b = track(_with_bearings(meas, seed, math.radians(1.0), every=2), imu)
        assert "bearing_status" not in a["frames"] and a["settings"]["bearings_used"] == 0
        used = b["frames"]["bearing_status"]
        assert b["settings"]["bearings_used"] == (np.arange(used.size) % 2 == 0).sum()
        assert set(used[1::2]) == {"none"} and np.isin(used[::2], ("accepted", "accepted_after_gates")).all()
        err, _, sigma = errors(b)
        assert np.mean(err <= 3 * sigma) >= 0.95
        plain.append(errors(a)[0].mean())
        with_b.append(err.mean())
    assert np.mean(with_b) < 0.7 * np.mean(plain), (plain, with_b)
    off = track(_with_bearings(meas, 3, math.radians(1.0)), imu, use_bearing=False)
    assert "bearing_status" not in off["frames"]


def test_cli_reads_bearing_columns_and_writes_their_status(files, capsys):
    d = files
    meas, _ = mission(6, outlier=10)
    meas["range_m"] = np.hypot(meas["range_m"], 12.0 - 2.0)
    write(d / "meas.csv", _with_bearings(meas, 6, math.radians(0.3)), comment='format: "seamodem.measurements/1"')
    assert cli(d, "--depth", "12", "2", "--bearing-floor", "0.4") == 0
    assert "array bearings: " in capsys.readouterr().out
    with open(d / "track_frames.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[-1] == "bearing_status" and rows[0]["bearing_status"] == "accepted"
    side = json.loads((d / "track.json").read_text())
    assert side["bearings_used"] == len(rows) and side["bearing_floor_deg"] == pytest.approx(0.4)
    assert cli(d, "--depth", "12", "2", "--no-bearing", out="plain.csv") == 0
    with open(d / "plain_frames.csv") as f:
        assert "bearing_status" not in next(csv.reader(f))


@pytest.mark.parametrize("option, value, message", [("--min-speed", "abc", "--min-speed: must be a speed in m/s or 'none'"),
                                                    ("--window", "-1", "window_s: must be finite and >= 0 s")])
def test_cli_bad_filter_option_is_one_line_error_and_no_output(files, capsys, option, value, message):
    d = files
    try:
        code = cli(d, option, value)
    except SystemExit as exc:  # argparse's own type errors
        code = exc.code
    assert code == 2
    err = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith(" ")]
    assert message in err[-1] and "Traceback" not in "\n".join(err)
    assert not (d / "track.csv").exists()


def test_cli_min_speed_reaches_the_filter(files):
    """--min-speed none and a value land in the sidecar's filter settings."""
    d = files
    assert cli(d, "--min-speed", "none", out="free.csv") == 0
    assert cli(d, "--min-speed", "0.2", out="floor.csv") == 0
    sides = [json.loads((d / name).read_text()) for name in ("free.json", "floor.json")]
    found = [_find_key(s, "min_speed_mps") for s in sides]
    assert found == [None, 0.2], found


def _find_key(obj, key):
    if isinstance(obj, dict):
        if key in obj:
            return obj[key]
        for v in obj.values():
            r = _find_key(v, key)
            if r is not _MISSING:
                return r
    return _MISSING


_MISSING = object()
