"""Decode many recordings, or one long recording in overlapping segments, in parallel.

Each recording is cut into parts: the whole file, or segments
[start, end) of ``segment_s`` seconds. A part runs the streaming
:class:`~seamodem.receive.receiver.Receiver` on the samples
[start − overlap, end + overlap) and keeps the frames that arrive in
[start − guard, end + guard); where two neighbouring segments found the same
frame in that band around their boundary, the merge keeps one (the one of the
segment its arrival lies in). The overlap exceeds a frame's span plus the guard,
so a frame cut by a boundary is whole in at least one part: found once, never
lost nor doubled.

Parts go through :func:`~seamodem.batch.runner.run_tasks` (serial, local
processes or Dask). Each finished part is saved in ``OUTPUT.parts/`` as soon
as it arrives, so that a failure or an interruption loses nothing decoded, and a
rerun with ``resume=True`` skips the parts already there. The merged output is
written at the end: recordings in the order given, records by arrival time
within each, with the recording in the ``source`` column.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import shutil
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..config import FrameConfig
from ..errors import ConfigError, SeamodemError
from ..io.blocks import read_blocks
from ..io.files import check_writable
from ..io.source import BlockStats, open_recording
from ..receive.detect import DETECTION_CONTEXT_S
from ..receive.measure import NOISE_GAP_S, NOISE_WINDOW_S, frame_span_s
from ..receive.records import MeasurementRecord, write_measurements
from ..receive.recording import recording_warnings
from ..receive.settings import Emissions, ReceiverSettings
from ..receive.stream import Receiver, ReceiverWarning
from .runner import TaskResult, run_tasks

__all__ = [
    "Recording",
    "Part",
    "PartFailure",
    "BatchResult",
    "plan_parts",
    "decode_part",
    "decode_files",
    "min_overlap_s",
    "default_overlap_s",
    "guard_for",
    "overlap_for",
    "PART_FORMAT",
]

PART_FORMAT = "seamodem.batch-part/1"

#: half-width of the band around a segment boundary where neighbours' frames are reconciled, in frames
GUARD_FRAMES = 0.25


@dataclass(frozen=True)
class Recording:
    """One recording to decode and what its receiver needs.

    Parameters
    ----------
    path : str or Path
        Audio file; written as given in the ``source`` column.
    config : FrameConfig
    emissions : Emissions
    channel : int, optional
        Channel of a multichannel file.
    settings : ReceiverSettings
        How the recording is received (default: ``ReceiverSettings()``).
    pilot : numpy.ndarray, optional
        Pilot symbols (default: from the config's seed).
    payloads : sequence of bytes, optional
        The payload sent in each frame, to count bit errors when decoding.
    """

    path: str | Path
    config: FrameConfig
    emissions: Emissions
    channel: int | None = None
    settings: ReceiverSettings = field(default_factory=ReceiverSettings)
    pilot: np.ndarray | None = None
    payloads: Sequence[bytes] | None = None


def _frame_span_s(rec: Recording) -> float:
    s = rec.settings
    return frame_span_s(rec.config, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)


def guard_for(frame_duration_s: float) -> float:
    """Half-width of the band around a segment boundary where a frame found twice is kept once [s].

    Parameters
    ----------
    frame_duration_s : float
        The shortest frame (or ping) the receiver finds [s].

    Returns
    -------
    float
        ``GUARD_FRAMES`` frame durations: closer than any two frames.
    """
    return GUARD_FRAMES * frame_duration_s


def overlap_for(span_s: float, frame_duration_s: float) -> float:
    """Segment overlap giving a frame near a boundary the same context as in the whole recording [s].

    Parameters
    ----------
    span_s : float
        The longest a received frame lasts, with its tails and noise window [s].
    frame_duration_s : float
        The shortest frame [s] (sets the guard, :func:`guard_for`).

    Returns
    -------
    float
        The span, the guard, the detector's context and the noise windows [s].
    """
    return span_s + guard_for(frame_duration_s) + DETECTION_CONTEXT_S + NOISE_GAP_S + NOISE_WINDOW_S


def _guard_s(rec: Recording) -> float:
    return guard_for(rec.config.frame_duration_s)


def min_overlap_s(rec: Recording) -> float:
    """Smallest overlap of segments for ``rec``: a frame's span plus the reconciling guard [s].

    Parameters
    ----------
    rec : Recording
        The recording (its frame config and receiver settings set the span).

    Returns
    -------
    float
        Overlap [s]: the longest a frame can last at the settings' largest
        speed, plus ``GUARD_FRAMES`` frame durations.
    """
    return _frame_span_s(rec) + _guard_s(rec)


def default_overlap_s(rec: Recording) -> float:
    """Overlap giving a frame near a boundary the same detection context as in the whole file [s].

    Parameters
    ----------
    rec : Recording
        The recording.

    Returns
    -------
    float
        :func:`min_overlap_s` plus the detector's context and noise windows [s].
    """
    return overlap_for(_frame_span_s(rec), rec.config.frame_duration_s)


@dataclass(frozen=True)
class Part:
    """One unit of work: samples [lo, hi) of a recording, keeping arrivals in [keep_lo_s, keep_hi_s).

    ``start``/``end`` [samples] are the segment proper; ``segment`` its number
    (0 for a whole file), ``n_segments`` how many the recording has; ``file``
    the absolute path the worker reads (workers of a cluster have another
    working directory), ``recording.path`` the name written in ``source``.
    """

    recording: Recording
    file: str
    file_index: int
    segment: int
    n_segments: int
    start: int
    end: int
    lo: int
    hi: int
    fs: float
    n_samples: int
    channel: int
    keep_lo_s: float
    keep_hi_s: float

    @property
    def label(self) -> str:
        """The recording's path, plus ``segment k/n [t0, t1) s`` when it was cut."""
        if self.n_segments == 1:
            return str(self.recording.path)
        return (
            f"{self.recording.path} segment {self.segment + 1}/{self.n_segments} "
            f"[{self.start / self.fs:.3f}, {self.end / self.fs:.3f}) s"
        )

    def key(self) -> str:
        """Identity of the work: file (path, size, modification time), range and every option."""
        path = Path(self.file)
        st = path.stat()
        rec = self.recording
        material = {
            "version": __version__,
            "path": str(path),
            "size": st.st_size,
            "mtime_ns": st.st_mtime_ns,
            "range": [self.start, self.end, self.lo, self.hi, self.channel],
            "keep": [self.keep_lo_s, self.keep_hi_s],
            "config": rec.config.to_dict(),
            "emissions": rec.emissions.to_list(),
            "settings": rec.settings.to_dict(),
            "pilot": _plain(rec.pilot),
            "payloads": None if rec.payloads is None else [bytes(p).hex() for p in rec.payloads],
        }
        text = json.dumps(material, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


def _plain(value):
    if isinstance(value, np.ndarray):
        return [np.real(value).tolist(), np.imag(value).tolist()] if np.iscomplexobj(value) else value.tolist()
    return value


def plan_parts(
    recordings: Sequence[Recording], *, segment_s: float | None = None, overlap_s: float | None = None
) -> tuple[list[Part], list[tuple[int, str]]]:
    """Cut recordings into parts; returns (parts, [(file_index, error)] of unreadable files).

    Parameters
    ----------
    recordings : sequence of Recording
        The recordings to decode.
    segment_s : float or None, optional
        Length of a segment [s]; None (or a segment longer than the file)
        keeps each file whole. Must exceed half a frame.
    overlap_s : float or None, optional
        Samples read on each side of a segment [s], at least
        :func:`min_overlap_s`; None uses :func:`default_overlap_s`.

    Returns
    -------
    parts : list of Part
        The work units, file by file, segment by segment.
    failed : list of tuple
        ``(file_index, error)`` for each recording that could not be opened,
        the error as one line.

    Raises
    ------
    ConfigError
        ``segment_s`` not positive, ``overlap_s`` below :func:`min_overlap_s`.
    """
    if segment_s is not None and not (isinstance(segment_s, (int, float)) and math.isfinite(segment_s) and segment_s > 0):
        raise ConfigError("segment", f"must be a positive number of seconds, got {segment_s!r}")
    parts: list[Part] = []
    failed: list[tuple[int, str]] = []
    for i, rec in enumerate(recordings):
        try:
            source = open_recording(rec.path)
            ch = source.one_channel(rec.channel)
        except SeamodemError as exc:
            failed.append((i, str(exc)))
            continue
        fs, n = source.sample_rate_hz, source.n_samples
        file = str(Path(rec.path).resolve())
        if segment_s is None or segment_s * fs >= n:
            parts.append(Part(rec, file, i, 0, 1, 0, n, 0, n, fs, n, ch, -math.inf, math.inf))
            continue
        overlap = default_overlap_s(rec) if overlap_s is None else overlap_s
        if not (isinstance(overlap, (int, float)) and overlap >= min_overlap_s(rec)):
            raise ConfigError(
                "overlap", f"must be at least a frame's span plus the guard, {min_overlap_s(rec):.3f} s, got {overlap!r}"
            )
        guard = _guard_s(rec)
        if segment_s <= 2 * guard:
            raise ConfigError("segment", f"must be longer than {2 * guard:.3f} s (half a frame), got {segment_s!r}")
        seg, ov = round(segment_s * fs), math.ceil(overlap * fs)
        bounds = list(range(0, n, seg))
        for k, start in enumerate(bounds):
            end = min(n, start + seg)
            keep_lo = -math.inf if k == 0 else start / fs - guard
            keep_hi = math.inf if k == len(bounds) - 1 else end / fs + guard
            parts.append(
                Part(rec, file, i, k, len(bounds), start, end, max(0, start - ov), min(n, end + ov), fs, n, ch, keep_lo,
                     keep_hi)
            )
    return parts, failed


def decode_part(part: Part) -> dict[str, Any]:
    """Records of one part (the task run by the workers).

    Returns
    -------
    dict
        ``records`` (list of MeasurementRecord, times on the recording's clock,
        ``source`` set), ``clipped`` and ``silent`` (over the segment proper),
        ``warnings`` (one-line messages).
    """
    rec = part.recording
    t0 = part.lo / part.fs
    stats = BlockStats()
    cut: list[float] = []

    def on_frame(m, *_):
        if not m.complete:
            cut.append(m.pilot.t_start_s + t0)

    rx = Receiver(
        rec.config,
        emissions=rec.emissions.shifted(t0),
        settings=rec.settings,
        pilot=rec.pilot,
        payloads=rec.payloads,
        on_frame=on_frame,
    )
    blocks = read_blocks(
        part.file, channel=part.channel, start=part.lo, stop=part.hi, counted=(part.start, part.end), stats=stats,
        name=rec.path,
    )
    kept = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ReceiverWarning)
        for r in rx.run(blocks, fs=part.fs):
            t_arr = r.t_arrival_s + t0
            if part.keep_lo_s <= t_arr < part.keep_hi_s:
                kept.append(_on_file_clock(r, t_arr, rec.emissions, str(rec.path)))
    messages = []
    for w in caught:
        text = str(w.message)
        if issubclass(w.category, ReceiverWarning) and "is cut by the end of the recording" not in text:
            messages.append(text)
        elif not issubclass(w.category, ReceiverWarning):
            messages.append(f"{w.category.__name__}: {text}")
    if part.hi == part.n_samples:
        for t in cut:
            if part.keep_lo_s <= t < part.keep_hi_s:
                messages.append(
                    f"recording {rec.path}: frame at {t:.3f} s is cut by the end of the recording: "
                    "its Doppler uses the part received"
                )
    return {"records": kept, "clipped": stats.clipped, "silent": stats.silent, "warnings": messages}


def _on_file_clock(r: MeasurementRecord, t_arrival_s: float, emissions: Emissions, source: str) -> MeasurementRecord:
    """A part's record with its times on the recording's clock (t = 0 at its first sample)."""
    return dataclasses.replace(r, t_arrival_s=t_arrival_s, t_emit_s=emissions.time_of(r.frame_index), source=source)


@dataclass(frozen=True)
class PartFailure:
    """A recording or segment that could not be decoded, and why (one line).

    Attributes
    ----------
    label : str
        The recording's path, with the segment and its time span [s] when
        the file was cut.
    error : str
        The error message, one line.
    """

    label: str
    error: str


@dataclass
class BatchResult:
    """What a batch decode did.

    Attributes
    ----------
    records : list of MeasurementRecord
        Merged: recordings in the order given, by arrival time within each.
    failures : list of PartFailure
    warnings : list of str
    n_parts, n_resumed : int
        Parts of the job, and how many were taken from an earlier run.
    """

    records: list
    failures: list
    warnings: list
    n_parts: int
    n_resumed: int

    @property
    def ok(self) -> bool:
        return not self.failures


def _parts_dir(output: Path) -> Path:
    return output.with_name(output.name + ".parts")


def _save_part(folder: Path, key: str, part: Part, value: dict) -> None:
    """Write one finished part atomically (a crash mid-write leaves no half part)."""
    data = {
        "format": PART_FORMAT,
        "source": str(part.recording.path),
        "segment": part.segment,
        "range": [part.start, part.end],
        "clipped": value["clipped"],
        "silent": value["silent"],
        "warnings": value["warnings"],
        "records": [r.to_dict() for r in value["records"]],
    }
    tmp = folder / f".{key}.tmp"
    tmp.write_text(json.dumps(data), encoding="utf-8")
    os.replace(tmp, folder / f"{key}.json")


def _load_part(path: Path, source: str) -> dict | None:
    """A saved part, its records' source as spelled now; None when unreadable (then decoded again)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("format") != PART_FORMAT:
            return None
        records = [MeasurementRecord(**(r | {"source": source})) for r in data["records"]]
    except (OSError, ValueError, TypeError, KeyError):
        return None
    return {"records": records, "clipped": data["clipped"], "silent": data["silent"], "warnings": data["warnings"]}


def decode_files(
    recordings: Sequence[Recording | str | Path],
    config: FrameConfig | None = None,
    *,
    emissions: Emissions | None = None,
    channel: int | None = None,
    segment_s: float | None = None,
    overlap_s: float | None = None,
    output: str | Path | None = None,
    header: dict[str, Any] | None = None,
    resume: bool = False,
    backend: str = "processes",
    workers: int | None = None,
    scheduler=None,
    progress: bool | None | Callable[[int, int], None] = None,
    failed: Sequence[PartFailure] = (),
    settings: ReceiverSettings | None = None,
    pilot: np.ndarray | None = None,
    payloads: Sequence[bytes] | None = None,
) -> BatchResult:
    """Decode several recordings, each whole or in overlapping segments, and merge the records.

    Parameters
    ----------
    recordings : sequence of Recording, str or Path
        Paths use ``config``, ``emissions``, ``channel``, ``settings``, ``pilot`` and ``payloads``.
    segment_s : float, optional
        Cut recordings longer than this into segments [s] (default: whole files).
    overlap_s : float, optional
        Samples added before and after each segment [s]; at least
        :func:`min_overlap_s` (default: that plus the detector's context, ≈ 1 s).
    output : str or Path, optional
        Merged .csv or .jsonl; finished parts are kept in ``OUTPUT.parts/``
        until every part has succeeded.
    header : dict, optional
        Extra header of the output (command, sound speed...).
    resume : bool
        Reuse the parts of an earlier run found in ``OUTPUT.parts/`` (same
        file, range and options); otherwise they are decoded again.
    backend, workers, scheduler, progress
        As :func:`~seamodem.batch.runner.run_tasks`.
    failed : sequence of PartFailure
        Recordings that failed before this call (e.g. no sidecar): reported
        with the others, and the parts are kept for a rerun.

    Returns
    -------
    BatchResult
        Records, per-part failures (the job goes on past them) and warnings.
    """
    recs = []
    for r in recordings:
        if isinstance(r, Recording):
            recs.append(r)
        else:
            if config is None or emissions is None:
                raise ConfigError("config", "paths need a config and emissions (or give Recording objects)")
            recs.append(Recording(r, config, emissions, channel, settings or ReceiverSettings(), pilot, payloads))
    folder = None
    if output is not None:
        output = check_writable(output)
        if output.suffix.lower() not in (".csv", ".jsonl"):
            raise SeamodemError(f"output: must end in .csv or .jsonl, got {str(output)!r}")
        folder = _parts_dir(output)
    parts, unreadable = plan_parts(recs, segment_s=segment_s, overlap_s=overlap_s)
    failures = list(failed) + [PartFailure(str(recs[i].path), err) for i, err in unreadable]
    keys = [p.key() for p in parts] if folder is not None else [None] * len(parts)
    values: list[dict | None] = [None] * len(parts)
    if folder is not None:
        if folder.is_dir() and not resume:
            shutil.rmtree(folder)
        folder.mkdir(exist_ok=True)
        for i, key in enumerate(keys):
            if (folder / f"{key}.json").is_file():
                values[i] = _load_part(folder / f"{key}.json", str(parts[i].recording.path))
    todo = [i for i, v in enumerate(values) if v is None]
    n_resumed = len(parts) - len(todo)

    def save(result: TaskResult) -> None:
        if result.ok and folder is not None:
            i = todo[result.index]
            _save_part(folder, keys[i], parts[i], result.value)

    results = run_tasks(
        decode_part,
        [parts[i] for i in todo],
        backend=backend,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
        on_result=save,
        desc="rx",
    )
    for i, res in zip(todo, results):
        if res.ok:
            values[i] = res.value
        else:
            failures.append(PartFailure(parts[i].label, res.error))
    records, notes = _merge(parts, values)
    if output is not None:
        head = {"created_by": f"seamodem {__version__}", **(header or {})}
        head["recordings"] = [str(r.path) for r in recs]
        write_measurements(output, records, head)  # with its sidecar, both atomic
        if not failures:
            shutil.rmtree(folder, ignore_errors=True)
    return BatchResult(records, failures, notes, len(parts), n_resumed)


def _merge(parts: list[Part], values: list[dict | None]) -> tuple[list[MeasurementRecord], list[str]]:
    """Records of every finished part, one per frame, recordings in order and by arrival within each."""
    by_file: dict[int, list[tuple[Part, dict]]] = {}
    for p, v in zip(parts, values):
        if v is not None:
            by_file.setdefault(p.file_index, []).append((p, v))
    out: list[MeasurementRecord] = []
    notes: list[str] = []
    for i in sorted(by_file):
        done = sorted(by_file[i], key=lambda pv: pv[0].segment)
        rec = done[0][0].recording
        kept: list[MeasurementRecord] = []
        for p, v in done:
            kept.extend(v["records"])
            notes.extend(v["warnings"])
        kept = _reconcile(kept, done, _guard_s(rec))
        kept.sort(key=lambda r: r.t_arrival_s)
        out.extend(kept)
        whole = len(done) == done[0][0].n_segments
        stats = BlockStats(clipped=sum(v["clipped"] for _, v in done), silent=whole and all(v["silent"] for _, v in done))
        notes.extend(recording_warnings(rec.path, stats, n_frames=len(kept) if whole else None))
    return out, notes


def _reconcile(records: list[MeasurementRecord], done: list[tuple[Part, dict]], guard_s: float) -> list[MeasurementRecord]:
    """Drop the second copy of a frame found by both segments around a boundary.

    Each segment keeps arrivals up to ``guard_s`` past its boundary, so a frame
    arriving near one is seen by both sides; the two estimates differ by far
    less than the guard (a quarter frame, closer than any two frames). The copy
    kept is the one of the segment the arrival lies in (the earlier segment's
    when the two estimates straddle the boundary).
    """
    bounds = {p.segment: p.end / p.fs for p, _ in done}
    drop = set()
    for p, v in done:
        if p.segment + 1 not in bounds:
            continue
        b = bounds[p.segment]
        mine = [r for r in v["records"] if r.t_arrival_s >= b - guard_s]
        theirs = [
            r
            for q, w in done
            if q.segment == p.segment + 1
            for r in w["records"]
            if r.t_arrival_s < b + guard_s
        ]
        for a in mine:
            for c in theirs:
                if id(c) not in drop and abs(a.t_arrival_s - c.t_arrival_s) < guard_s:
                    drop.add(id(c) if (a.t_arrival_s < b or c.t_arrival_s < b) else id(a))
                    break
    return [r for r in records if id(r) not in drop]
