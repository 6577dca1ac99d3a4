"""A whole-recording receiver run on a live stream in overlapping segments, its records emitted as they are final.

The array receiver (:func:`~seamodem.receive.array.receive_array`) and the
reference receiver work on a whole recording. On a stream (``seamodem rx -
--array``, ``--reference``) :func:`segmented_records` keeps a buffer of the
stream and, each time ``segment_s`` of new samples has arrived, runs the
receiver on the buffer from ``overlap`` before the part not yet emitted to the
newest sample. It emits the records that arrive in the part not yet emitted
and early enough to be whole in the buffer, then drops the samples the next
run no longer needs. At the end of the stream it runs once more and emits the
rest. The rules are the batch decoder's (:mod:`~seamodem.batch.decode`): a run
keeps the arrivals in [boundary − guard, newest − (overlap − guard)) (a batch
segment [start − overlap, end + overlap) keeps [start − guard, end + guard)), and
an arrival within the guard of one already emitted is the same frame, found
again: not emitted twice. A frame is emitted at most ``segment_s + overlap``
after its arrival (plus the receiver's run); memory holds at most
``segment_s + 2·overlap`` of samples.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Iterable, Iterator

import numpy as np

__all__ = ["DEFAULT_SEGMENT_S", "segmented_records", "on_stream_clock"]

#: live ``--array``/``--reference``: seconds of new stream between two runs of the receiver (the latency's bound)
DEFAULT_SEGMENT_S = 5.0

#: a warning of a run about the buffer's end, not the stream's: a frame cut there is received in the next run
_BUFFER_END = "cut by the end of the recording"


def on_stream_clock(record, t0_s: float):
    """A record received on samples starting at ``t0_s`` of the stream, with its times on the stream's clock.

    Parameters
    ----------
    record : MeasurementRecord
        Times relative to the buffer's first sample (emissions shifted by ``t0_s``).
    t0_s : float
        Stream time of the buffer's first sample [s].

    Returns
    -------
    MeasurementRecord
        ``t_arrival_s`` and ``t_emit_s`` moved by ``t0_s`` (``tof_s`` and the rest unchanged).
    """
    if t0_s == 0:
        return record
    return dataclasses.replace(record, t_arrival_s=record.t_arrival_s + t0_s, t_emit_s=record.t_emit_s + t0_s)


def segmented_records(
    blocks: Iterable[np.ndarray],
    fs: float,
    receive: Callable[[np.ndarray, float], list],
    *,
    overlap_s: float,
    guard_s: float,
    segment_s: float = DEFAULT_SEGMENT_S,
    partial_warnings: tuple[type[Warning], ...] = (),
) -> Iterator:
    """Records of a whole-recording receiver on a stream, each yielded once its frame is final.

    Parameters
    ----------
    blocks : iterable of numpy.ndarray, shape (n, n_channels)
        The stream, as it arrives.
    fs : float
        Sample rate [Hz].
    receive : callable
        ``receive(x, t0_s)``: the records of the samples ``x`` (shape (n, n_channels)) whose first sample
        is at stream time ``t0_s``, with their times on the stream's clock (:func:`on_stream_clock`).
    overlap_s : float
        Samples before the part not yet emitted given to each run, and after an arrival before it is
        emitted [s] (:func:`~seamodem.batch.decode.overlap_for`).
    guard_s : float
        Two arrivals closer than this are one frame [s] (:func:`~seamodem.batch.decode.guard_for`).
    segment_s : float
        New stream between two runs [s].
    partial_warnings : tuple of Warning classes
        Warnings a run raises about what the buffer's edges cut (an incomplete packet): shown from the
        last run only. Other warnings are shown once each.

    Yields
    ------
    MeasurementRecord
        By arrival, each frame once.
    """
    if not (segment_s > 0 and math.isfinite(segment_s)):
        raise ValueError(f"segment_s must be positive, got {segment_s!r}")
    settle = max(1, math.ceil((overlap_s - guard_s) * fs))  # after an arrival before it is emitted [samples]
    ov, seg = math.ceil(overlap_s * fs), max(1, round(segment_s * fs))
    chunks: list[np.ndarray] = []
    buf_start = 0  # stream sample of the buffer's first sample
    n = 0  # samples read
    done = 0  # every arrival before this sample (less the guard) has been emitted
    emitted: list[float] = []  # recent arrivals emitted [s]
    seen: set[str] = set()
    next_run = seg

    def run(final: bool):
        nonlocal chunks, buf_start, done
        cut = math.inf if final else n - settle
        if not final and cut <= done:
            return []
        lo = max(0, done - ov)
        x = np.concatenate(chunks) if len(chunks) > 1 else chunks[0]
        chunks = [x[lo - buf_start:]]
        buf_start = lo
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            records = receive(chunks[0], lo / fs) if len(chunks[0]) else []
        for w in caught:  # each warning once, and none about the buffer's end before the stream's
            text = str(w.message)
            partial = _BUFFER_END in text or issubclass(w.category, partial_warnings)
            if (final or not partial) and text not in seen:
                seen.add(text)
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        t_lo, t_hi = done / fs - guard_s, cut / fs
        out = []
        for r in sorted(records, key=lambda r: r.t_arrival_s):
            t = r.t_arrival_s
            if t_lo <= t < t_hi and not any(abs(t - e) < guard_s for e in emitted):
                out.append(r)
                emitted.append(t)
        if not final:
            done = int(cut)
            del emitted[:-8]  # only arrivals near the boundary can come again
        return out

    for block in blocks:
        block = np.asarray(block, float).reshape(len(block), -1)
        if not len(block):
            continue
        chunks.append(block)
        n += len(block)
        if n >= next_run:
            yield from run(final=False)
            next_run = n + seg
    if n:
        yield from run(final=True)
