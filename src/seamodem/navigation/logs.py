"""Reading what a vehicle logs: IMU/AHRS samples, the receiver's measurement records, GNSS fixes, depth.

Each reader returns a dict of arrays keyed by column name, in time order. What
can be repaired is repaired with one :class:`LogWarning` per defect, a single line
naming the file, the defect and how many rows it touched (unsorted times are
sorted, exact duplicate times keep their first row, rows with missing values are
dropped); what cannot is a one-line :class:`~seamodem.errors.InputFileError` or
:class:`~seamodem.errors.ConfigError`.

Files are read with the :mod:`csv` module, so a quoted field may hold commas, ``#``
and quotes (the receiver's ``payload_text``). Lines starting with ``#`` before the
header are metadata comments (``# key: json-value``, as ``seamodem rx`` writes them;
:func:`read_metadata`); a file without them is read the same way. A ``.jsonl`` file
(one JSON object per line, as ``seamodem rx -o M.jsonl`` writes) is read as the same
table: ``null`` is an empty cell, ``true``/``false`` are 1/0. A binary file is refused
by name, without its bytes.
"""

from __future__ import annotations

import csv
import io
import json
import math
import warnings
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputFileError, value_text
from .geometry import check_lat_lon, geodetic_to_local

__all__ = [
    "LogWarning",
    "IMU_COLUMNS",
    "MEASUREMENT_COLUMNS",
    "FIX_SIGMA_M",
    "GAP_FACTOR",
    "read_columns",
    "read_metadata",
    "read_imu",
    "read_measurements",
    "read_fixes",
    "read_depth",
    "depth_at",
    "parse_pair",
    "parse_position",
]

IMU_COLUMNS = ("t_s", "heading_rad", "omega_rad_s", "accel_mps2")
MEASUREMENT_COLUMNS = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db")
#: Other names of the records' standard deviations → the names ``seamodem rx`` writes.
SIGMA_ALIASES = {"range_std_m": "sigma_range_m", "v_r_std_mps": "sigma_v_r_mps"}
#: Default 1-σ error of a GNSS fix, per horizontal axis [m]. The GPS SPS Performance
#: Standard (5th ed., 2020) bounds the global-average horizontal error at 8 m (95 %);
#: for a circular 2-D Gaussian the 95 % radius is 2.45 σ, so σ ≈ 3.3 m, which is also
#: what a single-frequency receiver with open sky typically shows (2–4 m).
FIX_SIGMA_M = 3.0
#: A time step longer than this many median steps is reported as a gap.
GAP_FACTOR = 5.0


class LogWarning(UserWarning):
    """A log file that was usable after a repair (sorted, de-duplicated, rows dropped, gaps)."""


def _warn(message: str) -> None:
    warnings.warn(message, LogWarning, stacklevel=3)


def _read_table(path, what: str):
    """(header, data rows as lists of str, comment lines before the header) of a CSV file."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"{what} not found: {path}")
    raw = path.read_bytes()
    if b"\0" in raw[:4096]:  # a recording or an archive: its bytes would make an unreadable message
        raise InputFileError(f"{what} {path}: binary data, not a text table (a CSV or JSON Lines file of "
                             "named columns expected)")
    text = raw.decode("utf-8-sig", errors="replace")  # -sig: a spreadsheet's byte-order mark
    if path.suffix.lower() == ".jsonl" or text.lstrip().startswith("{"):
        return _jsonl_table(text, path, what)
    lines = text.splitlines(keepends=True)
    comments, k = [], 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("#")):
        if lines[k].strip():
            comments.append(lines[k].strip()[1:].strip())
        k += 1
    reader = csv.reader(io.StringIO("".join(lines[k:])))
    header = [h.strip() for h in next(reader, [])]
    # Blank rows and '#' rows after the header are skipped, as the earlier line-based reader did.
    rows = [r for r in reader if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not header or not rows:
        raise InputFileError(f"{what} {path}: no data rows (need a header line and at least one row)")
    return header, rows, comments


def _jsonl_cell(value) -> str:
    """A JSON value as the CSV reader would see it: null → empty, true/false → 1/0."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(int(value))
    return str(value)


def _jsonl_table(text: str, path: Path, what: str):
    """(header, rows, []) of a JSON Lines file (``seamodem rx -o M.jsonl``): one object per line."""
    objects = []
    for i, line in enumerate(text.splitlines()):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputFileError(f"{what} {path}: line {i + 1} is not valid JSON ({exc.msg})") from None
        if not isinstance(obj, dict):
            raise InputFileError(f"{what} {path}: line {i + 1} is not a JSON object")
        objects.append(obj)
    if objects and "format" in objects[0] and "frame_index" not in objects[0]:
        objects.pop(0)  # format 1's header object
    header = list(dict.fromkeys(k for obj in objects for k in obj))
    if not header:
        raise InputFileError(f"{what} {path}: no data rows (need at least one JSON object)")
    return header, [[_jsonl_cell(obj.get(k)) for k in header] for obj in objects], []


