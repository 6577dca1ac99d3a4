"""``seamodem nav track`` and ``nav simulate``: outputs, accuracy on a known track, one-line errors."""

import csv
import json

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.navigation.models import closing_speed

BEACON = (50.0, 30.0)


def write_csv(path, header, rows, comment=None):
    with open(path, "w", newline="") as f:
        if comment:
            f.write(f"# {comment}\n")
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


@pytest.fixture
def scenario(tmp_path):
    """Straight leg at 1 m/s along x past the beacon, IMU at 4 Hz, one frame every 3 s."""
    rng = np.random.default_rng(8)
    t_imu = np.arange(0, 120.0001, 0.25)
    x, y = t_imu * 1.0, np.zeros_like(t_imu)
    write_csv(tmp_path / "imu.csv", ["t_s", "heading_rad", "omega_rad_s", "accel_mps2"],
              [(t, 0.01 * rng.normal(), 0.01 * rng.normal(), 0.01 * rng.normal()) for t in t_imu])
    t_meas = np.arange(3.0, 120.0, 3.0)
    rows = []
    for k, t in enumerate(t_meas):
        d = np.hypot(t - BEACON[0], -BEACON[1])
        vr = float(closing_speed(t, 0.0, 0.0, 1.0, BEACON))
        rows.append((k, t - d / 1500, t, d / 1500, d + 0.5 * rng.normal(), vr + 0.05 * rng.normal(), 12.0, 0.5, 0.05))
    header = ["frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db", "range_std_m", "v_r_std_mps"]
    write_csv(tmp_path / "meas.csv", header, rows, comment="format: seamodem.measurements/1, sound_speed_mps: 1500")
    write_csv(tmp_path / "truth.csv", ["t_s", "x_m", "y_m"], zip(t_imu, x, y))
    return tmp_path, header, rows


def test_track_writes_outputs_and_is_accurate(scenario, capsys):
    d, _, _ = scenario
    code = main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--beacon", "50,30",
                 "--start", "0,0", "--start-speed", "1", "--truth", str(d / "truth.csv"), "-o", str(d / "track.csv")])
    assert code == 0
    stats = json.loads((d / "track.json").read_text())
    # 0.5 m range noise, exact initial state: the mean error stays well below the range noise scale (2 m).
    assert stats["mean_error_m"] < 2.0
    assert (d / "track.png").stat().st_size > 1000
    with open(d / "track.csv") as f:
        header = next(csv.reader(f))
    assert header[:3] == ["t_s", "x_m", "y_m"] and "var_x_m2" in header


def test_track_geodetic_adds_lat_lon(scenario):
    d, _, _ = scenario
    code = main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--geodetic",
                 "--beacon", "48.38243,-4.407295", "--start", "48.38216,-4.407968", "-o", str(d / "geo.csv")])
    assert code == 0
    with open(d / "geo.csv") as f:
        assert "lat_deg" in next(csv.reader(f))


def _defective(d, header, rows, defect):
    rows = [list(r) for r in rows]
    if defect == "missing_column":
        i = header.index("v_r_mps")
        header = header[:i] + header[i + 1:]
        rows = [r[:i] + r[i + 1:] for r in rows]
    elif defect == "unsorted":
        rows[3], rows[4] = rows[4], rows[3]
    elif defect == "duplicate":
        rows[4][2] = rows[3][2]
    else:
        rows[5][4] = "nan"
    write_csv(d / "bad.csv", header, rows)


