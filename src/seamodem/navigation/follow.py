"""Following a mission as it happens: measurement records read as they are appended, a position per record.

:class:`RecordFollower` reads the receiver's records as they arrive — from a
file that grows (``seamodem rx ... -o MEAS.csv``: read like ``tail -f`` until
its sidecar says the run is complete), from a FIFO or from stdin (``seamodem rx
- -o - | seamodem nav track - --follow``: until the pipe closes) — in CSV or
JSON Lines, with the sidecar first on a stream (a JSON line, or ``# seamodem:``
and the JSON object before a CSV header).

:class:`FollowTracker` turns each new record into a position: it runs the
filter of :func:`~seamodem.navigation.track.run_track` over the records so far
and the IMU samples up to the record's arrival (re-read when the IMU log grows),
and returns the state at the record. The filter is causal, so this state is the
one a filter run step by step would give; running it again from the start costs
O(records so far), small for hours of 3-s frames (measured in
``benchmarks/bench_live.py``).
"""

from __future__ import annotations

import json
import math
import os
import select
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import InputFileError
from ..receive.records import STREAM_HEADER_PREFIX

__all__ = ["RecordFollower", "FollowTracker"]

_NUMERIC = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db", "sigma_range_m",
            "sigma_v_r_mps", "azimuth_body_rad", "sigma_azimuth_body_rad")


def _number(value) -> float:
    if value is None or value == "":
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


