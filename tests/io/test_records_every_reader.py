"""Issue 29 items 1 and 4: every reader takes what every ``seamodem rx`` mode writes, and names a bad file."""

from __future__ import annotations

import csv
import dataclasses
import math

import numpy as np
import pytest

from seamodem.cli import main
from seamodem.errors import InputFileError
from seamodem.navigation import logs
from seamodem.receive.records import REQUIRED_FIELDS, MeasurementRecord, read_measurements, write_measurements
from seamodem.receive.reference.records import REFERENCE_FIELDS, ReferenceRecord

BASE = MeasurementRecord(
    frame_index=0, t_emit_s=0.0, t_arrival_s=0.2, tof_s=0.2, range_m=300.0, v_r_mps=-1.25, snr_db=11.0,
    v_r_tone_eq9_mps=-1.2, v_r_bank_mps=-1.3, detection_z=500.0, detection_rho=0.6, sigma_range_m=0.002,
    sigma_v_r_mps=6e-4, sigma_v_r_bank_mps=0.02, tone_c_n0_dbhz=50.0,
)


def _frames(kind: str) -> tuple[list, dict]:
    """Three records of one rx mode: frames (decoded or not), array rows (azimuths), reference rows."""
    recs = [dataclasses.replace(BASE, frame_index=k, t_emit_s=3.0 * k, t_arrival_s=3.0 * k + 0.2,
                                crc_ok=None if k == 2 else True) for k in range(3)]
    if kind == "array":
        recs = [dataclasses.replace(r, azimuth_body_rad=0.1 * k, sigma_azimuth_body_rad=0.01, n_channels=4)
                for k, r in enumerate(recs)]
    if kind == "reference":
        recs = [ReferenceRecord(**dataclasses.asdict(r), reference="lfm", channel=0, e_n0_db=30.0, misfit=0.1,
                                role="ping") for r in recs]
        return recs, {"fields": REFERENCE_FIELDS, "keep_unmatched": True}
    return recs, {}


@pytest.mark.parametrize("suffix", ["csv", "jsonl"])
@pytest.mark.parametrize("kind", ["frames", "array", "reference"])
def test_nav_reader_and_record_reader_take_every_rx_file(tmp_path, kind, suffix):
    """Item 1: ``nav track``'s reader took CSV only (a .jsonl was 'missing column(s)'); both readers take both."""
    recs, options = _frames(kind)
    path = tmp_path / f"m.{suffix}"
    write_measurements(path, recs, {"sound_speed_mps": 1500.0}, **options)
    nav = logs.read_measurements(path)
    np.testing.assert_array_equal(nav["t_arrival_s"], [r.t_arrival_s for r in recs])
    np.testing.assert_array_equal(nav["range_m"], [r.range_m for r in recs])
    np.testing.assert_array_equal(nav["crc_ok"], [1.0, 1.0, math.nan])  # decoded, decoded, not decoded
    if kind == "array":
        np.testing.assert_array_equal(nav["azimuth_body_rad"], [0.0, 0.1, 0.2])
    records, _ = read_measurements(path)
    assert [r.range_m for r in records] == [r.range_m for r in recs]


@pytest.mark.parametrize("suffix", ["csv", "jsonl"])
def test_both_readers_take_the_seven_required_columns_and_refuse_six(tmp_path, suffix):
    """Item 1: read_measurements refused a 7-column CSV that nav track accepts; they now agree."""
    assert REQUIRED_FIELDS == logs.MEASUREMENT_COLUMNS
    rows = [{c: getattr(dataclasses.replace(BASE, frame_index=k, t_arrival_s=0.2 + k), c) for c in REQUIRED_FIELDS}
            for k in range(2)]
    path = tmp_path / f"seven.{suffix}"
    if suffix == "csv":
        with path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=REQUIRED_FIELDS)
            writer.writeheader()
            writer.writerows(rows)
    else:
        import json
        path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    with pytest.warns(UserWarning, match="no sidecar"):
        records, _ = read_measurements(path)
    assert [r.t_arrival_s for r in records] == [0.2, 1.2] and math.isnan(records[0].v_r_bank_mps)
    np.testing.assert_array_equal(logs.read_measurements(path)["t_arrival_s"], [0.2, 1.2])
    six = tmp_path / "six.csv"
    six.write_text("frame_index,t_emit_s,t_arrival_s,tof_s,range_m,v_r_mps\n0,0,0.2,0.2,300,1\n")
    with pytest.raises(InputFileError, match="snr_db"):
        logs.read_measurements(six)
    with pytest.raises(InputFileError, match="snr_db"), pytest.warns(UserWarning, match="no sidecar"):
        read_measurements(six)


def test_a_wav_given_as_records_is_named_not_dumped(tmp_path, capsys):
    """Item 4: ``nav track rec.wav`` printed the WAV's bytes (RIFF…WAVEfmt) over 8 lines."""
    wav = tmp_path / "rec.wav"
    wav.write_bytes(b"RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x01\x00" + bytes(range(256)) * 8)
    imu = tmp_path / "imu.csv"
    imu.write_text("t_s,heading_rad,omega_rad_s,accel_mps2\n0,0,0,0\n1,0,0,0\n")
    code = main(["nav", "track", str(wav), "--imu", str(imu), "--beacon", "-45,25", "--start", "0,0",
                 "-o", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert str(wav) in err and "RIFF" not in err and "binary" in err
    assert not (tmp_path / "t.csv").exists()


def test_a_missing_column_message_lists_names_not_a_record(tmp_path):
    """Item 1's message: one JSON record dumped as the 'header' (1,207 characters); now at most 12 names."""
    wide = tmp_path / "wide.csv"
    names = [f"column_{k}" for k in range(40)]
    wide.write_text(",".join(names) + "\n" + ",".join("1" * 40) + "\n")
    with pytest.raises(InputFileError) as exc:
        logs.read_measurements(wide)
    assert "and 28 more" in str(exc.value) and len(str(exc.value)) < 400


def test_a_cell_of_junk_is_quoted_short(tmp_path):
    """Item 4, the other way a file's contents reached the terminal: a non-numeric cell quoted whole."""
    junk = tmp_path / "junk.csv"
    junk.write_text("frame_index,t_emit_s,t_arrival_s,tof_s,range_m,v_r_mps,snr_db\n"
                    f"0,0,0.2,0.2,{'x' * 2000},1,10\n")
    with pytest.raises(InputFileError) as exc:
        logs.read_measurements(junk)
    assert "column range_m: not a number" in str(exc.value) and len(str(exc.value)) < 200
