"""``seamodem rx`` over several recordings, long recordings in segments, on processes or Dask.

The single-recording command stays in :mod:`seamodem.cli.rx`; it hands over
to :func:`run_batch` when given several recordings or any option below.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import SeamodemError
from ..io.files import check_writable
from .decode import PartFailure, Recording, decode_files

__all__ = ["add_batch_options", "wants_batch", "run_batch"]


def add_batch_options(p: argparse.ArgumentParser) -> None:
    """The batch options of ``seamodem rx`` (docs/batch.md)."""
    g = p.add_argument_group(
        "several or long recordings",
        "Given several recordings (e.g. a shell glob DIR/*.wav) or any of these options, the recordings "
        "are decoded in parallel into one file with a 'source' column: recordings in the order given, "
        "frames by arrival within each. Finished recordings and segments are kept in OUTPUT.parts/ "
        "until all succeed; the exit code is 1 if any failed.",
    )
    g.add_argument(
        "--segment",
        type=float,
        metavar="S",
        help="cut recordings longer than S seconds into overlapping segments decoded in parallel",
    )
    g.add_argument(
        "--overlap",
        type=float,
        metavar="S",
        help="samples added on each side of a segment [s] (default: a frame plus the detector's context, ~1 s)",
    )
    g.add_argument("--workers", type=int, metavar="N", help="local worker processes (default: the CPUs)")
    g.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://HOST:8786; needs pip install 'seamodem[dask]')",
    )
    g.add_argument(
        "--resume", action="store_true", help="reuse the finished parts of an earlier run (OUTPUT.parts/)"
    )


def wants_batch(args: argparse.Namespace) -> bool:
    """True when ``seamodem rx`` was given several recordings or a batch option."""
    return len(args.recording) > 1 or any(
        getattr(args, name) not in (None, False) for name in ("segment", "overlap", "workers", "scheduler", "resume")
    )


def run_batch(args: argparse.Namespace) -> int:
    """Decode every recording of ``args``; 0 when all succeeded, 1 when any failed."""
    from ..cli import rx
    from ..cli._common import command_line

    out = check_writable(args.output)
    if args.plot:
        raise SeamodemError("plot: figures are drawn for a single recording only (drop --plot, or give one file)")
    if args.workers is not None and args.workers < 1:
        raise SeamodemError(f"workers: must be >= 1, got {args.workers}")
    if args.turbo_passes < 1:
        raise SeamodemError(f"turbo-passes: must be >= 1, got {args.turbo_passes}")
    recordings, failures, described = [], [], []
    for path in args.recording:
        one = argparse.Namespace(**vars(args))
        one.recording = path
        try:
            inputs = rx._inputs(one)
        except SeamodemError as exc:
            failures.append(PartFailure(str(path), str(exc)))
            continue
        recordings.append(
            Recording(
                path,
                inputs.config,
                inputs.emissions,
                args.channel,
                {
                    "sound_speed_mps": inputs.sound_speed_mps,
                    "clock_offset_s": args.clock_offset,
                    "turnaround_s": one.turnaround,  # a two-way recording's sidecar may set it
                    "v_max_mps": args.v_max,
                    "false_alarms_per_hour": args.false_alarms_per_hour,
                    "pilot": inputs.pilot,
                    "decode": args.decode,
                    "turbo_passes": args.turbo_passes,
                    "payloads": inputs.payloads,
                },
            )
        )
        described.append(
            {"sample_rate_hz": inputs.info.samplerate, "sound_speed_mps": inputs.sound_speed_mps,
             "turnaround_s": one.turnaround, "config": inputs.config.to_dict()}
        )
    header = {
        "created_by": command_line(),
        "clock_offset_s": args.clock_offset,
        "decode": args.decode,
        "turbo_passes": args.turbo_passes,
        "segment_s": args.segment,
    }
    # what every recording shares goes in the header, as for a single recording
    for key in ("sample_rate_hz", "sound_speed_mps", "turnaround_s", "config"):
        values = [d[key] for d in described]
        if values and all(v == values[0] for v in values):
            header[key] = values[0]
    result = decode_files(
        recordings,
        segment_s=args.segment,
        overlap_s=args.overlap,
        output=out,
        header=header,
        resume=args.resume,
        backend="dask" if args.scheduler else "processes",
        workers=args.workers,
        scheduler=args.scheduler,
        progress=False if args.quiet else None,
        failed=failures,
    )
    for note in dict.fromkeys(result.warnings):
        print(f"seamodem rx: warning: {note}", file=sys.stderr)
    for f in result.failures:
        print(f"seamodem rx: failed: {f.label}: {f.error}", file=sys.stderr)
    n = len(result.records)
    if not args.quiet:
        line = (
            f"wrote {out}: {n} frame{'s' if n != 1 else ''} from {len(recordings)} recording"
            f"{'s' if len(recordings) != 1 else ''} ({result.n_parts} parts"
            + (f", {result.n_resumed} from an earlier run" if result.n_resumed else "")
            + ")"
        )
        print(line)
        if result.failures:
            print(f"{len(result.failures)} failed (listed above); finished parts kept in {out.name}.parts/ for --resume")
    return 0 if result.ok else 1