#: a boolean cell (``crc_ok``) as a number
_BOOLEANS = {"true": 1.0, "false": 0.0}


def _float_column(rows, i: int, column: str, path, what: str) -> np.ndarray:
    """Column ``i`` as floats; an empty or missing cell is NaN, text that is not a number an error."""
    out = np.empty(len(rows))
    for r, row in enumerate(rows):
        cell = row[i].strip() if i < len(row) else ""
        try:
            out[r] = _BOOLEANS.get(cell.lower(), math.nan) if cell.lower() in _BOOLEANS or not cell else float(cell)
        except ValueError:
            raise InputFileError(f"{what} {path}: data row {r + 1}, column {column}: not a number ({value_text(cell)})") from None
    return out


def _check_columns(header, required, path, what) -> None:
    missing = [c for c in required if c not in header]
    if missing:
        has = ", ".join(h if len(h) <= 40 else h[:37] + "..." for h in header[:12])
        more = f" and {len(header) - 12} more" if len(header) > 12 else ""
        raise InputFileError(f"{what} {path}: missing column(s) {', '.join(missing)} (has: {has}{more})")


def read_columns(path, required, *, optional=(), time_column=None, what="file") -> dict[str, np.ndarray]:
    """Read named float columns of a CSV, strictly: every defect is a one-line error.

    Parameters
    ----------
    path : str or Path
    required, optional : sequence of str
        Column names; ``optional`` ones are returned when present.
    time_column : str, optional
        A column that must be strictly increasing.
    what : str
        Name of the file in messages ("IMU file").

    Raises
    ------
    InputFileError
        Missing or empty file, missing columns, non-numeric or NaN values, or
        (for ``time_column``) times that are not strictly increasing.

    See Also
    --------
    read_imu, read_measurements : lenient readers that repair what they can, with warnings.
    """
    header, rows, _ = _read_table(path, what)
    _check_columns(header, required, path, what)
    wanted = list(required) + [c for c in optional if c in header]
    data = {c: _float_column(rows, header.index(c), c, path, what) for c in wanted}
    for c in wanted:
        bad = np.flatnonzero(~np.isfinite(data[c]))
        if bad.size:
            raise InputFileError(f"{what} {path}: column {c} has {bad.size} NaN/inf value(s), first at data row {bad[0] + 1}")
    if time_column is not None:
        t = data[time_column]
        steps = np.diff(t)
        if np.any(steps == 0):
            k = int(np.flatnonzero(steps == 0)[0])
            raise InputFileError(f"{what} {path}: duplicate time {time_column} = {float(t[k])!r} at data rows {k + 1} and {k + 2}")
        if np.any(steps < 0):
            k = int(np.flatnonzero(steps < 0)[0])
            raise InputFileError(f"{what} {path}: {time_column} not sorted (data row {k + 2}: {float(t[k + 1])!r} after {float(t[k])!r})")
    return data


def _take(data: dict, keep) -> dict:
    return {c: v[keep] for c, v in data.items()}


def _drop_missing(data: dict, required, path, what: str, *, why: str = "") -> dict:
    """Drop rows with NaN/inf in a required column (one warning); a column entirely missing is an error."""
    n = len(data[required[0]])
    bad_by_column = {c: ~np.isfinite(data[c]) for c in required}
    for c, bad in bad_by_column.items():
        if bad.all():
            raise InputFileError(f"{what} {path}: column {c} has no numeric value in its {n} row(s)")
    bad = np.logical_or.reduce(list(bad_by_column.values()))
    if bad.any():
        counts = ", ".join(f"{c} {int(b.sum())}" for c, b in bad_by_column.items() if b.any())
        _warn(f"{what} {path}: skipped {int(bad.sum())} of {n} row(s) with NaN or empty values (in {counts}){why}")
        data = _take(data, ~bad)
    return data


def _fill_optional(data: dict, optional, t: str, path, what: str) -> dict:
    """Interpolate NaN cells of optional columns in time (one warning each); drop a column that has none."""
    for c in [c for c in optional if c in data]:
        bad = ~np.isfinite(data[c])
        if bad.all():
            _warn(f"{what} {path}: column {c} has no numeric value; ignored")
            del data[c]
        elif bad.any():
            data[c][bad] = np.interp(data[t][bad], data[t][~bad], data[c][~bad])
            _warn(f"{what} {path}: filled {int(bad.sum())} NaN value(s) of {c} by linear interpolation in {t}")
    return data


