"""The measurement record of SPEC §4 and its CSV / JSON Lines files.

One record per detected frame. Meanings (SPEC §1): t = 0 at the recording's
first sample; ``t_arrival_s`` is the reception time of the frame start on the
first (direct) path; ``tof_s = t_arrival_s − t_emit_s − clock_offset_s``
(one-way) or ``(t_arrival_s − t_emit_s − turnaround_s)/2`` (two-way, paper 004
§III.B, with ``t_emit_s`` the vehicle's poll emission); ``range_m = c·tof_s``
(slant range); v_r positive when closing, the mean over the frame.

Both files start with a header that records the format, the sound speed, the
clock offset or turnaround and the frame configuration: CSV as ``#`` comment
lines, JSON Lines as a first object with ``"format"``.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

from ..errors import InputFileError, SeamodemError

__all__ = ["MeasurementRecord", "MEASUREMENT_FORMAT", "write_measurements", "read_measurements"]

MEASUREMENT_FORMAT = "seamodem.measurements/1"


@dataclass(frozen=True)
class MeasurementRecord:
    """Range and radial speed of one received frame.

    Attributes
    ----------
    frame_index : int
        Index k of the emission (sidecar frame, or T0 + k·T_com); −1 when no
        emission precedes the arrival.
    t_emit_s : float
        Emission time of the frame start (two-way: of the poll) [s]; NaN if unknown.
    t_arrival_s : float
        Reception time of the frame start, first path [s].
    tof_s : float
        One-way time of flight [s].
    range_m : float
        Slant range c·tof [m].
    v_r_mps : float
        Mean closing speed over the frame, tone maximum-likelihood estimate [m/s].
    snr_db : float
        Measured in-band SNR (SPEC §1): frame power over the noise measured
        just before and after the frame, in B [dB]; from the pilot residual
        (echoes then count as noise) when no noise window exists.
    v_r_tone_eq9_mps : float
        Mean of the tone phase-derivative track, paper 000 eq 9 [m/s].
    v_r_bank_mps : float
        Doppler-scaled pilot filter bank refined by dichotomy [m/s] (over the pilot only).
    detection_z : float
        |c|²/σ_c² of the pilot correlation (Exp(1) in noise).
    detection_rho : float
        Normalised pilot correlation in [0, 1].
    sigma_range_m : float
        Std of range_m from the delay CRLB at the measured SNR [m].
    sigma_v_r_mps : float
        Std of v_r_mps from the tone CRLB at the measured tone C/N0 [m/s].
    sigma_v_r_bank_mps : float
        Std of v_r_bank_mps from the pilot-Doppler CRLB at the measured SNR [m/s].
    tone_c_n0_dbhz : float
        Measured tone C/N0 [dB-Hz].
    two_way : bool
        True when tof_s comes from a round trip (paper 004).
    crc_ok : bool or None
        The payload's CRC passed; None when the frame was not decoded (decoding
        off, or the frame cut by the end of the recording).
    payload_hex : str
        Decoded payload bytes in hex; empty unless ``crc_ok``.
    payload_text : str
        The payload as UTF-8 text when ``crc_ok`` and printable; else empty.
    eq_snr_db : float
        SNR at the equaliser output [dB]; NaN when not decoded.
    decode_passes : int
        Equaliser passes run (1: DFE alone; more: turbo); 0 when not decoded.
    ber : float
        Information-bit error rate after decoding, against the payload sent
        (sidecar); NaN when unknown or not decoded.
    raw_ber : float
        Bit error rate of the equaliser's hard decisions before the decoder; NaN
        when unknown or not decoded.
    source : str
        The recording the frame was found in (batch decoding of several
        files, :mod:`seamodem.batch`); empty for a single recording.
    """

    frame_index: int
    t_emit_s: float
    t_arrival_s: float
    tof_s: float
    range_m: float
    v_r_mps: float
    snr_db: float
    v_r_tone_eq9_mps: float
    v_r_bank_mps: float
    detection_z: float
    detection_rho: float
    sigma_range_m: float
    sigma_v_r_mps: float
    sigma_v_r_bank_mps: float
    tone_c_n0_dbhz: float
    two_way: bool = False
    crc_ok: bool | None = None
    payload_hex: str = ""
    payload_text: str = ""
    eq_snr_db: float = math.nan
    decode_passes: int = 0
    ber: float = math.nan
    raw_ber: float = math.nan
    source: str = ""

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


FIELDS = tuple(f.name for f in dataclasses.fields(MeasurementRecord))
#: columns a file may lack (measured without decoding, or written before decoding existed)
OPTIONAL_FIELDS = ("crc_ok", "payload_hex", "payload_text", "eq_snr_db", "decode_passes", "ber", "raw_ber", "source")
_TYPES = {f.name: f.type for f in dataclasses.fields(MeasurementRecord)}


def _format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return "csv"
    if suffix in (".jsonl", ".ndjson"):
        return "jsonl"
    raise SeamodemError(f"output: measurement file must end in .csv or .jsonl, got {str(path)!r}")


def _json_value(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_measurements(
    path: str | Path, records: Iterable[MeasurementRecord], header: dict[str, Any], *, kind: str | None = None
) -> int:
    """Write records to ``path`` (.csv or .jsonl) as they come; returns how many.

    Parameters
    ----------
    header : dict
        Run description (sound speed, clock offset, configuration...), written
        first with ``format`` added.
    kind : {"csv", "jsonl"}, optional
        File format; default from the suffix of ``path``.

    Notes
    -----
    The caller wraps this in :func:`seamodem.io.files.atomic_outputs` so that a
    failed run leaves no partial file.
    """
    path = Path(path)
    kind = kind or _format(path)
    head = {"format": MEASUREMENT_FORMAT, **header}
    n = 0
    with path.open("w", encoding="utf-8", newline="") as f:
        if kind == "csv":
            for key, value in head.items():
                f.write(f"# {key}: {json.dumps(value)}\n")
            writer = csv.DictWriter(f, fieldnames=FIELDS)
            writer.writeheader()
            for rec in records:
                row = rec.to_dict()
                row["crc_ok"] = "" if rec.crc_ok is None else int(rec.crc_ok)
                row["two_way"] = int(rec.two_way)
                writer.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in row.items()})
                f.flush()
                n += 1
        else:
            f.write(json.dumps(head) + "\n")
            for rec in records:
                f.write(json.dumps({k: _json_value(v) for k, v in rec.to_dict().items()}) + "\n")
                f.flush()
                n += 1
    return n


def _parse(name: str, value):
    kind = _TYPES[name]
    if kind == "str":
        return "" if value is None else str(value)
    if value is None or value == "":
        return None if "None" in kind else math.nan
    if kind == "int":
        return int(value)
    if "bool" in kind:
        return bool(int(value)) if isinstance(value, str) else bool(value)
    return float(value)


def read_measurements(path: str | Path) -> tuple[list[MeasurementRecord], dict[str, Any]]:
    """Read a file written by :func:`write_measurements`: (records, header).

    Raises
    ------
    InputFileError
        Missing file, unknown format, a row with missing columns.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"measurement file not found: {path}")
    kind = _format(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    header: dict[str, Any] = {}
    rows: list[dict[str, Any]] = []
    if kind == "csv":
        body = []
        for line in lines:
            if line.startswith("# "):
                key, _, value = line[2:].partition(": ")
                header[key] = json.loads(value)
            else:
                body.append(line)
        rows = list(csv.DictReader(body))
    else:
        if lines:
            header = json.loads(lines[0])
        rows = [json.loads(line) for line in lines[1:] if line.strip()]
    if header.get("format") != MEASUREMENT_FORMAT:
        raise InputFileError(f"{path} is not a seamodem measurement file ({MEASUREMENT_FORMAT!r} expected)")
    records = []
    for i, row in enumerate(rows):
        missing = [k for k in FIELDS if k not in row and k not in OPTIONAL_FIELDS]
        if missing:
            raise InputFileError(f"{path}: row {i + 1} lacks {', '.join(missing)}")
        records.append(MeasurementRecord(**{k: _parse(k, row[k]) for k in FIELDS if k in row}))
    return records, header