def test_missing_column_fails_in_one_line(scenario, capsys):
    d, header, rows = scenario
    _defective(d, header, rows, "missing_column")
    code = main(["nav", "track", str(d / "bad.csv"), "--imu", str(d / "imu.csv"), "--beacon", "50,30",
                 "--start", "0,0", "-o", str(d / "out.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "missing column(s) v_r_mps" in err and len(err.splitlines()) == 1
    assert not (d / "out.csv").exists() and not (d / "out.png").exists()


@pytest.mark.parametrize(
    "defect, message",
    [
        ("unsorted", "t_arrival_s not in time order; sorted"),
        ("duplicate", "dropped 1 row(s) with a duplicate t_arrival_s"),
        ("nan", "skipped 1 of 39 row(s) with NaN or empty values (in range_m 1)"),
    ],
)
def test_repairable_measurement_files_warn_in_one_line(scenario, capsys, defect, message):
    """What navigation.logs repairs is one warning line on stderr, and the track is written."""
    d, header, rows = scenario
    _defective(d, header, rows, defect)
    code = main(["nav", "track", str(d / "bad.csv"), "--imu", str(d / "imu.csv"), "--beacon", "50,30",
                 "--start", "0,0", "--start-speed", "1", "-o", str(d / "out.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 0 and len(err.splitlines()) == 1
    assert err.startswith("seamodem nav track: warning: measurement file") and message in err
    assert (d / "out.csv").exists() and (d / "out_frames.csv").exists()


def test_missing_beacon_or_bad_beacon(scenario, capsys):
    d, _, _ = scenario
    with pytest.raises(SystemExit):  # argparse: --beacon is required
        main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--start", "0,0", "-o", str(d / "o.csv")])
    code = main(["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--beacon", "50",
                 "--start", "0,0", "-o", str(d / "o.csv")])
    assert code == 2 and "beacon: must be two numbers" in capsys.readouterr().err


def test_simulate_writes_table_csv(tmp_path, capsys, monkeypatch):
    import seamodem.navigation.montecarlo as mc

    # A short path keeps this CLI test to a second; the full mission runs in the benchmark.
    short = mc.MissionConfig.__dataclass_fields__["path"]
    monkeypatch.setattr(short, "default_factory", lambda: {"lane_length_m": 30.0, "n_lanes": 2})
    code = main(["nav", "simulate", "--paper", "--tcom", "3", "6", "--runs", "5", "-q", "-o", str(tmp_path / "sim")])
    assert code == 0
    with open(tmp_path / "sim" / "table.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[:7] == ["tcom_s", "filter", "mean_error_m", "error_variance_m2", "etd_max_pct",
                                 "etd_mean_pct", "outliers"] and "diverged" in rows[0]
    assert [(r["tcom_s"], r["filter"]) for r in rows] == [("3.0", "proposed"), ("3.0", "rosb"),
                                                          ("6.0", "proposed"), ("6.0", "rosb")]
    assert (tmp_path / "sim" / "fig7_top_view.png").exists() and (tmp_path / "sim" / "fig8_error.png").exists()
    assert "Mean position error" in capsys.readouterr().out


def test_track_smooth_improves_and_keeps_last_state(scenario):
    """Paper filter: the RTS smoother's last state is the filter's own."""
    d, _, _ = scenario
    common = ["nav", "track", str(d / "meas.csv"), "--imu", str(d / "imu.csv"), "--beacon", "50,30",
              "--start", "0,0", "--start-speed", "1", "--truth", str(d / "truth.csv"), "--r-from-records",
              "--filter", "proposed"]
    assert main(common + ["-o", str(d / "f.csv")]) == 0
    assert main(common + ["--smooth", "-o", str(d / "s.csv")]) == 0
    f, s = (json.loads((d / name).read_text()) for name in ("f.json", "s.json"))
    assert s["smoothed"] and not f["smoothed"]
    assert s["mean_error_m"] < f["mean_error_m"]
    last_f = (d / "f.csv").read_text().strip().splitlines()[-1]
    last_s = (d / "s.csv").read_text().strip().splitlines()[-1]
    assert last_f == last_s


def test_simulate_rejects_bad_workers(tmp_path, capsys):
    code = main(["nav", "simulate", "--workers", "0", "-q", "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "--workers" in err and len(err.splitlines()) == 1


def test_r_from_records_reads_the_receivers_sigma_columns(scenario):
    """seamodem rx names the per-frame deviations sigma_range_m and sigma_v_r_mps: same track as *_std names."""
    d, _, _ = scenario
    text = (d / "meas.csv").read_text()
    assert "range_std_m" in text
    (d / "meas_rx.csv").write_text(text.replace("range_std_m", "sigma_range_m").replace("v_r_std_mps", "sigma_v_r_mps"))
    common = ["--imu", str(d / "imu.csv"), "--beacon", "50,30", "--start", "0,0", "--start-speed", "1",
              "--r-from-records"]
    assert main(["nav", "track", str(d / "meas.csv"), *common, "-o", str(d / "a.csv")]) == 0
    assert main(["nav", "track", str(d / "meas_rx.csv"), *common, "-o", str(d / "b.csv")]) == 0
    assert (d / "a.csv").read_text() == (d / "b.csv").read_text()
