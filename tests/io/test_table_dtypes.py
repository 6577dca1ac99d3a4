"""Issue 29 item 9: every table ``rx`` and ``nav`` write reads with one type per column, in pandas and polars.

The type table of docs/records.md is generated here from what the libraries return (so it cannot drift).
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from seamodem.cli import main
from seamodem.io.tables import read_table
from seamodem.receive.janus.records import JANUS_FIELDS, JanusRecord
from seamodem.receive.records import FIELDS, MeasurementRecord, write_measurements
from seamodem.receive.reference.records import REFERENCE_FIELDS, ReferenceRecord

ROOT = Path(__file__).resolve().parents[2]
BASE = MeasurementRecord(
    frame_index=0, t_emit_s=0.0, t_arrival_s=0.2, tof_s=0.2, range_m=150.0, v_r_mps=-1.0, snr_db=11.0,
    v_r_tone_eq9_mps=-1.0, v_r_bank_mps=-1.0, detection_z=500.0, detection_rho=0.6, sigma_range_m=0.01,
    sigma_v_r_mps=0.02, sigma_v_r_bank_mps=0.02, tone_c_n0_dbhz=50.0,
)
#: the pandas and polars dtype each schema type must come in as, from CSV and from JSON Lines alike
EXPECTED = {"int": ("int64", "Int64"), "float": ("float64", "Float64"), "bool": ("boolean", "Boolean"),
            "str": ("str", "String")}


def _records(kind: str) -> tuple[list, tuple]:
    """What each rx mode writes, one decoded frame and one not decoded (crc_ok null, text empty)."""
    recs = [dataclasses.replace(BASE, frame_index=k, t_emit_s=3.0 * k, t_arrival_s=3.0 * k + 0.1 * (k + 1),
                                crc_ok=True if k == 0 else None) for k in range(2)]
    if kind == "array":
        return [dataclasses.replace(r, azimuth_body_rad=0.1, sigma_azimuth_body_rad=0.01, n_channels=4)
                for r in recs], FIELDS
    if kind == "reference":
        return [ReferenceRecord(**dataclasses.asdict(r), reference="lfm") for r in recs], REFERENCE_FIELDS
    if kind == "janus":
        return [JanusRecord(**dataclasses.asdict(r), mobility=True) for r in recs], JANUS_FIELDS
    return recs, FIELDS


def _nav_files(tmp: Path) -> dict[str, Path]:
    """nav track's track and frame files (from a JSON Lines record file, item 1) and nav simulate's table."""
    t = np.arange(0.0, 30.01, 0.25)
    with (tmp / "imu.csv").open("w") as f:
        f.write("t_s,heading_rad,omega_rad_s,accel_mps2\n" + "".join(f"{v},0,0,0\n" for v in t))
    recs = [dataclasses.replace(BASE, frame_index=k, t_emit_s=3.0 * k, t_arrival_s=3.0 * k + 0.05,
                                range_m=float(np.hypot(3.0 * k - 50, 30)), v_r_mps=0.0, crc_ok=True)
            for k in range(1, 10)]
    write_measurements(tmp / "m.jsonl", recs, {"sound_speed_mps": 1500.0})
    assert main(["nav", "track", str(tmp / "m.jsonl"), "--imu", str(tmp / "imu.csv"), "--beacon", "50,-30",
                 "--start", "0,0", "--start-speed", "1", "-o", str(tmp / "track.csv")]) == 0
    shutil.copy(ROOT / "tests/navigation/data/nav_simulate_paper_tcom3_20_runs60_seed1.csv", tmp / "table.csv")
    return {"nav track: OUT.csv": tmp / "track.csv", "nav track: OUT_frames.csv": tmp / "track_frames.csv",
            "nav simulate: DIR/table.csv": tmp / "table.csv"}


@pytest.fixture(scope="module")
def tables(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("tables")
    files = {}
    for kind, command in (("frames", "rx"), ("array", "rx --array"), ("reference", "rx --reference"),
                          ("janus", "rx --janus")):
        recs, fields = _records(kind)
        for suffix in ("csv", "jsonl"):
            path = tmp / f"{kind}.{suffix}"
            write_measurements(path, recs, {}, fields=fields, keep_unmatched=True)
            files[f"{command}: M.{suffix}"] = path
    return files | _nav_files(tmp)


def _schema(path: Path) -> dict[str, str]:
    sidecar = path.with_name(path.name + ".json")
    if sidecar.exists():
        return {c["name"]: c["type"] for c in json.loads(sidecar.read_text())["schema"]["columns"]}
    from seamodem.io.tables import table_schema

    return {c["name"]: c["type"] for c in table_schema(pd.read_csv(path, nrows=0).columns)}


def test_every_column_of_every_table_has_its_type_in_both_libraries(tables):
    pytest.importorskip("polars")
    for name, path in tables.items():
        schema = _schema(path)
        assert None not in schema.values(), (name, [c for c, t in schema.items() if t is None])
        pandas, polars = read_table(path), read_table(path, library="polars")
        for column, kind in schema.items():
            got = (str(pandas[column].dtype), str(polars[column].dtype))
            # pandas < 3 names its string dtype object
            assert got == EXPECTED[kind] or got == ("object", EXPECTED[kind][1]), (name, column, kind, got)


def test_nulls_are_one_token_and_text_stays_text(tables):
    """Item 9: ``source`` (always empty) came in as float64, all-"nan" columns as polars String."""
    pytest.importorskip("polars")
    for suffix in ("csv", "jsonl"):
        path = tables[f"rx: M.{suffix}"]
        df, pf = read_table(path), read_table(path, library="polars")
        assert list(df["source"]) == ["", ""] and list(pf["source"]) == ["", ""]
        assert df["crc_ok"].tolist()[0] is True and pd.isna(df["crc_ok"].iloc[1])
        assert pf["crc_ok"].to_list() == [True, None] and pf["azimuth_body_rad"].null_count() == 2
        assert np.isnan(df["azimuth_body_rad"]).all()
    text = tables["rx: M.csv"].read_text()
    assert "nan" not in text and ",true," in text  # the one null token is the empty cell; booleans as words


def test_plain_pandas_reads_booleans_as_booleans_in_both_formats(tables):
    """Item 9: ``crc_ok`` was an integer in CSV (1/0) and a boolean in JSON Lines."""
    for kind in ("frames", "janus"):
        recs, fields = _records(kind)
        decoded = [dataclasses.replace(r, crc_ok=True) for r in recs]
        dtypes = set()
        for suffix in ("csv", "jsonl"):
            path = tables[next(iter(tables))].with_name(f"decoded_{kind}.{suffix}")
            write_measurements(path, decoded, {}, fields=fields)
            df = pd.read_csv(path) if suffix == "csv" else pd.read_json(path, lines=True)
            dtypes |= {(c, str(df[c].dtype)) for c in ("crc_ok", "two_way")}
        assert dtypes == {("crc_ok", "bool"), ("two_way", "bool")}, dtypes


def dtype_table(tables) -> str:
    """docs/records.md's table: per file, its columns that are not float, by type."""
    lines = ["| file | int | bool | str |", "|---|---|---|---|"]
    for name, path in tables.items():
        schema = _schema(path)
        cells = [", ".join(f"`{c}`" for c, t in schema.items() if t == kind) or "—" for kind in ("int", "bool", "str")]
        lines.append(f"| `{name}` | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def test_docs_give_the_dtype_tables(tables):
    page = (ROOT / "docs/records.md").read_text(encoding="utf-8")
    shown = re.search(r"<!-- dtype-table -->\n(.*?)\n<!-- /dtype-table -->", page, re.S)
    assert shown and shown.group(1) == dtype_table(tables), (
        "docs/records.md's per-file table is out of date; this test's dtype_table() gives it:\n" + dtype_table(tables))
    for kind, (pandas_dtype, polars_dtype) in EXPECTED.items():
        assert f"| `{kind}` | `{pandas_dtype}` | `{polars_dtype}` |" in page, kind
