"""Reading vehicle logs: every defect gives one line that names it, and the cleaned result."""

import csv
import math
import warnings

import numpy as np
import pytest

from seamodem.errors import ConfigError, InputFileError
from seamodem.navigation.geometry import CoordinateWarning, geodetic_to_local
from seamodem.navigation.logs import (
    FIX_SIGMA_M,
    LogWarning,
    depth_at,
    parse_pair,
    parse_position,
    read_columns,
    read_depth,
    read_fixes,
    read_imu,
    read_measurements,
    read_metadata,
)

IMU_HEADER = ["t_s", "heading_rad", "omega_rad_s", "accel_mps2"]
MEAS_HEADER = ["frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db"]


def write(path, header, rows, comments=()):
    with open(path, "w", newline="", encoding="utf-8") as f:
        for line in comments:
            f.write(f"# {line}\n")
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return path


def imu_rows(t):
    return [(ti, 0.1 * k, 0.01, 0.02) for k, ti in enumerate(t)]


def meas_row(k, t_arrival, d=300.0):
    return (k, t_arrival - d / 1500, t_arrival, d / 1500, d, 0.5, 12.0)


def one_warning(record, fragment):
    """The single LogWarning recorded, checked to be one line containing ``fragment``."""
    texts = [str(w.message) for w in record if issubclass(w.category, LogWarning)]
    assert len(texts) == 1, texts
    assert fragment in texts[0] and "\n" not in texts[0], texts[0]
    return texts[0]