class RecordFollower:
    """Measurement records as they are appended to a file, a FIFO or stdin.

    Parameters
    ----------
    source : str
        ``-`` (stdin), a FIFO, or a measurement file (.csv / .jsonl) that may still grow.
    stop : threading.Event, optional
        Ends the following when set (Ctrl-C).
    poll_s : float
        How often a file that has not grown is looked at again [s].
    idle_timeout_s : float, optional
        End when nothing arrives for this long [s] (default: wait for the
        pipe to close, or the file's sidecar to say the run is complete).

    Attributes
    ----------
    metadata : dict
        The sidecar (from the stream's first line, or beside the file), once read.
    end_reason : str or None
        "end of stream", "complete" (the file's sidecar), "stalled", "interrupted".
    """

    def __init__(self, source: str, *, stop: threading.Event | None = None, poll_s: float = 0.02,
                 idle_timeout_s: float | None = None):
        self.source, self.stop, self.poll_s, self.idle_timeout_s = source, stop, poll_s, idle_timeout_s
        self.metadata: dict = {}
        self.end_reason: str | None = None
        self._columns: list[str] | None = None
        self._kind: str | None = None
        path = None if source == "-" else Path(source)
        if path is not None and not path.exists():
            raise InputFileError(f"measurement file not found: {source}")
        self._file = path is not None and path.is_file()
        if self._file:
            suffix = path.suffix.lower()
            if suffix not in (".csv", ".jsonl", ".ndjson"):
                raise InputFileError(f"measurements: must end in .csv or .jsonl, got {source!r}")
            self._kind = "csv" if suffix == ".csv" else "jsonl"
            self._sidecar = path.with_name(path.name + ".json")
        self._fd = os.dup(0) if path is None else os.open(path, os.O_RDONLY)

    def close(self) -> None:
        """Close the input."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def _complete(self) -> bool:
        try:
            side = json.loads(self._sidecar.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return False
        self.metadata = side
        return bool(side.get("complete"))

    def _chunks(self):
        """Bytes as they arrive, until the end (``end_reason`` says which)."""
        last = time.monotonic()
        while True:
            if self.stop is not None and self.stop.is_set():
                self.end_reason = "interrupted"
                return
            if self._file:
                data = os.read(self._fd, 1 << 16)
                if not data:
                    complete = self._complete()  # read before looking again: no row written before it is missed
                    data = os.read(self._fd, 1 << 16)
                    if not data and complete:
                        self.end_reason = "complete"
                        return
                if not data:
                    time.sleep(self.poll_s)
            else:
                ready, _, _ = select.select([self._fd], [], [], 0.1)
                data = os.read(self._fd, 1 << 16) if ready else b""
                if ready and not data:
                    self.end_reason = "end of stream"
                    return
            if data:
                last = time.monotonic()
                yield data
            elif self.idle_timeout_s is not None and time.monotonic() - last > self.idle_timeout_s:
                self.end_reason = "stalled"
                return

    def _lines(self):
        rest = b""
        for data in self._chunks():
            rest += data
            *lines, rest = rest.split(b"\n")
            for line in lines:
                text = line.decode("utf-8").rstrip("\r")
                if text.strip():
                    yield text

    def __iter__(self):
        """Each record as a dict of its columns (numbers as float, NaN when empty), as it arrives."""
        import csv

        for text in self._lines():
            if self._kind is None:  # a stream: its first line says what follows
                if text.startswith(STREAM_HEADER_PREFIX):
                    self.metadata, self._kind = json.loads(text[len(STREAM_HEADER_PREFIX):]), "csv"
                    continue
                if text.startswith("{"):
                    self._kind = "jsonl"
                else:
                    self._kind = "csv"
            if self._kind == "jsonl":
                try:
                    row = json.loads(text)
                except json.JSONDecodeError as exc:
                    raise InputFileError(f"{self.source}: a line is not JSON ({exc.msg}): {text[:60]!r}") from None
                if "format" in row and "frame_index" not in row:
                    self.metadata = row
                    continue
            else:
                values = next(csv.reader([text]))
                if self._columns is None:
                    self._columns = values
                    if "t_arrival_s" not in values:
                        raise InputFileError(f"{self.source}: CSV header lacks t_arrival_s (not measurement records)")
                    continue
                row = dict(zip(self._columns, values))
            yield {k: _number(row.get(k)) for k in _NUMERIC if k in row or k in _NUMERIC[:7]}


class FollowTracker:
    """A position for each new record: the causal filter over the records so far and the IMU up to it.

    Parameters
    ----------
    imu : str or Path
        The IMU/AHRS log (:func:`~seamodem.navigation.logs.read_imu`), re-read when it grows.
    track_options : dict
        Keyword arguments of :func:`~seamodem.navigation.track.run_track` (``beacon_xy``, ``start_xy``,
        ``filter``...; no smoother: positions are the filter's, in real time).

    Attributes
    ----------
    warnings : list of str
        Warnings of the filter runs, each once.
    """

    def __init__(self, imu, track_options: dict):
        self.imu_path = Path(imu)
        self.options = dict(track_options)
        self.rows: list[dict] = []
        self._imu: dict | None = None
        self._imu_stamp = None
        self.warnings: list[str] = []

    def _imu_samples(self) -> dict:
        from .logs import read_imu

        st = self.imu_path.stat()
        stamp = (st.st_size, st.st_mtime_ns)
        if stamp != self._imu_stamp:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self._imu = read_imu(self.imu_path)
            self._note(caught)
            self._imu_stamp = stamp
        return self._imu

    def _note(self, caught) -> None:
        for w in caught:
            line = str(w.message).splitlines()[0]
            if line not in self.warnings:
                self.warnings.append(line)

    def add(self, row: dict) -> dict | None:
        """Fuse one more record; the position at it, or None for a record without a range.

        Parameters
        ----------
        row : dict
            A record's columns (:class:`RecordFollower`).

        Returns
        -------
        dict or None
            ``t_s`` (the state's time), ``x_m``, ``y_m``, ``heading_rad``, ``speed_mps``, ``var_x_m2``,
            ``cov_xy_m2``, ``var_y_m2``, ``frame_index``, ``t_arrival_s``, ``status`` (the record's, as
            ``nav track``'s frame table) and ``nis``.
        """
        from .track import run_track

        if not (math.isfinite(row.get("range_m", math.nan)) and math.isfinite(row.get("t_arrival_s", math.nan))):
            return None
        self.rows.append(row)
        self.rows.sort(key=lambda r: r["t_arrival_s"])
        t_a = row["t_arrival_s"]
        imu = self._imu_samples()
        # the IMU up to the record, and its first sample after it (the record lies inside the IMU's span)
        n = min(int(np.searchsorted(imu["t_s"], t_a, side="left")) + 1, imu["t_s"].size)
        imu_now = {k: v[:n] for k, v in imu.items()}
        meas = {k: np.array([r.get(k, math.nan) for r in self.rows], dtype=float)
                for k in self.rows[0] if all(k in r for r in self.rows)}
        keep = meas["t_arrival_s"] <= imu_now["t_s"][-1]
        meas = {k: v[keep] for k, v in meas.items()}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out = run_track(meas, imu_now, **self.options)
        self._note(caught)
        state, cov, frames = out["state"][-1], out["cov"][-1], out["frames"]
        mine = np.flatnonzero(frames["t_arrival_s"] == t_a)
        status = str(frames["status"][mine[-1]]) if mine.size else "outside_imu"
        return {"t_s": float(out["t_s"][-1]), "x_m": float(state[0]), "y_m": float(state[1]),
                "heading_rad": float(state[2]), "speed_mps": float(state[3]), "var_x_m2": float(cov[0, 0]),
                "cov_xy_m2": float(cov[0, 1]), "var_y_m2": float(cov[1, 1]), "frame_index": int(row["frame_index"]),
                "t_arrival_s": float(t_a), "status": status,
                "nis": float(frames["nis"][mine[-1]]) if mine.size else math.nan}
