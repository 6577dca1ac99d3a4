"""Following a mission as it happens: measurement records read as they are appended, a position per record.

:class:`RecordFollower` reads the receiver's records as they arrive — from a
file that grows (``seamodem rx ... -o MEAS.csv``: read like ``tail -f`` until
its sidecar says the run is complete), from a FIFO or from stdin (``seamodem rx
- -o - | seamodem nav track - --follow``: until the pipe closes) — in CSV or
JSON Lines, with the sidecar first on a stream (a JSON line, or ``# seamodem:``
and the JSON object before a CSV header).

:class:`FollowTracker` turns each new record into a position: it steps the
inertial filter of :func:`~seamodem.navigation.track.run_track` over the IMU
samples since the last record and the new record (the IMU log read as it grows),
keeping its state and only the last nodes, so a record costs the same after
hours as after minutes (``benchmarks/bench_live.py``); optionally the fixed-lag
smoother runs behind it.
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


class _ImuLog:
    """IMU samples of a log that may still grow: read whole once (:func:`~.logs.read_imu`), then only the lines
    appended; the samples not yet taken by the filter are kept, those taken dropped (bounded memory).

    Appended lines are parsed as the file's first read found its columns (CSV header, or JSON Lines keys). What
    ``read_imu`` repairs in a whole file cannot be repaired in a line: a sample not after the last one is
    dropped, a row with a required value missing is skipped, a missing ``heading_std_rad`` takes the previous
    one (each counted in a warning).
    """

    def __init__(self, source, note):
        self.note = note  # one line of what was repaired or left out
        self.static = isinstance(source, dict)
        self.path = None if self.static else Path(source)
        self.samples: dict | None = ({k: np.asarray(v, dtype=float) for k, v in source.items()} if self.static
                                     else None)
        self._offset = 0
        self._rest = b""
        self._columns: list[str] | None = None
        self._jsonl = False
        self._skipped = 0

    def _first(self) -> None:
        from .logs import read_imu

        size = self.path.stat().st_size
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.samples = read_imu(self.path)
        for w in caught:
            self.note(str(w.message).splitlines()[0])
        text = self.path.read_bytes()[:size]
        self._offset = text.rfind(b"\n") + 1
        self._rest = text[self._offset:]
        self._offset = size
        self._jsonl = self.path.suffix.lower() == ".jsonl" or text.lstrip().startswith(b"{")
        if not self._jsonl:
            import csv

            lines = [ln for ln in text.decode("utf-8-sig", "replace").splitlines()
                     if ln.strip() and not ln.lstrip().startswith("#")]
            self._columns = [h.strip() for h in next(csv.reader(lines[:1]))]

    def _parse(self, line: str) -> dict | None:
        import csv

        if self._jsonl:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                return None
            if not isinstance(row, dict):
                return None
        else:
            if line.lstrip().startswith("#"):
                return None
            row = dict(zip(self._columns, next(csv.reader([line]))))
        if "heading_rad" not in row and "heading_deg" in row:
            row["heading_rad"] = math.radians(_number(row["heading_deg"]))
        return {k: _number(row.get(k)) for k in self.samples}

    def read(self) -> dict:
        """The samples not yet taken, with those appended since the last read."""
        if self.static:
            return self.samples
        if self.samples is None:
            self._first()
            return self.samples
        if self.path.stat().st_size <= self._offset:
            return self.samples
        with open(self.path, "rb") as f:
            f.seek(self._offset)
            data = f.read()
        self._offset += len(data)
        *lines, self._rest = (self._rest + data).split(b"\n")
        rows = [r for r in (self._parse(ln.decode("utf-8", "replace").rstrip("\r")) for ln in lines if ln.strip())
                if r is not None]
        if not rows:
            return self.samples
        new = {k: np.array([r[k] for r in rows]) for k in self.samples}
        last = self.samples["t_s"][-1] if self.samples["t_s"].size else -math.inf
        keep = np.isfinite(new["t_s"]) & np.isfinite(new["omega_rad_s"]) & np.isfinite(new["accel_mps2"])
        keep &= np.isfinite(new["heading_rad"])
        t = np.where(keep, new["t_s"], -math.inf)
        keep &= t > np.maximum.accumulate(np.r_[last, t])[:-1]
        if "heading_std_rad" in new:
            h = new["heading_std_rad"]
            for k in np.flatnonzero(~np.isfinite(h)):
                h[k] = h[k - 1] if k else (self.samples["heading_std_rad"][-1] if self.samples["t_s"].size else np.nan)
        if (~keep).any():
            self._skipped += int((~keep).sum())
            self.note(f"IMU file {self.path}: {self._skipped} appended row(s) not used (a value missing, or not "
                           f"after the sample before)")
        self.samples = {k: np.r_[v, new[k][keep]] for k, v in self.samples.items()}
        return self.samples

    def take(self, n: int) -> None:
        """Drop the first ``n`` samples (the filter has them)."""
        self.samples = {k: v[n:] for k, v in self.samples.items()}


class _NodeBuffer:
    """The filter's arrays over the last nodes: inputs (:class:`~.inertial.records.NodeData`), states, history and
    per-node output, appended as nodes come and compacted (the oldest dropped) when full."""

    def __init__(self, n: int, capacity: int = 4096):
        self.n, self.size, self.base = n, 0, 0
        self.fields = {  # name: (shape after the node axis, dtype, fill)
            "t": ((), float, np.nan), "dt": ((), float, 0.0), "omega": ((), float, 0.0), "accel": ((), float, 0.0),
            "has_heading": ((), bool, False), "heading": ((), float, 0.0), "heading_var": ((), float, 1.0),
            "has_frame": ((), bool, False), "meas": ((2,), float, 0.0), "meas_var": ((2,), float, 1.0),
            "has_fix": ((), bool, False), "fix": ((2,), float, 0.0), "fix_var": ((), float, 1.0),
            "has_bearing": ((), bool, False), "bearing": ((), float, 0.0), "bearing_var": ((), float, 1.0),
            "states": ((n,), float, 0.0), "history": ((n, 3 * n + 1), float, 0.0), "charts": ((), np.int8, 0),
            "nis": ((), float, np.nan), "status": ((), np.int8, 0), "bearing_nis": ((), float, np.nan),
            "bearing_status": ((), np.int8, 0), "used_frame": ((), bool, False), "used_bearing": ((), bool, False),
            "online": ((2,), float, 0.0), "windows": ((), np.int64, 0)}
        self.a = {k: np.full((capacity, *shape), fill, dtype=dtype) for k, (shape, dtype, fill) in self.fields.items()}

    def append(self, m: int, keep_from: int) -> int:
        """Room for ``m`` new nodes, dropping the nodes before buffer index ``keep_from`` if it must; the index
        of the first new node."""
        cap = next(iter(self.a.values())).shape[0]
        if self.size + m > cap:
            kept = self.size - keep_from
            new_cap = max(cap, 2 * (kept + m))
            for k, (shape, dtype, fill) in self.fields.items():
                old = self.a[k]
                arr = np.full((new_cap, *shape), fill, dtype=dtype) if new_cap != cap else old
                arr[:kept] = old[keep_from:self.size].copy()
                arr[kept:] = fill
                self.a[k] = arr
            self.size, self.base = kept, self.base + keep_from
        start = self.size
        self.size += m
        return start

    def kernel_views(self):
        """(NodeData, Track, FilterOutput) over the nodes so far, as the kernels take them."""
        from .inertial.filter import FilterOutput
        from .inertial.records import NodeData, Track

        a, e = self.a, self.size
        nodes = NodeData(*(a[k][:e] for k in ("dt", "omega", "accel", "has_heading", "heading", "heading_var",
                                               "has_frame", "meas", "meas_var", "has_fix", "fix", "fix_var",
                                               "has_bearing", "bearing", "bearing_var")))
        track = Track(a["states"][:e], a["history"][:e], a["charts"][:e])
        out = FilterOutput(*(a[k][:e] for k in ("nis", "status", "bearing_nis", "bearing_status", "used_frame",
                                                 "used_bearing", "online", "windows")))
        return nodes, track, out


class FollowTracker:
    """Positions as records arrive: the inertial filter stepped over each new record and the IMU up to it, and
    optionally the fixed-lag smoother behind it.

    The filter keeps its state between records and runs only the new nodes (the IMU samples since the last
    record, and the record's arrival): the same operations in the same order as
    :func:`~seamodem.navigation.track.run_track` over the whole mission, so each position is the offline
    filter's real-time state at that record (its ``online_xy``; also its state, unless a later window
    re-linearization rewrote the node). It keeps the last nodes only — the filter's re-linearization window
    (``InertialConfig.window_s``) and what the smoother still needs — so the cost per record does not grow with
    the mission.

    With ``lag_s``, each record's node is also smoothed once the filter has reached ``lag_s`` seconds past it
    (:func:`~.inertial.smoothers.lag_back`, the recursion of
    :func:`~.inertial.smoothers.fixed_lag_smooth`): a smoothed row comes with the first record at or after
    that time. It equals the offline fixed-lag smoother's at the node, unless a window re-linearization after
    ``t + lag_s`` rewrote a node between ``t`` and ``t + lag_s`` (the offline smoother then uses the rewritten
    nodes, which no real-time output ``lag_s`` late can).

    Parameters
    ----------
    imu : str, Path or dict
        The IMU/AHRS log (:func:`~seamodem.navigation.logs.read_imu`), read as it grows; or its samples.
    track_options : dict
        Keyword arguments of :func:`~seamodem.navigation.track.run_track`: ``beacon_xy``, ``start_xy`` and
        optionally ``start_speed_mps``, ``filter`` (an inertial one), ``depths``, ``beacon_depth_m``,
        ``sound_speed_profile``, ``config``, the σ's and floors, ``start_sigma_m``, ``use_bearing``,
        ``bearing_floor_rad``.
    lag_s : float, optional
        Lag of the fixed-lag smoother [s]; none: filter positions only.

    Attributes
    ----------
    warnings : list of str
        What was repaired or left out, each once.
    """

    OPTIONS = {"beacon_xy": None, "start_xy": None, "start_speed_mps": 0.0, "filter": "inertial", "depths": None,
               "beacon_depth_m": 0.0, "sound_speed_profile": None, "config": None, "range_floor_m": None,
               "v_r_floor_mps": None, "sigma_range_m": None, "sigma_v_r_mps": None, "start_sigma_m": 1.0,
               "use_bearing": True, "bearing_floor_rad": None}

    def __init__(self, imu, track_options: dict, *, lag_s: float | None = None):
        from ..errors import ConfigError
        from .inertial.driver import filter_model, filter_settings
        from .track import BEARING_FLOOR_RAD, RANGE_FLOOR_M, V_R_FLOOR_MPS, check_positive, inertial_config

        other = sorted(k for k, v in track_options.items() if k not in self.OPTIONS and v not in (None, False))
        if other:
            raise ConfigError(other[0], "not with a follower (the filter in real time; run nav track afterwards)")
        o = {**self.OPTIONS, "range_floor_m": RANGE_FLOOR_M, "v_r_floor_mps": V_R_FLOOR_MPS,
             "bearing_floor_rad": BEARING_FLOOR_RAD}
        o.update({k: v for k, v in track_options.items() if k in self.OPTIONS and v is not None})
        if o["filter"] not in ("inertial", "inertial-range"):
            raise ConfigError("filter", f"a follower runs the inertial filters, not {o['filter']!r}")
        if lag_s is not None:
            check_positive("lag_s", lag_s)
        self.options, self.lag_s = o, None if lag_s is None else float(lag_s)
        self.cfg = inertial_config(o["config"], start_sigma_m=o["start_sigma_m"], range_floor_m=o["range_floor_m"],
                                   v_r_floor_mps=o["v_r_floor_mps"])
        self.beacon = np.asarray(o["beacon_xy"], dtype=float)
        use_vr = o["filter"] == "inertial"
        self.model = filter_model(self.cfg, self.beacon, use_range=True, use_vr=use_vr)
        self.settings = filter_settings(self.cfg, use_range=True, use_vr=use_vr)
        self.warnings: list[str] = []
        self._imu = _ImuLog(imu, self._note)
        self._buf = _NodeBuffer(self.cfg.n_states)
        self._z = self._P = None
        self._lay = self.cfg.layout.copy()
        self._runs = np.zeros(2, dtype=np.int64)
        self._waiting: list[dict] = []  # records the IMU does not reach yet
        self._to_smooth: list[tuple[int, dict]] = []  # (node's global index, its filter row)
        self._left_out = {"before the IMU log's first sample": 0, "not after the record before": 0}

    def add(self, row: dict) -> list[dict]:
        """Fuse one more record; the positions this makes known.

        Parameters
        ----------
        row : dict
            A record's columns (:class:`RecordFollower`).

        Returns
        -------
        list of dict
            The filter's position at this record (none for a record without a range, or while the IMU log
            has not reached its arrival: it comes with a later call), then the smoothed positions whose lag
            has passed. Each: ``estimate`` ("filter" or "smoothed"), ``lag_s`` (0 for the filter), ``t_s``
            (the time the position is at: the record's arrival), ``x_m``, ``y_m``, ``heading_rad``,
            ``speed_mps``, ``var_x_m2``, ``cov_xy_m2``, ``var_y_m2``, ``frame_index``, ``t_arrival_s``,
            ``status`` (the record's, as ``nav track``'s frame table) and ``nis``.
        """
        if not (math.isfinite(row.get("range_m", math.nan)) and math.isfinite(row.get("t_arrival_s", math.nan))):
            return []
        self._waiting.append(row)
        return self._advance()

    def finish(self) -> list[dict]:
        """At the end of the input: the records still waiting for the IMU, the rest of the IMU log and the
        smoothed positions not yet given (their lag shortened to what exists, as the offline smoother's at
        the end of a mission)."""
        out = self._advance()
        if self._waiting:
            last = self._imu.samples["t_s"][-1] if self._imu.samples["t_s"].size else math.nan
            self._note(f"measurements: {len(self._waiting)} record(s) arrive after the IMU log's last sample "
                            f"(t = {last:g} s) and are not used")
            self._waiting = []
        if self.lag_s is not None and self._z is not None and self._imu.samples["t_s"].size:
            self._commit(float(self._imu.samples["t_s"][-1]), None)
        if self.lag_s is not None:
            out += self._smoothed(final=True)
        for why, count in self._left_out.items():
            if count:
                self._note(f"measurements: {count} record(s) arrive {why} and are not used")
        return out

    def _note(self, line: str) -> None:
        if line not in self.warnings:
            self.warnings.append(line)

    def _advance(self) -> list[dict]:
        imu = self._imu.read()
        out = []
        while self._waiting:
            row = self._waiting[0]
            t_a = float(row["t_arrival_s"])
            t_imu = imu["t_s"]
            if self._z is None and t_imu.size and t_a < t_imu[0]:
                self._left_out["before the IMU log's first sample"] += 1
            elif self._z is not None and t_a <= self._buf.a["t"][self._buf.size - 1]:
                self._left_out["not after the record before"] += 1
            elif t_imu.size and t_imu[-1] >= t_a:
                out.append(self._commit(t_a, row))
                if self.lag_s is not None:
                    out += self._smoothed(final=False)
            else:
                break  # the IMU has not reached it yet
            self._waiting.pop(0)
            imu = self._imu.samples
        return out

    def _start(self) -> None:
        from .inertial.charts import to_internal

        imu = self._imu.samples
        heading0 = float(imu["heading_rad"][0])
        if not math.isfinite(heading0):
            raise InputFileError("IMU samples: the first heading (the start heading) is not a number")
        o = self.options
        z, P = self.cfg.initial(float(o["start_xy"][0]), float(o["start_xy"][1]), heading0,
                                float(o["start_speed_mps"]))
        to_internal(z, P, self._lay, self.beacon)
        self._z, self._P = z, P

    def _frame(self, row: dict) -> tuple:
        """(range, v_r, their variances, bearing, its variance) of a record, as run_track makes them."""
        from .track import (DEFAULT_SIGMA_RANGE_M, DEFAULT_SIGMA_V_R_MPS, horizontal_ranges,
                            normalise_sigma_columns, record_sigma, bearing_sigma)

        o = self.options
        meas = normalise_sigma_columns({k: np.array([v], dtype=float) for k, v in row.items()})
        r = horizontal_ranges(meas, o["depths"], None, o["beacon_depth_m"], o["sound_speed_profile"])
        sr, _ = record_sigma(meas, "sigma_range_m", o["sigma_range_m"], DEFAULT_SIGMA_RANGE_M, o["range_floor_m"],
                              "sigma_range_m")
        sv, _ = record_sigma(meas, "sigma_v_r_mps", o["sigma_v_r_mps"], DEFAULT_SIGMA_V_R_MPS, o["v_r_floor_mps"],
                              "sigma_v_r_mps")
        az, var = math.nan, math.nan
        if o["use_bearing"] and "azimuth_body_rad" in meas:
            a, sb = bearing_sigma(meas, o["bearing_floor_rad"])
            az, var = float(a[0]), float(sb[0]) ** 2
        bearing = math.isfinite(az) and math.isfinite(var) and var > 0
        return (float(r[0]), float(meas["v_r_mps"][0]) if "v_r_mps" in meas else math.nan, float(sr[0]) ** 2,
                float(sv[0]) ** 2, bearing, az if bearing else 0.0, var if bearing else 1.0)

    def _keep_from(self) -> int:
        """Buffer index of the oldest node still needed: the re-linearization window behind the last node, the
        oldest node waiting for its smoothed position, and the last node."""
        b = self._buf
        t = b.a["t"][:b.size]
        keep = b.size - 1
        if self.settings.window_s > 0:
            keep = min(keep, max(int(np.searchsorted(t, t[-1] - self.settings.window_s - 1.0)) - 1, 0))
        if self._to_smooth:
            keep = min(keep, self._to_smooth[0][0] - b.base)
        return keep

    def _commit(self, t_until: float, row: dict | None) -> dict | None:
        """Nodes for the IMU samples up to ``t_until`` and the record ``row`` at ``t_until``, through the filter;
        the filter's position at the record."""
        from .inertial.filter import filter_span

        started = self._z is not None
        if not started:
            self._start()
        imu, b = self._imu.samples, self._buf
        m_imu = int(np.searchsorted(imu["t_s"], t_until, side="right"))
        times = imu["t_s"][:m_imu]
        rate = np.arange(m_imu)
        shared = row is not None and m_imu > 0 and times[-1] == t_until
        if row is not None and not shared:
            times, rate = np.r_[times, t_until], np.r_[rate, m_imu]  # the record: rates of the next IMU sample
        m = times.size
        if m == 0:
            return None
        cfg = self.cfg
        t_prev = b.a["t"][b.size - 1] if started else times[0]
        s = b.append(m, self._keep_from() if started else 0)
        a, sl = b.a, slice(s, s + m)
        a["t"][sl] = times
        a["dt"][sl] = np.diff(np.r_[t_prev, times])
        a["omega"][sl] = imu["omega_rad_s"][rate]
        a["accel"][sl] = imu["accel_mps2"][rate]
        on_imu = rate < m_imu
        on_imu[-1] = on_imu[-1] and (row is None or shared)
        head = np.where(on_imu, imu["heading_rad"][np.minimum(rate, max(m_imu - 1, 0))], np.nan)
        hvar = (imu["heading_std_rad"][np.minimum(rate, max(m_imu - 1, 0))] ** 2 if "heading_std_rad" in imu
                else np.full(m, cfg.heading_sigma_rad**2))
        hvar = np.where(on_imu, hvar, np.nan)
        has = np.isfinite(head) & np.isfinite(hvar)
        if not started:
            has[0] = False  # node 0: the start state holds its heading reading (run_filter's start_from_first_heading)
        a["has_heading"][sl] = has
        a["heading"][sl] = np.nan_to_num(head)
        a["heading_var"][sl] = np.nan_to_num(hvar, nan=1.0)
        k = s + m - 1
        if row is not None:
            r, vr, rvar, vvar, bearing, az, bvar = self._frame(row)
            a["has_frame"][k], a["meas"][k], a["meas_var"][k] = True, (r, vr), (rvar, vvar)
            a["has_bearing"][k], a["bearing"][k], a["bearing_var"][k] = bearing, az, bvar
        filter_span(s, s + m, self._z, self._P, self._lay, self.model, self.settings, *b.kernel_views(), self._runs)
        self._imu.take(m_imu)
        if row is None:
            return None
        pos = self._position(a["states"][k], a["history"][k, :, b.n + 1:2 * b.n + 1], a["charts"][k])
        from .track import FRAME_STATUS

        pos.update(estimate="filter", lag_s=0.0, t_s=float(t_until), frame_index=int(row["frame_index"]),
                   t_arrival_s=float(t_until), status=FRAME_STATUS[int(a["status"][k])], nis=float(a["nis"][k]))
        if self.lag_s is not None:
            self._to_smooth.append((b.base + k, pos))
        return self._ordered(pos)

    def _position(self, z, P, chart) -> dict:
        from .inertial.charts import to_cartesian

        xs, Ps = to_cartesian(z[None, :], P[None, :, :], np.array([chart], dtype=np.int8), self.beacon)
        x, c = xs[0], Ps[0]
        return {"x_m": float(x[0]), "y_m": float(x[1]), "heading_rad": float(x[2]), "speed_mps": float(x[3]),
                "var_x_m2": float(c[0, 0]), "cov_xy_m2": float(c[0, 1]), "var_y_m2": float(c[1, 1])}

    @staticmethod
    def _ordered(pos: dict) -> dict:
        keys = ("estimate", "lag_s", "t_s", "x_m", "y_m", "heading_rad", "speed_mps", "var_x_m2", "cov_xy_m2",
                "var_y_m2", "frame_index", "t_arrival_s", "status", "nis")
        return {k: pos[k] for k in keys}

    def _smoothed(self, final: bool) -> list[dict]:
        """Smoothed positions of the records whose lag has passed (all of them when ``final``)."""
        from .inertial.kernels import rts_gains
        from .inertial.smoothers import lag_back

        b = self._buf
        a, n, e = b.a, b.n, b.size
        t = a["t"][:e]
        out = []
        while self._to_smooth:
            g, filt = self._to_smooth[0]
            k = g - b.base
            if not final and t[-1] < t[k] + self.lag_s:
                break
            j = int(np.searchsorted(t, t[k] + self.lag_s, side="right")) - 1
            h = a["history"][k:j + 1]
            post, P_post = a["states"][k:j + 1], np.ascontiguousarray(h[:, :, n + 1:2 * n + 1])
            prior, P_prior = np.ascontiguousarray(h[:, :, 0]), np.ascontiguousarray(h[:, :, 1:n + 1])
            C = rts_gains(post, P_post, prior, P_prior, np.ascontiguousarray(h[:, :, 2 * n + 1:3 * n + 1]))
            xs, Ps = lag_back(post, P_post, prior, P_prior, C, 0, j - k)
            pos = {**filt, **self._position(xs, Ps, a["charts"][k]), "estimate": "smoothed",
                   "lag_s": min(self.lag_s, float(t[j] - t[k])) if final and j == e - 1 else self.lag_s}
            out.append(self._ordered(pos))
            self._to_smooth.pop(0)
        return out
