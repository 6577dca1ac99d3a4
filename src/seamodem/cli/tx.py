"""``seamodem tx``: write a beacon's frames to a WAV file and its sidecar."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..config import DEFAULT_PAYLOAD_TEXT
from ..errors import InputFileError
from ..io.wav import SUBTYPES
from ._common import add_config_options, command_line, config_from_args, output_path


def add_parser(sub) -> None:
    p = sub.add_parser(
        "tx",
        help="generate a beacon recording (WAV + JSON sidecar)",
        description=(
            "Write COUNT frames emitted every PERIOD seconds into OUT.wav, with OUT.json beside it "
            "(configuration, pilot, emission times, payloads, WAV scaling). Frame k's first sample "
            "is at START + k·PERIOD on the recording's clock."
        ),
    )
    add_config_options(p)
    p.add_argument("--count", type=int, help="number of frames (default 10, or as many as --payload-file needs)")
    p.add_argument("--period", type=float, default=3.0, metavar="SECONDS", help="T_com between emissions (default 3 s)")
    p.add_argument("--start", type=float, default=0.0, metavar="SECONDS", help="emission time of the first frame (default 0)")
    payload = p.add_mutually_exclusive_group()
    payload.add_argument(
        "--payload-text",
        metavar="TEXT",
        help=f"UTF-8 text sent in every frame; {{index}} becomes the frame index (default {DEFAULT_PAYLOAD_TEXT!r})",
    )
    payload.add_argument("--payload-file", metavar="FILE", help="bytes split over consecutive frames")
    p.add_argument("--format", choices=sorted(SUBTYPES), default="float32", help="WAV sample format (default float32)")
    p.add_argument("--peak", type=float, default=0.5, help="largest |sample| as a fraction of full scale (default 0.5)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.wav", help="output WAV; the sidecar is OUT.json")
    ref = p.add_argument_group(
        "reference waveforms (docs/references.md)",
        "Instead of seamodem frames, emit known pings: reference i of n at START + k·PERIOD + i·PERIOD/n "
        "(and its postamble, if it has one). The sidecar records the references and every emission.",
    )
    ref.add_argument(
        "--reference",
        action="append",
        metavar="SPEC",
        help="lfm:F1-F2:DURATION, hfm:F1-F2:DURATION, pn:CARRIER:CHIPRATE:DEGREE, template:FILE[:START-STOP], "
        "or a TOML/JSON file (repeatable)",
    )
    ref.add_argument("--sample-rate", type=float, default=96000.0, metavar="HZ", help="WAV rate for references (default 96000)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    from .janus import add_tx_options  # --janus: JANUS packets

    add_tx_options(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.janus:
        from .janus import run_tx

        return run_tx(args)
    if args.reference:
        return _run_references(args)
    from ..transmit.beacon import BeaconSchedule, payloads_from_bytes, payloads_from_text, write_beacon

    out = output_path(args.output, ".wav")
    config = config_from_args(args)
    if args.payload_file:
        path = Path(args.payload_file)
        if not path.is_file():
            raise InputFileError(f"payload file not found: {path}")
        payloads = payloads_from_bytes(path.read_bytes(), config.capacity_bytes, args.count)
        count = len(payloads)
    else:
        count = 10 if args.count is None else args.count
        payloads = payloads_from_text(args.payload_text or DEFAULT_PAYLOAD_TEXT, count)
    schedule = BeaconSchedule(count=count, period_s=args.period, start_s=args.start)
    sidecar = write_beacon(
        out,
        config,
        schedule,
        payloads,
        subtype=SUBTYPES[args.format],
        peak=args.peak,
        command=command_line(),
        progress=False if args.quiet else None,
    )
    if not args.quiet:
        rec = sidecar["recording"]
        print(
            f"wrote {out} ({count} frames of {config.frame_duration_s * 1e3:.1f} ms, {rec['duration_s']:.2f} s at "
            f"{rec['sample_rate_hz']} Hz, {args.format}) and {out.with_suffix('.json')}; "
            f"capacity {config.capacity_bytes} bytes/frame"
        )
    return 0


def _run_references(args: argparse.Namespace) -> int:
    """``--reference``: a beacon schedule of reference pings."""
    from ..transmit.reference import load_references, reference_replica, write_reference_beacon

    out = output_path(args.output, ".wav")
    if args.payload_text or args.payload_file:
        raise InputFileError("payload: reference pings carry no payload (drop --payload-text/--payload-file)")
    refs = [r for spec in args.reference for r in load_references(spec)]
    sidecar = write_reference_beacon(
        out,
        [reference_replica(r) for r in refs],
        count=10 if args.count is None else args.count,
        period_s=args.period,
        start_s=args.start,
        fs=args.sample_rate,
        subtype=SUBTYPES[args.format],
        peak=args.peak,
        command=command_line(),
    )
    if not args.quiet:
        rec = sidecar["recording"]
        names = ", ".join(r.name for r in refs)
        print(
            f"wrote {out} ({len(sidecar['frames'])} emissions of {names}, {rec['duration_s']:.2f} s at "
            f"{rec['sample_rate_hz']:g} Hz, {args.format}) and {out.with_suffix('.json')}"
        )
    return 0
