"""``seamodem rx --reference SPEC``: range and Doppler on known pings (chirps, m-sequences, templates).

Hooked into ``seamodem rx`` by :func:`add_reference_options`: with
``--reference`` the command runs :func:`run_reference` instead of the frame
receiver. Heavy imports stay inside the functions (fast command line).
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from ..errors import ConfigError, InputFileError, SeamodemError
from ..io.files import check_writable
from ._common import command_line, emit_schedule, sound_speed, sound_speed_words

__all__ = ["add_reference_options", "run_reference", "write_reference_records"]


def add_reference_options(p: argparse.ArgumentParser) -> None:
    """Add the reference options to ``seamodem rx`` and route ``--reference`` runs to :func:`run_reference`."""
    g = p.add_argument_group(
        "ranging on other waveforms (docs/references.md)",
        "With --reference, RECORDING is searched for known pings instead of seamodem frames: each "
        "occurrence gives one record (arrival, range, Doppler, SNR, σ's) naming the reference it matched. "
        "Emission times: --emit-start/--emit-period, or the sidecar `seamodem tx --reference` wrote.",
    )
    g.add_argument(
        "--reference",
        action="append",
        metavar="SPEC",
        help="lfm:F1-F2:DURATION, hfm:F1-F2:DURATION, pn:CARRIER:CHIPRATE:DEGREE, template:FILE[:START-STOP], "
        "a TOML/JSON file, or a reference sidecar (repeatable: several references in one recording)",
    )
    g.add_argument("--mat-variable", metavar="NAME", help=".mat recordings and .mat templates: the variable holding the samples")
    g.add_argument("--sample-rate", type=float, metavar="HZ", help="sample rate when the file has none (.mat recordings and templates), or to override the recording's")
    g.add_argument(
        "--all-channels",
        action="store_true",
        help="search every channel and keep, per detection, the channel with the highest E/N0",
    )
    g.add_argument(
        "--max-accel",
        type=float,
        default=None,
        metavar="MPS2",
        help="pre/postamble pairs: largest radial acceleration over a packet (default 0.3 m/s²); "
        "0 states a constant speed: the Doppler from the spacing alone, ~10x more precise",
    )
    frames_run = p.get_default("run")

    def run(args: argparse.Namespace) -> int:
        if args.reference:
            return run_reference(args)
        for name in ("all_channels", "max_accel"):
            if getattr(args, name) is not None and getattr(args, name) is not False:  # 0 is a value given
                raise SeamodemError(f"{name.replace('_', '-')}: only with --reference")
        return frames_run(args)

    p.set_defaults(run=run)


def _reference_emissions(args, sidecar: dict | None, references) -> dict:
    """Emissions per reference name (None when unknown)."""
    from ..receive.settings import Emissions

    given = emit_schedule(args)
    if given is not None:
        return {r.name: given for r in references}
    out = {}
    for r in references:
        # a packet's emission is its first chirp's: the later chirps of its trains and its postamble are
        # placed from it (ReferenceWaveform.packet)
        times = [float(f["t_emit_s"]) for f in (sidecar or {}).get("frames", [])
                 if f.get("reference") == r.name and f.get("role", "ping") != "postamble"
                 and f.get("train_position", 0) == 0]
        out[r.name] = Emissions(times_s=times) if times else None
    return out


def _with_template_options(ref, args):
    """--sample-rate and --mat-variable reach a template reference that does not set its own."""
    import dataclasses

    if ref.kind != "template":
        return ref
    changes = {}
    if args.sample_rate is not None and not ref.sample_rate_hz:
        changes["sample_rate_hz"] = args.sample_rate
    if args.mat_variable and not ref.mat_variable:
        changes["mat_variable"] = args.mat_variable
    return dataclasses.replace(ref, **changes) if changes else ref


def _recording_sidecar(recording: Path) -> dict | None:
    """The recording's sidecar (``REC.json``, any seamodem format: its sound speed, and with
    :func:`_own_sidecar` its emissions); None when absent or unreadable."""
    path = recording.with_suffix(".json")
    if path == recording or not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, OSError):
        return None
    return data if isinstance(data, dict) else None


def _own_sidecar(side: dict | None) -> dict | None:
    """The recording's sidecar when it is a reference beacon's (``seamodem tx --reference``, then ``channel``)."""
    from ..transmit.reference import REFERENCE_SIDECAR_FORMAT

    return side if side is not None and side.get("format") == REFERENCE_SIDECAR_FORMAT else None


def write_reference_records(path: Path, records: list, metadata: dict) -> int:
    """The receiver's :func:`~seamodem.receive.records.write_measurements` with the reference columns.

    Plain CSV (one header row) or JSON Lines, metadata in the sidecar ``PATH.json``; files appear together
    or not at all. Columns: every :class:`~seamodem.receive.records.MeasurementRecord` column, then the
    reference's own (:data:`~seamodem.receive.reference.REFERENCE_FIELDS`). Detections without an
    emission (times unknown) are written too, their range empty.
    """
    from ..receive.records import write_measurements
    from ..receive.reference import REFERENCE_FIELDS

    return write_measurements(path, records, metadata, fields=REFERENCE_FIELDS, keep_unmatched=True)


def _reference_records(receiver, blocks, *, channels: list[int], source, emissions: dict, settings,
                       t0_s: float = 0.0) -> list:
    """The records of every reference found in ``blocks`` (first sample at stream time ``t0_s``), on the stream's clock.

    The receiver's detections, the best channel's per ping, the matching reference's per overlap, packets
    paired (:func:`~seamodem.receive.reference.pair_up`, its warnings raised), then one record each.
    """
    from ..batch.live import on_stream_clock
    from ..receive.reference import best_per_detection, keep_matching_reference, pair_up, to_record

    fs = source.sample_rate_hz
    found = list(receiver.run(blocks))
    for f in found:
        f.channel = channels[f.channel]
        lo = int((f.fit.t_arrival_s + t0_s) * fs)
        f.clipped = source.stats.clipped_between(f.channel, lo, lo + int(f.reference.duration_s * fs) + 1)
    found = best_per_detection(found, tolerance_s=0.5 * min(r.duration_s for r in receiver.references))
    found = keep_matching_reference(found)
    c = settings.sound_speed_mps
    pair_up(found, eps_max=settings.eps_max, sound_speed_mps=c, max_accel_mps2=settings.max_accel_mps2)
    shifted = {name: None if e is None else e.shifted(t0_s) for name, e in emissions.items()}
    return [on_stream_clock(to_record(f, shifted[f.reference.name], sound_speed_mps=c,
                                      clock_offset_s=settings.clock_offset_s), t0_s) for f in found]


def _live_reference_records(args, new_receiver, source, channels: list[int], emissions: dict, settings):
    """A stream's records, the receiver run in overlapping segments, each yielded once its ping is final
    (:func:`~seamodem.batch.live.segmented_records`; overlap and guard by the batch decoder's rules)."""
    from ..batch.decode import guard_for, overlap_for
    from ..batch.live import DEFAULT_SEGMENT_S, segmented_records
    from ..receive.measure import FRAME_TAIL_S, NOISE_GAP_S, NOISE_WINDOW_S
    from ..receive.reference.packets import PacketWarning

    references = new_receiver().references
    c = settings.sound_speed_mps
    # the longest packet (first chirp to the end of the last) at the largest speed, its tails and noise window
    span = max(max(t for t, _, _ in r.packet()) + r.duration_s for r in references) * (1 + settings.v_max_mps / c)
    span += FRAME_TAIL_S + NOISE_GAP_S + NOISE_WINDOW_S
    shortest = min(r.duration_s for r in references)
    receiver = new_receiver()
    # and the detector's own noise context before a ping
    overlap = max(overlap_for(span, shortest), receiver.keep / receiver.plan.fs_bb + guard_for(shortest))

    def receive(x, t0_s):
        return _reference_records(new_receiver(), [x], channels=channels, source=source, emissions=emissions,
                                  settings=settings, t0_s=t0_s)

    return segmented_records(source.blocks(channels), source.sample_rate_hz, receive, overlap_s=overlap,
                             guard_s=guard_for(shortest), partial_warnings=(PacketWarning,),
                             segment_s=DEFAULT_SEGMENT_S if args.segment is None else args.segment)


def run_reference(args: argparse.Namespace) -> int:
    """Detect and measure every occurrence of the references in one recording, or a stream (docs/live.md)."""
    from .rx_live import check_live_options, live_requested

    live = live_requested(args)
    if live:
        check_live_options(args)
    elif len(args.recording) != 1:
        raise SeamodemError("reference: give one recording with --reference")
    out = None if args.output == "-" else check_writable(args.output)
    if out is not None and out.suffix.lower() not in (".csv", ".jsonl"):
        raise SeamodemError("output: must end in .csv or .jsonl" + (", or be '-' (stdout)" if live else "")
                            + f", got {str(out)!r}")
    for name in ("segment", "workers", "scheduler", "resume", "plot"):
        if getattr(args, name, None) and not (live and name == "segment"):
            raise SeamodemError(f"{name}: not available with --reference" + (" (but on a stream)" if name == "segment" else ""))
    from ..receive.settings import ReferenceSettings

    recording = Path(args.recording[0]) if args.recording else Path(f"device {args.device}")
    recording_side = None if args.device is not None else _recording_sidecar(recording)
    c, c_origin = sound_speed(args, recording_side)
    try:
        settings = ReferenceSettings(
            sound_speed_mps=c,
            clock_offset_s=args.clock_offset, turnaround_s=args.turnaround, v_max_mps=args.v_max,
            false_alarms_per_hour=args.false_alarms_per_hour,
            **({} if args.max_accel is None else {"max_accel_mps2": args.max_accel}),
        )
    except ConfigError as exc:  # named as the option is spelled
        raise SeamodemError(f"{exc.parameter.replace('_', '-')}:{str(exc).partition(':')[2]}") from None
    if args.all_channels and args.channel is not None:
        raise SeamodemError("channel: give --channel N or --all-channels, not both")
    from contextlib import nullcontext

    from .rx_live import LiveRun

    with LiveRun() if live else nullcontext() as run:
        return _run_reference(args, out, recording, recording_side, settings, c_origin, run)


def _run_reference(args, out, recording: Path, recording_side, settings, c_origin: str, run) -> int:
    """:func:`run_reference` once the options are checked (``run``: the live run's context, or None)."""
    from ..io.matlab import is_mat
    from ..io.source import open_recording
    from ..io.wav import RecordingWarning
    from ..transmit.reference import load_references
    from .rx_live import open_live_input

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RecordingWarning)
        # --mat-variable names a .mat recording's variable, and a .mat template's (_with_template_options)
        if run is not None:  # a stream: received in segments, each record written as its ping is final
            source = open_live_input(args, run.event)
        else:
            source = open_recording(recording, mat_variable=args.mat_variable if is_mat(recording) else None,
                                    sample_rate_hz=args.sample_rate)
    for w in caught:
        print(f"seamodem rx: warning: {w.message}", file=sys.stderr)
    if source.n_channels > 1 and args.channel is None and not args.all_channels:
        raise InputFileError(f"recording {recording} has {source.n_channels} channels: choose one with --channel, or --all-channels")
    channels = source.check_channel(None if args.all_channels else (args.channel or 0))
    references = [_with_template_options(r, args) for spec in args.reference for r in load_references(spec)]
    if args.mat_variable and not is_mat(recording) and not any(
            r.kind == "template" and is_mat(r.file) for r in references):
        raise SeamodemError(f"mat-variable: {recording} is not a .mat file, nor is any template")
    sidecar = _own_sidecar(recording_side)
    c = settings.sound_speed_mps
    emissions = _reference_emissions(args, sidecar, references)

    from ..receive.reference import REFERENCE_FIELDS, ReferenceReceiver
    from ..receive.reference.packets import PacketWarning
    from ..transmit.reference import reference_replica

    replicas = [reference_replica(r) for r in references]

    def new_receiver():
        return ReferenceReceiver([rep.reference for rep in replicas], source.sample_rate_hz, settings=settings,
                                 n_channels=len(channels), replicas=replicas)

    receiver = new_receiver()
    max_accel = settings.max_accel_mps2
    metadata = {
        "created_by": command_line(),
        "recording": str(recording),
        "sample_rate_hz": source.sample_rate_hz,
        "channels": channels,
        "sound_speed_mps": c,
        "clock_offset_s": settings.clock_offset_s,
        "v_max_mps": settings.v_max_mps,
        "false_alarms_per_hour": settings.false_alarms_per_hour,
        "max_accel_mps2": max_accel,
        "references": [r.to_dict() for r in receiver.references],
        "front_end": {"centre_hz": receiver.plan.centre_hz, "baseband_rate_hz": receiver.plan.fs_bb,
                      "decimation": receiver.plan.decimation},
        "snr_definition": "in-band SNR over the reference's band [f_low, f_high] during the ping; E/N0 = SNR·B·T",
    }
    if run is not None:
        from ..batch.live import DEFAULT_SEGMENT_S
        from ._common import reported_warnings
        from .rx_live import write_live

        metadata["segment_s"] = DEFAULT_SEGMENT_S if args.segment is None else args.segment
        with reported_warnings("rx"):
            records = _live_reference_records(args, new_receiver, source, channels, emissions, settings)
            code = write_live(args, out, records, metadata, source, run, fields=REFERENCE_FIELDS,
                              keep_unmatched=True)
        _reference_notes(source, recording, emissions, None)
        return code
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PacketWarning)
        records = _reference_records(receiver, source.blocks(channels), channels=channels, source=source,
                                     emissions=emissions, settings=settings)
    for w in caught:
        print(f"seamodem rx: warning: {w.message}", file=sys.stderr)
    n = write_reference_records(out, records, metadata)
    _reference_notes(source, recording, emissions, n)
    if not args.quiet:
        per = {r.name: sum(rec.reference == r.name for rec in records) for r in receiver.references}
        listed = ", ".join(f"{k}: {v}" for k, v in per.items())
        print(f"wrote {out}: {n} detection{'s' if n != 1 else ''} ({listed}; {sound_speed_words(c, c_origin)})")
    return 0


def _reference_notes(source, recording: Path, emissions: dict, n: int | None) -> None:
    """The warnings after a run: clipping and silence, unknown emission times, nothing found (``n`` records;
    None: a stream, whose writer reported its count)."""
    for note in source.stats.notes(str(recording), source.sample_rate_hz):
        print(f"seamodem rx: warning: {note}", file=sys.stderr)
    if any(e is None for e in emissions.values()) and n != 0:
        print("seamodem rx: warning: emission times unknown for some references (no sidecar, no --emit-start): "
              "their tof_s and range_m are empty", file=sys.stderr)
    if n == 0:
        print(f"seamodem rx: warning: no reference found in {recording}", file=sys.stderr)