def _sort_and_dedupe(data: dict, t: str, path, what: str) -> dict:
    """Sort by ``t`` (stable) and keep the first row of each exact duplicate time, one warning each."""
    order = np.argsort(data[t], kind="stable")
    moved = int(np.count_nonzero(order != np.arange(order.size)))
    if moved:
        _warn(f"{what} {path}: {t} not in time order; sorted ({moved} row(s) moved)")
        data = _take(data, order)
    dup = np.r_[False, np.diff(data[t]) == 0]
    if dup.any():
        first = data[t][np.flatnonzero(dup)[0]]
        _warn(f"{what} {path}: dropped {int(dup.sum())} row(s) with a duplicate {t} (kept the first of each; "
              f"first at {t} = {first:g})")
        data = _take(data, ~dup)
    return data


def _warn_gaps(t: np.ndarray, column: str, path, what: str, factor: float = GAP_FACTOR) -> None:
    if t.size < 3:
        return
    steps = np.diff(t)
    median = float(np.median(steps))
    gaps = np.flatnonzero(steps > factor * median)
    if gaps.size:
        listed = ", ".join(f"{steps[k]:g} s at {column} = {t[k]:g}" for k in gaps[:3])
        more = f" and {gaps.size - 3} more" if gaps.size > 3 else ""
        _warn(f"{what} {path}: {gaps.size} gap(s) longer than {factor:g} × the median step {median:g} s: "
              f"{listed}{more}")


