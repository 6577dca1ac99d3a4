"""The measurement record of SPEC §4 and its CSV / JSON Lines files.

One record per detected frame. Meanings (SPEC §1): t = 0 at the recording's
first sample; ``t_arrival_s`` is the reception time of the frame start on the
first (direct) path; ``tof_s = t_arrival_s − t_emit_s − clock_offset_s``
(one-way) or ``(t_arrival_s − t_emit_s − turnaround_s)/2`` (two-way, paper 004
§III.B, with ``t_emit_s`` the vehicle's poll emission); ``range_m = c·tof_s``
(slant range); v_r positive when closing, the mean over the frame.

The files are plain tables, one header row then one row per frame, so that
``pandas.read_csv(path)`` and ``pandas.read_json(path, lines=True)`` open them
as they are. What describes the run (format, command, sound speed, clock
offset or turnaround, frame configuration) goes in a JSON sidecar beside the
file, ``MEAS.csv.json`` (:func:`measurement_sidecar_path`). Files of format
``seamodem.measurements/1``, which carried that header inside (CSV ``#``
lines, a first JSON Lines object), are still read.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, NamedTuple, Sequence

from ..errors import InputFileError, SeamodemError, value_text
from ..io.files import atomic_outputs

__all__ = [
    "MeasurementRecord",
    "MEASUREMENT_FORMAT",
    "MeasurementFileWarning",
    "Measurements",
    "is_matched",
    "measurement_sidecar_path",
    "write_measurements",
    "read_measurements",
    "MeasurementWriter",
    "STREAM_HEADER_PREFIX",
]

#: format of the sidecar of a plain measurement file
MEASUREMENT_FORMAT = "seamodem.measurements/2"
#: the earlier format, with its header inside the file
MEASUREMENT_FORMAT_V1 = "seamodem.measurements/1"


class MeasurementFileWarning(UserWarning):
    """A measurement file that was read, but without the metadata it should have (no sidecar)."""


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
        Mean closing speed of the direct path over the frame [m/s]; from the
        estimate ``v_r_source`` names.
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
        Std of range_m [m]: the whole-frame timing's deviation (else the delay
        CRLB at the direct path's share of the SNR), with what the frame shows
        unmodelled (the direct path's channel shape across its band, its
        segments' timing scatter, the gap between the pilot's and the whole
        frame's arrivals beyond 3 combined σ).
    sigma_v_r_mps : float
        Std of v_r_mps [m/s]: whole-frame fit, the deviation of its segments'
        phases, at least the known-signal CRLB, with the direct path's
        log-amplitude rate (fading, a beating echo), a drift beyond 0.5 m/s²
        and its gap to the pilot bank beyond 3 combined σ unless the tone sides
        with the fit (``frame.bank_gap_sigmas_mps``); tone, its CRLB at
        the measured C/N0, inflated by its disagreement with the pilot bank
        (and with a fit on decisions set aside) when that exceeds 3 combined σ.
    sigma_v_r_bank_mps : float
        Std of v_r_bank_mps [m/s]: the pilot-Doppler CRLB at the measured SNR
        and the bank's error beyond it that its gaps to the last decoded
        frames' whole-frame fits show (their mean square less both noises; the
        bound of the pull of echoes over the pilot until three are in) and, on
        rows with a whole-frame fit, the channel's wander that fit shows
        (fading, a merged image's Doppler) and the bank's gap to the fit beyond
        3 combined σ.
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
        Equaliser passes run (1: DFE alone; more: turbo; beyond the turbo
        passes: a second pass with the echoes cancelled at their own Doppler,
        :func:`~seamodem.receive.demodulate.decode_through_echoes`); 0 when not decoded.
    ber : float
        Information-bit error rate after decoding, against the payload sent
        (sidecar); NaN when unknown or not decoded.
    raw_ber : float
        Bit error rate of the equaliser's hard decisions before the decoder; NaN
        when unknown or not decoded.
    source : str
        The recording the frame was found in (batch decoding of several
        files, :mod:`seamodem.batch`); empty for a single recording.
    azimuth_body_rad, elevation_body_rad : float
        Direct path's direction of arrival in the vehicle's body frame (x
        forward, y port, z up; :mod:`seamodem.receive.array`) [rad]; NaN with
        one hydrophone.
    sigma_azimuth_body_rad, sigma_elevation_body_rad : float
        Their CRLB-based standard deviations [rad]; NaN with one hydrophone.
    n_channels : int
        Hydrophones used.
    v_r_tone_mps : float
        Tone maximum-likelihood mean closing speed [m/s] (sums every path).
    v_r_source : str
        Where ``v_r_mps`` comes from: ``whole_frame`` (direct path's Doppler
        fitted over the whole decoded frame), ``whole_frame_decisions`` (CRC
        failed: pilots and confident decisions as the reference), ``tone``
        (tone ML: not decoded).
    tone_multipath_biased : bool or None
        The tone ML disagrees with the direct path's Doppler (whole-frame fit,
        else pilot bank) beyond 3 combined σ: echoes with other Doppler pull it.
    v_r_paths_spread_mps : float
        Largest minus smallest Doppler of the paths fitted over the whole
        frame [m/s]; NaN without the whole-frame fit.
    n_paths : int
        Paths resolved (whole-frame fit, else the arrival fit).
    blanked_fraction : float
        Fraction of the frame's input samples zeroed as impulses; NaN with
        blanking off.
    v_r_drift_mps2 : float
        The direct path's fitted drift of v_r over the frame [m/s²] (whole-frame
        fit; NaN without). Beyond what a vehicle does (|·| > 0.5 m/s²) it is
        phase wander that is not Doppler (fading, a merged echo): ``sigma_v_r_mps``
        then carries it.
    horizontal_range_m : float
        Horizontal range [m] of the direct ray traced through a sound-speed profile whose travel
        time is ``tof_s`` (``rx --sound-speed-profile`` with both depths; ``range_m`` is then that
        ray's straight-line distance √(R² + Δz²)); NaN without a profile.
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
    azimuth_body_rad: float = math.nan
    elevation_body_rad: float = math.nan
    sigma_azimuth_body_rad: float = math.nan
    sigma_elevation_body_rad: float = math.nan
    n_channels: int = 1
    v_r_tone_mps: float = math.nan
    v_r_source: str = ""
    tone_multipath_biased: bool | None = None
    v_r_paths_spread_mps: float = math.nan
    n_paths: int = 0
    blanked_fraction: float = math.nan
    v_r_drift_mps2: float = math.nan
    horizontal_range_m: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


FIELDS = tuple(f.name for f in dataclasses.fields(MeasurementRecord))
#: columns every file seamodem writes has: SPEC §4's required ones and the receiver's estimates ...
CORE_FIELDS = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db", "v_r_tone_eq9_mps",
               "v_r_bank_mps", "detection_z", "detection_rho", "sigma_range_m", "sigma_v_r_mps",
               "sigma_v_r_bank_mps", "tone_c_n0_dbhz")
#: what a file must have to be read (SPEC §4; ``seamodem nav track`` requires the same): the others are NaN if absent
REQUIRED_FIELDS = CORE_FIELDS[:7]
#: ... and the others, which a file may lack (measured without decoding, or written before the column existed)
OPTIONAL_FIELDS = tuple(f for f in FIELDS if f not in CORE_FIELDS)
_TYPES = {f.name: f.type for f in dataclasses.fields(MeasurementRecord)}


def measurement_sidecar_path(path: str | Path) -> Path:
    """The metadata sidecar of a measurement file: ``MEAS.csv`` → ``MEAS.csv.json``.

    The whole file name is kept, so that ``MEAS.csv`` and ``MEAS.jsonl`` have
    their own sidecars and neither replaces a recording's ``MEAS.json``.
    """
    path = Path(path)
    return path.with_name(path.name + ".json")


def is_matched(rec: MeasurementRecord) -> bool:
    """Whether a record has an emission (a frame index ≥ 0 and a finite ``t_emit_s``), hence a range."""
    return rec.frame_index >= 0 and math.isfinite(rec.t_emit_s)


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


def _csv_row(rec: MeasurementRecord) -> dict[str, Any]:
    from ..io.tables import csv_cell

    return {k: csv_cell(v) for k, v in rec.to_dict().items()}


def _schema(records_type, fields: Sequence[str]) -> dict[str, Any]:
    """The sidecar's ``schema``: the null token and each column's name, type and unit."""
    from ..io.tables import NULL_TOKEN, table_schema

    annotations = {f.name: str(f.type) for f in dataclasses.fields(records_type)}
    return {"null": NULL_TOKEN, "columns": table_schema(fields, annotations)}


def write_measurements(
    path: str | Path, records: Iterable[MeasurementRecord], header: dict[str, Any], *, kind: str | None = None,
    fields: Sequence[str] = FIELDS, keep_unmatched: bool = False,
) -> int:
    """Write the records to ``path`` (.csv or .jsonl) as they come, the metadata to its sidecar; returns how many.

    Parameters
    ----------
    path : str or Path
        The measurement file; its sidecar is :func:`measurement_sidecar_path`.
    records : iterable of MeasurementRecord
        Written one row each as they come (a streaming receiver's records
        reach the disk as frames are found).
    header : dict
        Run description (command, sound speed, clock offset, configuration...),
        written to the sidecar with ``format``, ``file``, ``columns`` and
        ``rows`` added.
    kind : {"csv", "jsonl"}, optional
        File format; default from the suffix of ``path``.
    fields : sequence of str
        Columns, in order: :data:`FIELDS`, or those of a record subclass
        (e.g. :data:`seamodem.receive.reference.REFERENCE_FIELDS`).
    keep_unmatched : bool
        Write arrivals without an emission too (their range empty), as
        ``rx --reference`` does when emission times are unknown.

    Notes
    -----
    Every row written is usable downstream: an arrival that no emission
    precedes (``frame_index`` −1, no ``t_emit_s``, so no range) is not a
    measurement and is left out; the sidecar lists such arrivals' times as
    ``unmatched_arrivals_s``. The file and its sidecar appear together when
    all records are written, or not at all
    (:func:`seamodem.io.files.atomic_outputs`).

    CSV: one header row, then one row per record; floats as Python's
    ``repr`` (shortest round-trip text); booleans ``true``/``false``; an
    unknown value (NaN, ``crc_ok`` of a frame not decoded) is the one null
    token, an empty cell; text quoted when it holds a comma, a quote or a line
    break. JSON Lines: one object per record, ``null`` when unknown. The
    sidecar's ``schema`` gives every column's type and unit
    (:mod:`seamodem.io.tables`, which also reads the files with pandas or polars).
    """
    path = Path(path)
    kind = kind or _format(path)
    sidecar = measurement_sidecar_path(path)
    n, unmatched, record_type = 0, [], MeasurementRecord
    with atomic_outputs(path, sidecar) as (tmp, tmp_sidecar):
        with tmp.open("w", encoding="utf-8", newline="") as f:
            writer = None
            if kind == "csv":
                writer = csv.DictWriter(f, fieldnames=fields)
                writer.writeheader()
            for rec in records:
                record_type = type(rec)
                if not keep_unmatched and not is_matched(rec):
                    unmatched.append(rec.t_arrival_s)
                    continue
                if writer is not None:
                    writer.writerow(_csv_row(rec))
                else:
                    f.write(json.dumps({k: _json_value(v) for k, v in rec.to_dict().items()}) + "\n")
                f.flush()
                n += 1
        meta = {"format": MEASUREMENT_FORMAT, "file": path.name, **header, "columns": list(fields), "rows": n,
                "unmatched_arrivals_s": unmatched, "schema": _schema(record_type, fields)}
        tmp_sidecar.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return n


#: a CSV measurement stream's first line: this, then its sidecar as one JSON object
STREAM_HEADER_PREFIX = "# seamodem: "


class MeasurementWriter:
    """Records written and flushed one at a time, as they are measured (a live receiver's output).

    The sidecar comes first: beside a file (``MEAS.csv.json``, marked
    ``"complete": false`` until :meth:`close`), or on a stream (stdout) as its
    first line: the JSON object itself (JSON Lines), or
    :data:`STREAM_HEADER_PREFIX` and the object (CSV). Then one row per record,
    each flushed as it is written.

    Parameters
    ----------
    path : str or Path or None
        The measurement file; None: write to ``stream``.
    header : dict
        Run description, as :func:`write_measurements`.
    kind : {"csv", "jsonl"}, optional
        Default: from the suffix of ``path``; on a stream "jsonl".
    stream : text file, optional
        Where to write when ``path`` is None (e.g. ``sys.stdout``).
    fields : sequence of str
        Columns, in order.

    Attributes
    ----------
    rows : int
        Records written.
    unmatched : list of float
        Arrival times of the records without an emission (not written).

    Notes
    -----
    Unlike :func:`write_measurements`, the file is not atomic: every row in it
    is a complete record as soon as it is there (a reader following the file
    sees frames as they are measured). A ``BrokenPipeError`` from the stream
    (its reader has gone) is left to the caller.
    """

    def __init__(self, path: str | Path | None, header: dict[str, Any], *, kind: str | None = None, stream=None,
                 fields: Sequence[str] = FIELDS, keep_unmatched: bool = False):
        self.path = None if path is None else Path(path)
        self.keep_unmatched = keep_unmatched
        self.kind = kind or ("jsonl" if self.path is None else _format(self.path))
        self.fields = list(fields)
        self.rows, self.unmatched = 0, []
        self.meta = {"format": MEASUREMENT_FORMAT, "file": "-" if self.path is None else self.path.name, **header,
                     "columns": self.fields, "rows": None, "complete": False}
        if self.path is None:
            self._f = stream
            line = json.dumps(self.meta)
            self._f.write(line + "\n" if self.kind == "jsonl" else STREAM_HEADER_PREFIX + line + "\n")
        else:
            self._write_sidecar()
            self._f = self.path.open("w", encoding="utf-8", newline="")
        self._csv = None
        if self.kind == "csv":
            self._csv = csv.DictWriter(self._f, fieldnames=self.fields)
            self._csv.writeheader()
        self._f.flush()

    def _write_sidecar(self) -> None:
        with atomic_outputs(measurement_sidecar_path(self.path)) as (tmp,):
            tmp.write_text(json.dumps(self.meta, indent=1) + "\n", encoding="utf-8")

    def write(self, rec: MeasurementRecord) -> bool:
        """Write one record and flush it; False (not written) for an arrival without an emission, unless
        ``keep_unmatched`` (then written too, its range empty, as :func:`write_measurements` does)."""
        if not self.keep_unmatched and not is_matched(rec):
            self.unmatched.append(rec.t_arrival_s)
            return False
        if self._csv is not None:
            self._csv.writerow(_csv_row(rec))
        else:
            self._f.write(json.dumps({k: _json_value(v) for k, v in rec.to_dict().items()}) + "\n")
        self._f.flush()
        self.rows += 1
        return True

    def close(self, **end: Any) -> None:
        """Close the file and complete its sidecar (rows, unmatched arrivals and ``end``, e.g. why it ended;
        ``complete=False`` in ``end`` marks a run that failed).

        On a stream nothing more is written (the stream is left open).
        """
        self.meta.update({"rows": self.rows, "complete": True, "unmatched_arrivals_s": self.unmatched} | end)
        if self.path is not None:
            self._f.close()
            self._write_sidecar()


def _parse(name: str, value):
    kind = _TYPES[name]
    if kind == "str":
        return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)
    if value is None or value == "":
        return None if "None" in kind else math.nan
    if kind == "int":
        return int(float(value))
    if "bool" in kind:
        if isinstance(value, str):
            text = value.strip().lower()
            if text in ("true", "false"):
                return text == "true"
            return bool(float(text))
        return bool(value)
    return float(value)


class Measurements(NamedTuple):
    """What :func:`read_measurements` returns: the records and the run's metadata.

    Unpacks as ``records, metadata = read_measurements(path)``.
    """

    records: list[MeasurementRecord]
    metadata: dict[str, Any]

    def columns(self) -> dict[str, list]:
        """The records column by column, e.g. for ``pandas.DataFrame(m.columns())``."""
        return {name: [getattr(r, name) for r in self.records] for name in FIELDS}


def _read_csv(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(inline header of a format-1 file or {}, rows) of a CSV measurement file."""
    header: dict[str, Any] = {}
    # newline="": a payload_text with a line break is one quoted field, kept as written
    text = _read_text(path)
    pos = 0
    while text.startswith("# ", pos):  # format 1: '# key: json' lines before the header row
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end + 1
        key, _, value = text[pos + 2 : end].strip().partition(": ")
        try:
            header[key] = json.loads(value)
        except json.JSONDecodeError:
            raise InputFileError(f"{path}: header line {key!r} is not valid JSON") from None
        pos = end
    try:
        return header, list(csv.DictReader(io.StringIO(text[pos:], newline="")))
    except csv.Error as exc:
        raise InputFileError(f"{path} is not a readable CSV table ({exc})") from None


def _read_text(path: Path) -> str:
    """A measurement file's text (UTF-8, a byte-order mark allowed)."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as f:
            return f.read()
    except UnicodeDecodeError as exc:
        raise InputFileError(f"{path} is not UTF-8 text (byte {exc.start} is {exc.object[exc.start]:#04x}): "
                             "not a measurement file, or damaged") from None


def _read_jsonl(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(inline header of a format-1 file or {}, rows) of a JSON Lines measurement file."""
    lines = [line for line in _read_text(path).split("\n") if line.strip()]
    rows = []
    for i, line in enumerate(lines):
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError as exc:
            raise InputFileError(f"{path}: line {i + 1} is not valid JSON ({exc.msg})") from None
        if not isinstance(rows[-1], dict):
            raise InputFileError(f"{path}: line {i + 1} is not a JSON object")
    header = {}
    if rows and "format" in rows[0] and "frame_index" not in rows[0]:
        header = rows.pop(0)
    return header, rows


def read_measurements(path: str | Path) -> Measurements:
    """Read a measurement file: its records and the metadata of its sidecar.

    Parameters
    ----------
    path : str or Path
        A .csv or .jsonl file written by :func:`write_measurements` (or by an
        earlier version, with the header inside the file), or any table with
        the record's columns.

    Returns
    -------
    Measurements
        ``(records, metadata)``; ``metadata`` is the sidecar (``format``,
        ``created_by``, ``sound_speed_mps``, ``config``...), or the header of a
        format-1 file, or ``{}``.

    Raises
    ------
    InputFileError
        Missing file, unknown format, a sidecar that is not JSON or of another
        format, a row without one of :data:`REQUIRED_FIELDS` (SPEC §4's seven; the
        other columns may be absent: NaN or their default) or a value that is not a number.

    Warns
    -----
    MeasurementFileWarning
        No sidecar and no header in the file: the rows are read, the metadata is empty.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"measurement file not found: {path}")
    kind = _format(path)
    header, rows = _read_csv(path) if kind == "csv" else _read_jsonl(path)
    sidecar = measurement_sidecar_path(path)
    if not header and sidecar.is_file():
        try:
            header = json.loads(sidecar.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputFileError(f"measurement sidecar {sidecar} is not valid JSON: {exc}") from None
        if not isinstance(header, dict) or header.get("format") != MEASUREMENT_FORMAT:
            raise InputFileError(f"{sidecar} is not a seamodem measurement sidecar ({MEASUREMENT_FORMAT!r} expected)")
    elif not header:
        warnings.warn(f"{path} has no sidecar ({sidecar.name}): rows read without the run's metadata",
                      MeasurementFileWarning, stacklevel=2)
    elif header.get("format") != MEASUREMENT_FORMAT_V1:
        raise InputFileError(f"{path} is not a seamodem measurement file ({MEASUREMENT_FORMAT_V1!r} header expected)")
    records = []
    for i, row in enumerate(rows):
        missing = [k for k in REQUIRED_FIELDS if k not in row]
        if missing:
            raise InputFileError(f"{path}: row {i + 1} lacks {', '.join(missing)}")
        values = {k: math.nan for k in CORE_FIELDS}  # a table of the required columns only (SPEC §4)
        for k in FIELDS:
            if k in row:
                try:
                    values[k] = _parse(k, row[k])
                except (TypeError, ValueError, OverflowError):
                    raise InputFileError(f"{path}: row {i + 1}, column {k}: {value_text(row[k])} is not "
                                         f"{'an' if _TYPES[k][0] in 'aeiou' else 'a'} {_TYPES[k]}") from None
        records.append(MeasurementRecord(**values))
    return Measurements(records, header)