def no_warnings(read, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read(*args, **kwargs)


# --- IMU ---------------------------------------------------------------------------------------------


def test_imu_at_irregular_times_reads_silently(tmp_path):
    t = np.cumsum(np.r_[0.0, np.random.default_rng(3).uniform(0.05, 0.4, 200)])  # no two steps alike
    data = no_warnings(read_imu, write(tmp_path / "imu.csv", IMU_HEADER, imu_rows(t)))
    np.testing.assert_array_equal(data["t_s"], t)
    assert set(data) == set(IMU_HEADER)


def test_imu_with_a_byte_order_mark_reads(tmp_path):
    path = tmp_path / "imu.csv"
    path.write_bytes("\ufefft_s,heading_rad,omega_rad_s,accel_mps2\n0,1,2,3\n".encode("utf-8"))  # as Excel saves UTF-8
    assert no_warnings(read_imu, path)["accel_mps2"].tolist() == [3.0]


def test_imu_unsorted_is_sorted_with_the_count_of_rows_moved(tmp_path):
    t = np.arange(10) * 0.25
    rows = imu_rows(t)
    rows[3], rows[6] = rows[6], rows[3]  # two rows out of place
    with pytest.warns(LogWarning) as rec:
        data = read_imu(write(tmp_path / "imu.csv", IMU_HEADER, rows))
    one_warning(rec, "t_s not in time order; sorted (2 row(s) moved)")
    np.testing.assert_array_equal(data["t_s"], t)
    np.testing.assert_array_equal(data["heading_rad"], 0.1 * np.arange(10))  # rows moved whole


def test_imu_duplicate_times_keep_the_first(tmp_path):
    rows = imu_rows(np.arange(10) * 0.25)
    rows.insert(5, (rows[4][0], 99.0, 0.0, 0.0))  # a second sample at t = 1.0 s
    rows.insert(8, (rows[7][0], 98.0, 0.0, 0.0))
    with pytest.warns(LogWarning) as rec:
        data = read_imu(write(tmp_path / "imu.csv", IMU_HEADER, rows))
    one_warning(rec, "dropped 2 row(s) with a duplicate t_s (kept the first of each; first at t_s = 1)")
    assert data["t_s"].size == 10 and 99.0 not in data["heading_rad"] and 98.0 not in data["heading_rad"]


def test_imu_nan_rows_are_dropped_with_the_count(tmp_path):
    rows = [list(r) for r in imu_rows(np.arange(10) * 0.25)]
    rows[2][1] = "nan"
    rows[5][3] = ""  # an empty cell is a missing value too
    with pytest.warns(LogWarning) as rec:
        data = read_imu(write(tmp_path / "imu.csv", IMU_HEADER, rows))
    one_warning(rec, "skipped 2 of 10 row(s) with NaN or empty values (in heading_rad 1, accel_mps2 1)")
    np.testing.assert_array_equal(data["t_s"], np.delete(np.arange(10) * 0.25, [2, 5]))


def test_imu_column_entirely_nan_is_an_error(tmp_path):
    rows = [(t, "nan", 0.0, 0.0) for t in range(5)]
    with pytest.raises(InputFileError, match=r"column heading_rad has no numeric value in its 5 row\(s\)$"):
        read_imu(write(tmp_path / "imu.csv", IMU_HEADER, rows))


def test_imu_gap_is_named_by_time_and_length(tmp_path):
    t = np.r_[np.arange(0, 10, 0.25), np.arange(22.5, 30, 0.25)]  # 12.5 s without samples after t = 9.75
    with pytest.warns(LogWarning) as rec:
        data = read_imu(write(tmp_path / "imu.csv", IMU_HEADER, imu_rows(t)))
    one_warning(rec, "1 gap(s) longer than 5 × the median step 0.25 s: 12.75 s at t_s = 9.75")
    assert data["t_s"].size == t.size  # a gap is reported, nothing is dropped


def test_imu_heading_in_degrees_is_converted(tmp_path):
    rows = [(0.0, 90.0, 0.0, 0.0), (0.5, -180.0, 0.0, 0.0)]
    data = no_warnings(read_imu, write(tmp_path / "imu.csv", ["t_s", "heading_deg", "omega_rad_s", "accel_mps2"], rows))
    np.testing.assert_allclose(data["heading_rad"], [math.pi / 2, -math.pi], rtol=1e-15)  # radians() is exact to eps
    assert "heading_deg" not in data


def test_imu_optional_columns_and_their_nan_cells(tmp_path):
    header = IMU_HEADER + ["heading_std_rad", "depth_m"]
    rows = [(t, 0.0, 0.0, 0.0, 0.01, d) for t, d in zip(range(5), (2.0, 4.0, "", 8.0, 10.0))]
    with pytest.warns(LogWarning) as rec:
        data = read_imu(write(tmp_path / "imu.csv", header, rows))
    one_warning(rec, "filled 1 NaN value(s) of depth_m by linear interpolation in t_s")
    np.testing.assert_array_equal(data["depth_m"], [2.0, 4.0, 6.0, 8.0, 10.0])  # midpoint of 4 and 8
    np.testing.assert_array_equal(data["heading_std_rad"], 0.01)


@pytest.mark.parametrize("content, message", [
    (None, r"^IMU file not found: .*nope\.csv$"),
    ("", r"^IMU file .*imu\.csv: no data rows \(need a header line and at least one row\)$"),
    ("t_s,heading_rad,omega_rad_s,accel_mps2\n", r"no data rows"),
    ("t_s,heading_rad,accel_mps2\n0,0,0\n", r"missing column\(s\) omega_rad_s \(has: t_s, heading_rad, accel_mps2\)$"),
    ("t_s,heading_rad,omega_rad_s,accel_mps2\n0,north,0,0\n", r"data row 1, column heading_rad: not a number \('north'\)$"),
])
def test_imu_unreadable_files_are_one_line_errors(tmp_path, content, message):
    path = tmp_path / ("nope.csv" if content is None else "imu.csv")
    if content is not None:
        path.write_text(content)
    with pytest.raises(InputFileError, match=message) as err:
        read_imu(path)
    assert "\n" not in str(err.value)


# --- measurement records -----------------------------------------------------------------------------


def test_measurements_with_metadata_comments_and_payload_text(tmp_path):
    header = MEAS_HEADER + ["sigma_range_m", "sigma_v_r_mps", "crc_ok", "payload_text", "status"]
    tricky = 'depth 12 m, #3 "ok", done'  # comma, hash and quotes inside one quoted field
    rows = [(*meas_row(0, 3.2), 0.01, 0.02, 1, tricky, "ok"),
            (*meas_row(1, 6.2), 0.02, 0.03, "", "#not a comment", "cut")]
    path = write(tmp_path / "meas.csv", header, rows, comments=['format: "seamodem.measurements/1"',
                                                                "sound_speed_mps: 1500.0"])
    data = no_warnings(read_measurements, path)
    np.testing.assert_array_equal(data["t_arrival_s"], [3.2, 6.2])
    np.testing.assert_array_equal(data["sigma_range_m"], [0.01, 0.02])
    np.testing.assert_array_equal(data["crc_ok"], [1.0, np.nan])  # empty: not decoded
    assert list(data["status"]) == ["ok", "cut"] and "payload_text" not in data
    assert read_metadata(path) == {"format": "seamodem.measurements/1", "sound_speed_mps": 1500.0}


def test_measurements_without_comments_and_with_sigma_aliases(tmp_path):
    path = write(tmp_path / "meas.csv", MEAS_HEADER + ["range_std_m", "v_r_std_mps"],
                 [(*meas_row(0, 3.0), 0.5, 0.05)])
    data = no_warnings(read_measurements, path)
    assert data["sigma_range_m"].tolist() == [0.5] and data["sigma_v_r_mps"].tolist() == [0.05]
    assert read_metadata(path) == {}


def test_measurement_before_the_first_emission_is_skipped_not_fatal(tmp_path):
    rows = [(-1, "nan", 1.1, "nan", "nan", 0.3, 9.0)] + [meas_row(k, 3.0 * k + 3) for k in range(4)]
    with pytest.warns(LogWarning) as rec:
        data = read_measurements(write(tmp_path / "meas.csv", MEAS_HEADER, rows))
    one_warning(rec, "skipped 1 of 5 row(s) with NaN or empty values (in t_emit_s 1, tof_s 1, range_m 1)")
    np.testing.assert_array_equal(data["frame_index"], [0, 1, 2, 3])


def test_measurements_unsorted_and_duplicated_arrivals(tmp_path):
    rows = [meas_row(k, 3.0 * k + 3) for k in range(6)]
    rows[1], rows[4] = rows[4], rows[1]
    rows.append(meas_row(9, rows[2][2], d=999.0))  # a second record at an arrival time already seen
    with pytest.warns(LogWarning) as rec:
        data = read_measurements(write(tmp_path / "meas.csv", MEAS_HEADER, rows))
    texts = [str(w.message) for w in rec]
    assert len(texts) == 2
    # arrivals 3, 15, 9, 12, 6, 18, 9 → 3, 6, 9, 9, 12, 15, 18: all but the first and the 9 s row change place
    assert "t_arrival_s not in time order; sorted (5 row(s) moved)" in texts[0]
    assert "dropped 1 row(s) with a duplicate t_arrival_s (kept the first of each; first at t_arrival_s = 9)" in texts[1]
    np.testing.assert_array_equal(data["t_arrival_s"], 3.0 * np.arange(6) + 3)
    assert 999.0 not in data["range_m"]  # the first record of t = 9 s was kept


def test_measurements_missing_column_and_bad_sigma(tmp_path):
    with pytest.raises(InputFileError, match=r"measurement file .*: missing column\(s\) v_r_mps \("):
        read_measurements(write(tmp_path / "a.csv", [c for c in MEAS_HEADER if c != "v_r_mps"], [(0, 1, 2, 3, 4, 5)]))
    with pytest.raises(InputFileError, match=r"sigma_range_m must be > 0, got 0.0 at t_arrival_s = 3$"):
        read_measurements(write(tmp_path / "b.csv", MEAS_HEADER + ["sigma_range_m"], [(*meas_row(0, 3.0), 0.0)]))


# --- GNSS fixes and depth ----------------------------------------------------------------------------


def test_fixes_in_metres_get_the_default_sigma(tmp_path):
    data = no_warnings(read_fixes, write(tmp_path / "f.csv", ["t_s", "x_m", "y_m"], [(0, 1.0, 2.0), (600, 5.0, 6.0)]))
    np.testing.assert_array_equal(data["sigma_m"], [FIX_SIGMA_M] * 2)
    np.testing.assert_array_equal(data["x_m"], [1.0, 5.0])


def test_fixes_in_degrees_become_local_with_an_origin(tmp_path):
    origin = (48.38243, -4.407295)
    rows = [(0, 48.3822, -4.4079, 2.5), (900, 48.3830, -4.4060, 4.0)]
    data = no_warnings(read_fixes, write(tmp_path / "f.csv", ["t_s", "lat_deg", "lon_deg", "sigma_m"], rows),
                       origin=origin)
    east, north = geodetic_to_local(np.array([48.3822, 48.3830]), np.array([-4.4079, -4.4060]), *origin)
    np.testing.assert_array_equal(data["x_m"], east)
    np.testing.assert_array_equal(data["y_m"], north)
    np.testing.assert_array_equal(data["sigma_m"], [2.5, 4.0])
    assert "x_m" not in read_fixes(tmp_path / "f.csv")  # no origin: stays geodetic


def test_fixes_given_as_lon_lat_warn(tmp_path):
    path = write(tmp_path / "f.csv", ["t_s", "lat_deg", "lon_deg"], [(0, -4.4079, 48.3822)])
    with pytest.warns(CoordinateWarning, match="was it given as lon,lat"):
        read_fixes(path, origin=(48.38243, -4.407295))
    path = write(tmp_path / "g.csv", ["t_s", "lat_deg", "lon_deg"], [(0, -120.0, 48.3822)])
    with pytest.raises(ConfigError, match=r"latitude must be in \[-90, 90\] degrees, got -120.0 \(looks like lon,lat"):
        read_fixes(path)


def test_fixes_without_position_columns(tmp_path):
    with pytest.raises(InputFileError, match=r"needs columns x_m, y_m or lat_deg, lon_deg \(has: t_s, x_m\)$"):
        read_fixes(write(tmp_path / "f.csv", ["t_s", "x_m"], [(0, 1.0)]))


def test_depth_log_and_interpolation(tmp_path):
    rows = [(0.0, 1.0), (20.0, 5.0), (10.0, 3.0)]  # unsorted
    with pytest.warns(LogWarning, match=r"t_s not in time order; sorted \(2 row\(s\) moved\)"):
        log = read_depth(write(tmp_path / "d.csv", ["t_s", "depth_m"], rows))
    # linear between samples; the end samples held outside the log
    np.testing.assert_array_equal(depth_at(log, [5.0, 15.0, -3.0, 25.0]), [2.0, 4.0, 1.0, 5.0])


# --- strict reader and command-line pairs ------------------------------------------------------------


def test_read_columns_stays_strict(tmp_path):
    path = write(tmp_path / "t.csv", ["t_s", "x_m"], [(0, 1), (0, 2)])
    with pytest.raises(InputFileError, match=r"duplicate time t_s = 0.0 at data rows 1 and 2$"):
        read_columns(path, ("t_s", "x_m"), time_column="t_s", what="truth file")


def test_parse_pair_and_parse_position():
    assert parse_pair(" 50, 100", "beacon") == (50.0, 100.0)
    with pytest.raises(ConfigError, match=r"^beacon: must be two numbers separated by a comma, got '50;100'$"):
        parse_pair("50;100", "beacon")
    with pytest.raises(ConfigError, match=r"^start: must be finite, got 'nan,1'$"):
        parse_pair("nan,1", "start")
    assert parse_position("3,4", geodetic=False, parameter="start") == (3.0, 4.0)
    origin = (48.38243, -4.407295)
    east, north = parse_position("48.38216,-4.407968", geodetic=True, origin=origin, parameter="start")
    assert (east, north) == tuple(float(v) for v in geodetic_to_local(48.38216, -4.407968, *origin))
    with pytest.warns(CoordinateWarning, match=r"^start: .* from the origin but within 50 km if read as lon,lat"):
        parse_position("-4.407968,48.38216", geodetic=True, origin=origin, parameter="start")
    with pytest.raises(ConfigError, match=r"^start: a geodetic position needs the origin"):
        parse_position("48.4,-4.4", geodetic=True, parameter="start")