def read_metadata(path) -> dict:
    """The ``# key: value`` comment lines before a CSV header, as a dict (values JSON-decoded when they parse).

    Returns an empty dict for a file without them (e.g. when the metadata moved to a JSON sidecar).
    """
    _, _, comments = _read_table(path, "file")
    meta = {}
    for line in comments:
        key, sep, value = line.partition(":")
        if not sep:
            continue
        try:
            meta[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            meta[key.strip()] = value.strip()
    return meta


def read_imu(path, *, what: str = "IMU file") -> dict[str, np.ndarray]:
    """IMU/AHRS samples at arbitrary times, cleaned.

    Parameters
    ----------
    path : str or Path
        CSV with columns ``t_s`` [s], ``heading_rad`` [rad] (or ``heading_deg``
        [deg], converted to radians; ``heading_rad`` wins when both are present),
        ``omega_rad_s`` [rad/s], ``accel_mps2`` [m/s²]; optional
        ``heading_std_rad`` [rad] and ``depth_m`` [m]. Any time stamps: the
        samples need not be regular.

    Returns
    -------
    dict of ndarray
        ``t_s``, ``heading_rad``, ``omega_rad_s``, ``accel_mps2`` and the optional
        columns present, shape (n,), strictly increasing ``t_s``. Heading is not
        unwrapped (the filters wrap angles themselves).

    Raises
    ------
    InputFileError
        Missing or empty file, missing column, text that is not a number, a
        required column with no numeric value.

    Warns
    -----
    LogWarning
        One line each: rows dropped for NaN/empty values in a required column
        (count); NaN cells of an optional column interpolated (count); times out
        of order, sorted (rows moved); exact duplicate times, first kept (count);
        gaps longer than :data:`GAP_FACTOR` × the median step (time and length).
    """
    header, rows, _ = _read_table(path, what)
    degrees = "heading_rad" not in header and "heading_deg" in header
    heading = "heading_deg" if degrees else "heading_rad"
    required = ("t_s", heading, "omega_rad_s", "accel_mps2")
    _check_columns(header, required, path, what)
    optional = [c for c in ("heading_std_rad", "depth_m") if c in header]
    data = {c: _float_column(rows, header.index(c), c, path, what) for c in (*required, *optional)}
    if degrees:
        data["heading_rad"] = np.radians(data.pop("heading_deg"))
    data = _drop_missing(data, IMU_COLUMNS, path, what)
    data = _sort_and_dedupe(data, "t_s", path, what)
    data = _fill_optional(data, optional, "t_s", path, what)
    _warn_gaps(data["t_s"], "t_s", path, what)
    return data


def read_measurements(path, *, what: str = "measurement file") -> dict[str, np.ndarray]:
    """The receiver's measurement records (SPEC §4), cleaned, in arrival-time order.

    Parameters
    ----------
    path : str or Path
        CSV or JSON Lines (what any ``seamodem rx`` mode writes) with the columns ``frame_index, t_emit_s, t_arrival_s, tof_s, range_m,
        v_r_mps, snr_db`` (SI units, SPEC §1); optional ``sigma_range_m`` [m] and
        ``sigma_v_r_mps`` [m/s] (also accepted as ``range_std_m``,
        ``v_r_std_mps``), ``crc_ok`` (true, false, 1, 0 or empty), ``status`` (text) and, from a
        hydrophone array (``seamodem rx --array``), ``azimuth_body_rad`` and
        ``sigma_azimuth_body_rad`` (empty where a frame has none). Other
        columns (``payload_text``...) are ignored. Metadata comment lines before
        the header are optional (:func:`read_metadata`).

    Returns
    -------
    dict of ndarray
        The required columns as float (n,); ``sigma_range_m`` and
        ``sigma_v_r_mps`` when present under either name (NaN where a row has
        none, with a warning); ``crc_ok`` as float (1, 0, NaN when unknown);
        ``status`` as str.

    Raises
    ------
    InputFileError
        Missing or empty file, missing column, text that is not a number, a
        required column with no numeric value, a standard deviation ≤ 0.

    Warns
    -----
    LogWarning
        Rows with NaN or empty values in a required column are skipped (e.g. a
        detection before the first emission, frame_index −1, has no emission time
        and so no range); times out of order are sorted; rows with a duplicate
        ``t_arrival_s`` keep the first. One line each, with the count.
    """
    header, rows, _ = _read_table(path, what)
    # An alias is renamed unless the file also has the canonical column (which then wins).
    header = [SIGMA_ALIASES[h] if h in SIGMA_ALIASES and SIGMA_ALIASES[h] not in header else h for h in header]
    _check_columns(header, MEASUREMENT_COLUMNS, path, what)
    numeric = [*MEASUREMENT_COLUMNS, *(c for c in ("sigma_range_m", "sigma_v_r_mps", "crc_ok", "azimuth_body_rad",
                                                   "sigma_azimuth_body_rad") if c in header)]
    data = {c: _float_column(rows, header.index(c), c, path, what) for c in numeric}
    if "status" in header:
        i = header.index("status")
        data["status"] = np.array([r[i] if i < len(r) else "" for r in rows], dtype=str)
    data = _drop_missing(data, MEASUREMENT_COLUMNS, path, what)
    data = _sort_and_dedupe(data, "t_arrival_s", path, what)
    for c in ("sigma_range_m", "sigma_v_r_mps"):
        if c not in data:
            continue
        if np.any(data[c] <= 0):
            k = int(np.flatnonzero(data[c] <= 0)[0])
            raise InputFileError(f"{what} {path}: {c} must be > 0, got {float(data[c][k])!r} at t_arrival_s = "
                                 f"{data['t_arrival_s'][k]:g}")
        if np.isnan(data[c]).any():
            _warn(f"{what} {path}: {int(np.isnan(data[c]).sum())} row(s) have no {c} (NaN, left as NaN): "
                  f"an estimator weighting by {c} needs its own value for them")
    return data


def read_fixes(path, *, origin=None, what: str = "GNSS fix file") -> dict[str, np.ndarray]:
    """GNSS fixes taken at the surface (start, and any later surfacing), cleaned.

    Parameters
    ----------
    path : str or Path
        CSV with ``t_s`` [s] and either ``x_m, y_m`` (local east, north [m]) or
        ``lat_deg, lon_deg`` (WGS-84 [deg]); optional ``sigma_m``, the 1-σ error
        per horizontal axis [m].
    origin : (float, float), optional
        (lat, lon) [deg] of the local frame's origin (the beacon): geodetic fixes
        are then converted to ``x_m, y_m`` and checked against it for a swapped
        latitude and longitude.

    Returns
    -------
    dict of ndarray
        ``t_s``, ``sigma_m`` (default :data:`FIX_SIGMA_M` = 3 m: the GPS SPS
        95 % horizontal bound of 8 m over 2.45), and ``x_m, y_m`` and/or
        ``lat_deg, lon_deg`` as given; ``x_m, y_m`` also when geodetic fixes come
        with ``origin``.

    Raises
    ------
    InputFileError
        Missing or empty file, neither column pair, a non-positive ``sigma_m``.
    ConfigError
        A latitude outside [−90, 90] or a longitude outside [−180, 180] degrees.
    """
    header, rows, _ = _read_table(path, what)
    _check_columns(header, ("t_s",), path, what)
    if {"x_m", "y_m"} <= set(header):
        position = ("x_m", "y_m")
    elif {"lat_deg", "lon_deg"} <= set(header):
        position = ("lat_deg", "lon_deg")
    else:
        raise InputFileError(f"{what} {path}: needs columns x_m, y_m or lat_deg, lon_deg (has: {', '.join(header)})")
    extra = [c for c in ("lat_deg", "lon_deg", "sigma_m") if c in header and c not in position]
    data = {c: _float_column(rows, header.index(c), c, path, what) for c in ("t_s", *position, *extra)}
    data = _drop_missing(data, ("t_s", *position), path, what)
    data = _sort_and_dedupe(data, "t_s", path, what)
    if "sigma_m" in data:
        data = _fill_optional(data, ["sigma_m"], "t_s", path, what)
    if "sigma_m" in data:
        if not np.all(data["sigma_m"] > 0):
            k = int(np.flatnonzero(~(data["sigma_m"] > 0))[0])
            raise InputFileError(f"{what} {path}: sigma_m must be > 0, got {float(data['sigma_m'][k])!r} at t_s = {data['t_s'][k]:g}")
    else:
        data["sigma_m"] = np.full(data["t_s"].size, FIX_SIGMA_M)
    if "lat_deg" in data:
        check_lat_lon(data["lat_deg"], data["lon_deg"], f"{what} {path}", reference=origin)
        if origin is not None and "x_m" not in data:
            data["x_m"], data["y_m"] = (np.asarray(v, dtype=float).reshape(-1) for v in
                                        geodetic_to_local(data["lat_deg"], data["lon_deg"], *origin))
    return data


def read_depth(path, *, what: str = "depth file") -> dict[str, np.ndarray]:
    """A depth sensor log: ``t_s`` [s], ``depth_m`` [m, positive down], cleaned like :func:`read_imu`.

    Used with :func:`depth_at` to turn slant ranges horizontal
    (:func:`~seamodem.navigation.geometry.slant_to_horizontal`).
    """
    header, rows, _ = _read_table(path, what)
    _check_columns(header, ("t_s", "depth_m"), path, what)
    data = {c: _float_column(rows, header.index(c), c, path, what) for c in ("t_s", "depth_m")}
    data = _drop_missing(data, ("t_s", "depth_m"), path, what)
    data = _sort_and_dedupe(data, "t_s", path, what)
    _warn_gaps(data["t_s"], "t_s", path, what)
    return data


def depth_at(depth_log: dict, t_s) -> np.ndarray:
    """Depth [m] at times ``t_s`` [s], linear between samples, the end samples held outside the log.

    Parameters
    ----------
    depth_log : dict
        ``t_s`` (increasing) and ``depth_m``, as :func:`read_depth` or :func:`read_imu` return them.
    t_s : float or array_like
        Times [s].
    """
    if "depth_m" not in depth_log:
        raise ConfigError("depth_log", "has no depth_m column")
    return np.interp(np.asarray(t_s, dtype=float), depth_log["t_s"], depth_log["depth_m"])


def parse_pair(text, parameter: str) -> tuple[float, float]:
    """Two finite numbers from ``"a,b"`` text; one-line :class:`ConfigError` naming ``parameter`` otherwise."""
    if text is None:
        raise ConfigError(parameter, "is required (two numbers, e.g. 50,100)")
    try:
        a, b = (float(v) for v in str(text).split(","))
    except ValueError:
        raise ConfigError(parameter, f"must be two numbers separated by a comma, got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ConfigError(parameter, f"must be finite, got {text!r}")
    return a, b


def parse_position(text, *, geodetic: bool, origin=None, parameter: str = "position") -> tuple[float, float]:
    """A position given on the command line, as local (x, y) [m].

    Parameters
    ----------
    text : str
        ``"x,y"`` [m], or ``"lat,lon"`` [deg] when ``geodetic``.
    geodetic : bool
        Whether ``text`` is latitude, longitude.
    origin : (float, float), optional
        (lat, lon) [deg] of the local frame's origin; required when ``geodetic``.
        The position is checked against it (:func:`~seamodem.navigation.geometry.check_lat_lon`:
        a warning when it looks given as lon,lat).
    parameter : str
        Name of the option in messages (``"start"``).

    Raises
    ------
    ConfigError
        Not two finite numbers; a latitude or longitude out of range; ``geodetic``
        without ``origin``.
    """
    a, b = parse_pair(text, parameter)
    if not geodetic:
        return a, b
    if origin is None:
        raise ConfigError(parameter, "a geodetic position needs the origin (lat, lon) of the local frame")
    lat, lon = check_lat_lon(a, b, parameter, reference=origin, reference_what="the origin")
    east, north = geodetic_to_local(lat, lon, *origin)
    return float(east), float(north)
