"""Measurement files open with the default call of common tools; the metadata is in a sidecar (issue 14 item 1)."""

import dataclasses
import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

from seamodem.errors import InputFileError
from seamodem.receive.records import (
    FIELDS,
    MeasurementFileWarning,
    MeasurementRecord,
    measurement_sidecar_path,
    read_measurements,
    write_measurements,
)

BASE = MeasurementRecord(
    frame_index=0, t_emit_s=3.0, t_arrival_s=3.2, tof_s=0.2, range_m=300.0, v_r_mps=-1.25, snr_db=11.0,
    v_r_tone_eq9_mps=-1.2, v_r_bank_mps=-1.3, detection_z=500.0, detection_rho=0.6, sigma_range_m=0.002,
    sigma_v_r_mps=6e-4, sigma_v_r_bank_mps=0.02, tone_c_n0_dbhz=50.0,
)
#: payloads a user may send: '#' (a comment to a naive reader), commas, quotes, line breaks, non-ASCII
TEXTS = ["id#0", "a,b,c", 'say "hi", \'yo\'', "line 1\nline 2", "cr\r\nlf", "# starts like a comment", "é ✓ \u2028"]


def _records():
    recs = [dataclasses.replace(BASE, frame_index=k, t_emit_s=3.0 * k, t_arrival_s=3.0 * k + 0.2, crc_ok=True,
                                payload_text=t, payload_hex=t.encode().hex(), decode_passes=1)
            for k, t in enumerate(TEXTS)]
    return recs + [dataclasses.replace(BASE, frame_index=len(TEXTS), crc_ok=None)]  # not decoded: NaN, empty


@pytest.mark.parametrize("suffix", ["csv", "jsonl"])
def test_pandas_default_call_reads_every_row_and_payload(tmp_path, suffix):
    path = tmp_path / f"m.{suffix}"
    recs = _records()
    assert write_measurements(path, recs, {"sound_speed_mps": 1480.0}) == len(recs)
    df = pd.read_csv(path) if suffix == "csv" else pd.read_json(path, lines=True)
    assert list(df.columns) == list(FIELDS) and len(df) == len(recs)
    assert list(df["payload_text"][: len(TEXTS)]) == TEXTS
    np.testing.assert_array_equal(df["range_m"], [r.range_m for r in recs])
    np.testing.assert_array_equal(df["frame_index"], np.arange(len(recs)))
    assert df["frame_index"].dtype.kind == "i"  # (read_json makes whole-valued float columns int: pandas' choice)
    np.testing.assert_array_equal(df["t_emit_s"], [r.t_emit_s for r in recs])
    assert math.isnan(df["eq_snr_db"].iloc[-1]) and pd.isna(df["crc_ok"].iloc[-1])
    meta = json.loads(measurement_sidecar_path(path).read_text())
    assert meta["format"] == "seamodem.measurements/2" and meta["sound_speed_mps"] == 1480.0
    assert meta["rows"] == len(recs) and meta["columns"] == list(FIELDS) and meta["file"] == path.name
    # and our own reader gives the records back, text and all
    back, header = read_measurements(path)
    assert [r.payload_text for r in back] == [r.payload_text for r in recs] and header == meta
    assert back[-1].crc_ok is None and back[0].crc_ok is True


def test_the_naive_comment_workaround_is_no_longer_needed(tmp_path):
    """Issue 14: with '#' header lines, read_csv needed comment='#', which cut 'id#0' to 'id'. No '#' line now."""
    path = tmp_path / "m.csv"
    write_measurements(path, _records(), {})
    assert not any(line.startswith("#") for line in path.read_text().splitlines()[:2])
    assert pd.read_csv(path)["payload_text"][0] == "id#0"


def test_arrivals_without_emission_are_not_written_but_listed(tmp_path):
    path = tmp_path / "m.csv"
    early = dataclasses.replace(BASE, frame_index=-1, t_emit_s=math.nan, tof_s=math.nan, range_m=math.nan,
                                t_arrival_s=0.7)
    assert write_measurements(path, [early, BASE], {}) == 1
    df = pd.read_csv(path)
    assert list(df["frame_index"]) == [0] and np.isfinite(df[["t_emit_s", "range_m"]].to_numpy()).all()
    assert json.loads(measurement_sidecar_path(path).read_text())["unmatched_arrivals_s"] == [0.7]


def test_format_1_files_with_the_header_inside_are_still_read(tmp_path):
    row = {k: v for k, v in BASE.to_dict().items() if k in FIELDS[:16]}
    row["payload_text"] = "id#0, \"q\"\nx"
    header = {"format": "seamodem.measurements/1", "sound_speed_mps": 1500.0, "config": {"name": "jmse2024"}}
    csv_path = tmp_path / "old.csv"
    lines = [f"# {k}: {json.dumps(v)}" for k, v in header.items()]
    quoted = '"id#0, ""q""\nx"'
    values = [repr(v) if isinstance(v, float) else str(int(v)) for k, v in row.items() if k != "payload_text"]
    csv_path.write_text("\n".join(lines) + "\n" + ",".join(row) + "\n" + ",".join(values) + "," + quoted + "\n")
    jsonl_path = tmp_path / "old.jsonl"
    jsonl_path.write_text(json.dumps(header) + "\n" + json.dumps(row) + "\n")
    for path in (csv_path, jsonl_path):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            recs, meta = read_measurements(path)
        assert meta == header and len(recs) == 1
        assert recs[0].range_m == 300.0 and recs[0].payload_text == "id#0, \"q\"\nx"


def test_a_table_without_sidecar_is_read_with_a_warning(tmp_path):
    path = tmp_path / "m.csv"
    pd.DataFrame([BASE.to_dict()]).to_csv(path, index=False)  # e.g. saved again from pandas or a spreadsheet
    with pytest.warns(MeasurementFileWarning, match="no sidecar"):
        recs, meta = read_measurements(path)
    assert meta == {} and recs[0].range_m == 300.0 and recs[0].two_way is False


def test_bad_measurement_files_are_one_line_errors(tmp_path):
    path = tmp_path / "m.csv"
    write_measurements(path, [BASE], {})
    measurement_sidecar_path(path).write_text("{not json")
    with pytest.raises(InputFileError, match="not valid JSON"):
        read_measurements(path)
    measurement_sidecar_path(path).write_text(json.dumps({"format": "something/else"}))
    with pytest.raises(InputFileError, match="not a seamodem measurement sidecar"):
        read_measurements(path)
    bad = tmp_path / "b.jsonl"
    bad.write_text('{"frame_index": 0}\n')
    with pytest.raises(InputFileError, match="lacks"), pytest.warns(MeasurementFileWarning):
        read_measurements(bad)
