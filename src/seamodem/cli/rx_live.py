"""``seamodem rx -``: a receiver fed live, from a pipe, a FIFO, stdin or a sound card (docs/live.md).

rx.py only branches here: the stream is opened by :func:`open_live_input`
(instead of a file), and the receiver's records go through
:func:`write_live` (each written and flushed as it is measured, the sidecar
first) instead of the whole-file writer. A status line goes to stderr.

Exit codes (docs/live.md): 0 the producer closed the stream (everything that
arrived is measured); 2 bad input or options; 3 the producer stalled
(``--stall-timeout``); 4 the reader of the output went away (EPIPE); 5 the
sound card overran (samples lost: the clock after it is not the stream's);
130 stopped by Ctrl-C or SIGTERM (everything that arrived before is
measured; a second Ctrl-C quits at once).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import time

from ..errors import SeamodemError

__all__ = ["EXIT_CODES", "LIVE_FRONT_END_BLOCK", "LiveRun", "live_settings", "add_live_options", "live_requested", "check_live_options", "open_live_input",
           "warm_up", "write_live"]

#: input samples per front-end FFT block live (≈ 85 ms at 96 kHz; a file's 2¹⁶ is ≈ 0.68 s of latency)
LIVE_FRONT_END_BLOCK = 1 << 13

#: why a live run ended → its exit code
EXIT_CODES = {"end of stream": 0, "stalled": 3, "output closed": 4, "overrun": 5, "interrupted": 130}


def add_live_options(p: argparse.ArgumentParser) -> None:
    """The options of a live receiver (stream format, stall timeout, sound card, status line)."""
    g = p.add_argument_group(
        "live input (docs/live.md)",
        "RECORDING '-' (stdin), a FIFO or /dev/stdin is read as it arrives: a WAV stream, or raw PCM with --raw. "
        "Each record is written and flushed as its frame is measured (-o - : JSON Lines on stdout, the sidecar "
        "as its first line); a status line goes to stderr. Exit codes: 0 end of stream, 3 stalled, 4 output "
        "closed, 5 sound-card overrun, 130 Ctrl-C.",
    )
    g.add_argument("--raw", metavar="FORMAT",
                   help="raw PCM on the stream: S16_LE, S24_LE (4-byte container, ALSA), S24_3LE, S32_LE, FLOAT_LE, "
                        "FLOAT64_LE (with --sample-rate and --channels)")
    g.add_argument("--channels", type=int, metavar="N", help="raw PCM or sound card: interleaved channels (default 1)")
    g.add_argument("--stall-timeout", type=float, metavar="S",
                   help="end the run (exit 3) when the producer writes nothing for S seconds (default: wait)")
    g.add_argument("--device", metavar="NAME|INDEX",
                   help="read a sound card through PortAudio (pip install 'seamodem[live]'); needs --sample-rate")
    g.add_argument("--output-format", choices=("jsonl", "csv"), default="jsonl",
                   help="records on stdout (-o -): JSON Lines (default) or CSV")
    g.add_argument("--front-end-block", type=int, metavar="N",
                   help=f"live: input samples per front-end FFT block (default {LIVE_FRONT_END_BLOCK}; smaller: "
                        "less latency, more CPU)")
    g.add_argument("--no-status", dest="status", action="store_false",
                   help="no status line on stderr (also with -q)")


def live_requested(args: argparse.Namespace) -> bool:
    """Whether ``rx`` runs live: a stream or a sound card as input, or records to stdout."""
    from ..io.live import is_live_input

    return (args.device is not None or args.output == "-"
            or (len(args.recording) == 1 and is_live_input(args.recording[0])))


def live_settings(settings, args: argparse.Namespace):
    """The receiver's settings for a live run: the front end's short blocks (``--front-end-block``), and
    each record given out as soon as it is measured (``lookahead_frames=0`` unless ``--lookahead`` says
    otherwise: an autopilot wants it now; its range σ then has only the earlier frames' channel bend).

    Parameters
    ----------
    settings : ReceiverSettings
    args : argparse.Namespace

    Returns
    -------
    ReceiverSettings
    """
    import dataclasses

    from ..errors import ConfigError

    block = LIVE_FRONT_END_BLOCK if args.front_end_block is None else args.front_end_block
    try:
        lookahead = 0 if getattr(args, "lookahead", None) is None else args.lookahead
        return dataclasses.replace(settings, front_end_block=block, lookahead_frames=lookahead)
    except ConfigError as exc:
        raise SeamodemError(f"front-end-block:{str(exc).partition(':')[2]}") from None


def check_live_options(args: argparse.Namespace) -> None:
    """Refuse what a live run cannot do (one-line errors, before anything is read)."""
    if args.device is not None and args.recording:
        raise SeamodemError("device: a sound card replaces RECORDING: give one or the other")
    if args.device is None and len(args.recording) != 1:
        raise SeamodemError("recording: a live run reads one stream (give '-', a FIFO, or --device)")
    for name in ("segment", "overlap", "workers", "scheduler", "resume", "plot"):
        if name == "segment" and (args.array or getattr(args, "reference", None)):
            continue  # the array and reference receivers run in segments on a stream
        if getattr(args, name, None) not in (None, False):
            raise SeamodemError(f"{name.replace('_', '-')}: not available on a live stream"
                                + (" (--segment: with --array or --reference only)" if name == "segment" else ""))
    if args.segment is not None and not (args.segment > 0 and math.isfinite(args.segment)):
        raise SeamodemError(f"segment: must be a positive number of seconds, got {args.segment!r}")
    if args.output != "-" and args.output_format != "jsonl":
        raise SeamodemError("output-format: chooses the format on stdout (-o -); a file's comes from its suffix")


class LiveRun:
    """The context of a live run: Ctrl-C and SIGTERM end the stream, stdout carries only records.

    Inside it, Ctrl-C or SIGTERM once sets :attr:`event` (the source stops
    reading and the receiver measures what has arrived); Ctrl-C twice quits at
    once. ``sys.stdout`` is stderr, so that no message mixes with the records,
    which go to :attr:`stdout`.

    Attributes
    ----------
    event : threading.Event
        Set to end the stream.
    stdout : text file
        The real stdout.
    warm_up : threading.Thread or None
        The receiver's warm-up (:func:`warm_up`), waited for before the first block.
    """

    def __init__(self):
        self.event = threading.Event()
        self.stdout = sys.stdout
        self.warm_up: threading.Thread | None = None
        self._old = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._old[sig] = signal.signal(sig, self._handle)
        sys.stdout = sys.stderr
        return self

    def _handle(self, signum, frame):
        if self.event.is_set() and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.event.set()
        print("\nseamodem rx: stopping: measuring what has arrived (Ctrl-C again to quit now)", file=sys.stderr)

    def __exit__(self, *exc):
        sys.stdout = self.stdout
        for sig, old in self._old.items():
            signal.signal(sig, old)


def open_live_input(args: argparse.Namespace, stop: threading.Event):
    """The live source the options name: a sound card (``--device``) or a stream (RECORDING).

    Parameters
    ----------
    args : argparse.Namespace
        ``rx``'s options.
    stop : threading.Event
        Set to end the stream (Ctrl-C).

    Returns
    -------
    RecordingSource
        Of unknown length (``n_samples`` None), with an ``end_reason``.
    """
    if args.device is not None:
        from ..io.device import open_device

        if args.raw is not None:
            raise SeamodemError("raw: a sound card gives samples, not a byte stream: drop --raw")
        return open_device(args.device, sample_rate_hz=args.sample_rate, n_channels=args.channels or 1, stop=stop)
    from ..io.live import open_live

    return open_live(args.recording[0], raw_format=args.raw, sample_rate_hz=args.sample_rate,
                     n_channels=args.channels, stall_timeout_s=args.stall_timeout, stop=stop)


class _Status:
    """The status line on stderr: stream time, frames, the last frame's SNR (rewritten in place on a terminal)."""

    def __init__(self, source, enabled: bool):
        self.source, self.enabled = source, enabled
        self.tty = enabled and sys.stderr.isatty()
        self.frames, self.last = 0, None
        self._done = threading.Event()
        if self.tty:
            threading.Thread(target=self._tick, daemon=True).start()

    def _stream_time(self) -> float:
        return self.source.stats.read / self.source.sample_rate_hz

    def line(self) -> str:
        last = "" if self.last is None else (f", last: frame {self.last.frame_index} at {self.last.t_arrival_s:.3f} s, "
                                             f"SNR {self.last.snr_db:.1f} dB, range {self.last.range_m:.2f} m")
        behind = getattr(self.source, "backlog_s", 0.0)
        lag = f", {behind:.1f} s behind" if behind >= 0.5 else ""
        return (f"rx: stream {self._stream_time():8.1f} s{lag}, {self.frames} frame{'s' if self.frames != 1 else ''}"
                f"{last}")

    def _tick(self):
        while not self._done.wait(1.0):
            print("\r" + self.line(), end="", file=sys.stderr, flush=True)

    def frame(self, rec) -> None:
        self.frames += 1
        self.last = rec
        if self.enabled:
            print(("\r" if self.tty else "") + self.line(), end="" if self.tty else "\n", file=sys.stderr, flush=True)

    def close(self) -> None:
        self._done.set()
        if self.tty:
            print("\r" + self.line(), file=sys.stderr, flush=True)


def warm_up(args: argparse.Namespace) -> threading.Thread:
    """Run the receiver once on a synthetic frame, in a thread started before the stream is opened.

    The first frame of a run otherwise pays for the first calls of the compiled kernels and of scipy's
    transforms (about 1.5 s here, benchmarks/bench_live.py). Started before the stream's header is
    read, it runs while the producer starts; :func:`write_live` waits for it before the first block
    (the source's own thread keeps reading the pipe meanwhile, so the producer does not wait).

    Parameters
    ----------
    args : argparse.Namespace
        ``rx``'s options (the frame configuration, decoding on or off).

    Returns
    -------
    threading.Thread
    """
    def work():
        import numpy as np

        from ..receive.settings import Emissions, ReceiverSettings
        from ..receive.stream import Receiver
        from ..transmit.beacon import BeaconSchedule, render_beacon
        from ._common import config_from_args

        try:
            config = config_from_args(args)
            settings = ReceiverSettings(decode=args.decode, front_end_block=LIVE_FRONT_END_BLOCK)
        except (SeamodemError, ValueError):  # the run reports it itself
            return
        beacon = render_beacon(config, BeaconSchedule(count=1, period_s=1.0, start_s=0.1))
        x = np.concatenate([*beacon.blocks(progress=False), np.zeros(int(config.sample_rate_hz))])
        x = x + 1e-3 * np.random.default_rng(0).standard_normal(x.size)
        for _ in Receiver(config, emissions=Emissions(start_s=0.1, period_s=1.0), settings=settings).run(
                [x], fs=config.sample_rate_hz):
            pass

    thread = threading.Thread(target=work, daemon=True, name="rx warm-up")
    thread.start()
    return thread


def write_live(args: argparse.Namespace, out, records, header: dict, source, run: LiveRun, *,
               fields=None, keep_unmatched: bool = False) -> int:
    """Write each record as it comes (flushed), the sidecar first; report how the stream ended; its exit code.

    Parameters
    ----------
    args : argparse.Namespace
        ``rx``'s options (``output``, ``output_format``, ``quiet``, ``status``).
    out : Path or None
        The measurement file; None: stdout.
    records : iterable of MeasurementRecord
        The receiver's, as measured.
    header : dict
        The run's description (as for a file).
    source : RecordingSource
        The live source (its ``end_reason`` and statistics).
    run : LiveRun
        The run's context (its ``stdout``; its ``event``, set here when the output closes).
    fields : sequence of str, optional
        The columns (default: the measurement record's).
    keep_unmatched : bool
        Write the arrivals without an emission too (the reference receiver's, range empty).

    Returns
    -------
    int
        :data:`EXIT_CODES` of why the run ended.
    """
    from ..receive.records import MeasurementWriter

    stdout, stop = run.stdout, run.event
    header = header | {"live": {"input": source.name, "stall_timeout_s": args.stall_timeout,
                                "block_s": getattr(source, "block_s", None)}}
    writer = MeasurementWriter(out, header, stream=stdout if out is None else None,
                               kind=args.output_format if out is None else None, keep_unmatched=keep_unmatched,
                               **({} if fields is None else {"fields": fields}))
    if run.warm_up is not None:
        run.warm_up.join()
    status = _Status(source, enabled=args.status and not args.quiet)
    reason, error = None, None
    t_start = time.monotonic()
    try:
        for rec in records:
            try:
                written = writer.write(rec)
            except BrokenPipeError:
                reason = "output closed"
                stop.set()
                break
            if written:
                status.frame(rec)
    except SeamodemError as exc:
        error = exc
    finally:
        status.close()
        close = getattr(records, "close", None)
        if close is not None:
            close()
    if reason == "output closed":
        # nothing more may reach the closed pipe, not even Python's flush at exit
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, stdout.fileno())
    reason = reason or getattr(source, "end_reason", None) or "end of stream"
    t_stream = source.stats.read / source.sample_rate_hz
    end = {"ended": reason if error is None else f"error: {error}", "complete": error is None, "stream_s": t_stream,
           "wall_s": time.monotonic() - t_start}
    if getattr(source, "overruns", None):
        end["overruns"] = source.overruns
    writer.close(**end)
    if error is not None:
        raise error
    messages = {
        "end of stream": "the producer closed the stream",
        "stalled": f"the producer wrote nothing for {args.stall_timeout} s (--stall-timeout): stopped",
        "output closed": "the output's reader went away (EPIPE): stopped; frames measured after it are lost",
        "overrun": "the sound card overran (samples lost): stopped, the stream's clock is no longer the beacon's",
        "interrupted": "interrupted: stopped",
    }
    print(f"seamodem rx: {messages.get(reason, reason)} at stream time {t_stream:.1f} s; {writer.rows} record"
          f"{'s' if writer.rows != 1 else ''} written to {'stdout' if out is None else out}", file=sys.stderr)
    if getattr(source, "dropped_bytes", 0):
        print(f"seamodem rx: warning: the stream ended inside a sample ({source.dropped_bytes} bytes left over)",
              file=sys.stderr)
    return EXIT_CODES.get(reason, 1)
