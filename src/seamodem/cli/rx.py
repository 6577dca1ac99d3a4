"""``seamodem rx``: measure every frame of a recording (range, radial speed, SNR)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..batch.cli import add_batch_options, run_batch, wants_batch
from ..errors import InputFileError, SeamodemError
from ..io.files import atomic_outputs, check_writable
from ..io.sidecar import read_sidecar, sidecar_path, sidecar_payloads, sidecar_pilot_bits
from ..io.wav import wav_channel
from ..receive.receiver import Emissions, ReceiverWarning, receive_file
from ..receive.records import write_measurements
from ._common import add_config_options, command_line, config_from_args

DEFAULT_SOUND_SPEED_MPS = 1500.0


def add_parser(sub) -> None:
    p = sub.add_parser(
        "rx",
        help="measure range and radial speed of every frame in a recording",
        description=(
            "Detect every frame in RECORDING and write one measurement record per frame "
            "(frame_index, t_emit_s, t_arrival_s, tof_s, range_m, v_r_mps, snr_db, ...) to a .csv or "
            ".jsonl file. Emission times come from the sidecar (--config SIDECAR.json, or the "
            "recording's own .json), or from --emit-start/--emit-period."
        ),
    )
    p.add_argument(
        "recording",
        nargs="+",
        metavar="RECORDING",
        help="audio file (WAV...), any sample rate holding the band; several: decoded in parallel into one output",
    )
    add_config_options(p)
    p.add_argument("-o", "--output", required=True, metavar="MEAS", help="output .csv or .jsonl")
    p.add_argument("--emit-start", type=float, metavar="T0", help="emission time of frame 0 [s] (PPS beacon)")
    p.add_argument("--emit-period", type=float, metavar="TCOM", help="time between emissions [s]")
    p.add_argument("--sound-speed", type=float, metavar="M/S", help="c (default: the sidecar's, else 1500 m/s)")
    p.add_argument("--clock-offset", type=float, default=0.0, metavar="S", help="receiver minus beacon clock [s]")
    p.add_argument(
        "--turnaround",
        type=float,
        metavar="S",
        help="two-way ranging: the beacon's reply delay [s]; emission times are then the vehicle's polls",
    )
    p.add_argument("--channel", type=int, help="channel of a multichannel recording (0-based)")
    p.add_argument("--v-max", type=float, default=5.0, metavar="M/S", help="largest |v_r| searched (default 5 m/s)")
    p.add_argument(
        "--false-alarms-per-hour",
        type=float,
        default=0.01,
        metavar="RATE",
        help="detector design false-alarm rate in white noise (default 0.01 per hour)",
    )
    p.add_argument(
        "--no-decode",
        dest="decode",
        action="store_false",
        help="measure only: skip equalising and decoding the payloads",
    )
    p.add_argument(
        "--turbo-passes",
        type=int,
        default=3,
        metavar="N",
        help="most equaliser passes per frame; turbo passes run while the CRC fails (default 3; 1 = DFE only)",
    )
    p.add_argument("--plot", metavar="DIR", help="write figures of the first --plot-frames frames to DIR")
    p.add_argument("--plot-frames", type=int, default=3, metavar="N", help="frames to plot (default 3)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    add_batch_options(p)
    p.set_defaults(run=run)


def _sidecar_for(args) -> dict | None:
    """The sidecar named by --config (if it is one), else the recording's own, else None.

    A --config that is a preset or a plain configuration file still takes the
    emission times, pilot and payloads from the recording's own sidecar when
    one lies beside it.
    """
    if args.config:
        path = Path(args.config)
        if path.suffix.lower() == ".json" and path.is_file():
            try:
                data = json.loads(path.read_text(encoding="utf-8"))
            except json.JSONDecodeError:
                return None  # load_config reports it with the file name
            if isinstance(data, dict) and "format" in data:
                return read_sidecar(path)
    own = sidecar_path(args.recording)
    return read_sidecar(own) if own.is_file() and own != Path(args.recording) else None


def _emissions(args, sidecar, duration_s: float) -> Emissions:
    if args.emit_start is not None or args.emit_period is not None:
        if args.emit_start is None or args.emit_period is None:
            raise SeamodemError("emit-start: --emit-start and --emit-period go together")
        return Emissions(start_s=args.emit_start, period_s=args.emit_period)
    if sidecar is None:
        raise SeamodemError(
            "emission times unknown: give --config SIDECAR.json, put the sidecar beside the recording, "
            "or use --emit-start and --emit-period"
        )
    try:
        times = np.array([float(f["t_emit_s"]) for f in sidecar["frames"]])
    except (KeyError, TypeError, ValueError):
        raise InputFileError("sidecar: its 'frames' list lacks valid t_emit_s values") from None
    if times.size == 0:
        raise InputFileError("sidecar: lists no frames")
    if times[0] - args.clock_offset >= duration_s:
        raise InputFileError(
            f"sidecar does not match {args.recording}: its first emission is at {times[0]:g} s, "
            f"after the recording's end at {duration_s:g} s"
        )
    return Emissions(times_s=times)


class _Inputs(NamedTuple):
    """What the receiver of one recording needs, from the options and the sidecar."""

    info: object
    sidecar: dict | None
    config: object
    emissions: Emissions
    pilot: np.ndarray | None
    payloads: list | None
    sound_speed_mps: float


def _inputs(args: argparse.Namespace) -> _Inputs:
    """Header, sidecar, configuration, emissions, pilot, payloads and c of ``args.recording``."""
    info, _ = wav_channel(args.recording, channel=args.channel)
    sidecar = _sidecar_for(args)
    if sidecar is not None and not args.config:
        args.config = str(sidecar_path(args.recording))
    config = config_from_args(args)
    emissions = _emissions(args, sidecar, info.frames / info.samplerate)
    pilot = None
    bits = sidecar_pilot_bits(sidecar) if sidecar is not None else None
    if bits is not None and bits.size == config.n_pilot:
        pilot = (1.0 - 2.0 * bits).astype(complex)
    two_way = ((sidecar or {}).get("channel") or {}).get("two_way")
    if two_way and args.turnaround is None and args.emit_start is None:
        # a two-way exchange (seamodem channel with [two_way]): its frames' t_emit_s are the polls
        args.turnaround = float(two_way["turnaround_s"])
        if not args.quiet:
            print(f"two-way recording: turnaround {args.turnaround:g} s from its sidecar")
    # an older or hand-made sidecar without payloads: decode without counting bit errors
    payloads = sidecar_payloads(sidecar) if sidecar is not None and args.decode else None
    sound_speed = args.sound_speed
    if sound_speed is None:
        sound_speed = float((sidecar or {}).get("channel", {}).get("sound_speed_mps", DEFAULT_SOUND_SPEED_MPS))
    if not (math.isfinite(sound_speed) and sound_speed > 0):
        raise SeamodemError(f"sound-speed: must be a positive number of m/s, got {sound_speed!r}")
    return _Inputs(info, sidecar, config, emissions, pilot, payloads, sound_speed)


def run(args: argparse.Namespace) -> int:
    if wants_batch(args):
        return run_batch(args)
    args.recording = args.recording[0]
    out = check_writable(args.output)
    if out.suffix.lower() not in (".csv", ".jsonl"):
        raise SeamodemError(f"output: must end in .csv or .jsonl, got {str(out)!r}")
    if args.turbo_passes < 1:
        raise SeamodemError(f"turbo-passes: must be >= 1, got {args.turbo_passes}")
    info, _, config, emissions, pilot, payloads, sound_speed = _inputs(args)
    if args.plot:
        plot_dir = Path(args.plot)
        if not plot_dir.is_dir():
            raise SeamodemError(f"plot: folder {plot_dir} does not exist")
    on_frame = _plotter(args, config, pilot, sound_speed) if args.plot else None
    header = {
        "created_by": command_line(),
        "recording": str(args.recording),
        "sample_rate_hz": info.samplerate,
        "sound_speed_mps": sound_speed,
        "clock_offset_s": args.clock_offset,
        "turnaround_s": args.turnaround,
        "decode": args.decode,
        "turbo_passes": args.turbo_passes,
        "config": config.to_dict(),
    }
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ReceiverWarning)
        records = receive_file(
            args.recording,
            config,
            emissions=emissions,
            channel=args.channel,
            progress=False if args.quiet else None,
            sound_speed_mps=sound_speed,
            clock_offset_s=args.clock_offset,
            turnaround_s=args.turnaround,
            v_max_mps=args.v_max,
            false_alarms_per_hour=args.false_alarms_per_hour,
            pilot=pilot,
            on_frame=on_frame,
            decode=args.decode,
            turbo_passes=args.turbo_passes,
            payloads=payloads,
        )
        with atomic_outputs(out) as (tmp,):
            counted = _Counted(records)
            n = write_measurements(tmp, counted, header, kind=out.suffix.lower().lstrip("."))
    for w in caught:
        if issubclass(w.category, ReceiverWarning):
            print(f"seamodem rx: warning: {w.message}", file=sys.stderr)
    if not args.quiet:
        print(f"wrote {out}: {n} frame{'s' if n != 1 else ''} measured (c = {sound_speed:g} m/s)")
        if args.decode and counted.decoded:
            line = f"payloads: {counted.crc_ok} of {counted.decoded} decoded frames pass the CRC"
            if counted.ber_frames:
                line += f"; bit error rate {counted.ber_sum / counted.ber_frames:.2e} after decoding"
            print(line)
    return 0


class _Counted:
    """Pass records through, counting decoded frames, CRC passes and bit errors."""

    def __init__(self, records):
        self.records = records
        self.decoded = self.crc_ok = self.ber_frames = 0
        self.ber_sum = 0.0

    def __iter__(self):
        for rec in self.records:
            if rec.crc_ok is not None:
                self.decoded += 1
                self.crc_ok += int(rec.crc_ok)
            if math.isfinite(rec.ber):
                # every frame carries the same information block: the mean of the ber is the bit error rate
                self.ber_frames += 1
                self.ber_sum += rec.ber
            yield rec


def _plotter(args, config, pilot, sound_speed):
    """on_frame callback that saves a figure of each of the first --plot-frames frames."""
    from ..receive.plots import plot_frame
    from ..transmit.pilot import pilot_symbols

    symbols = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else pilot
    count = [0]

    def on_frame(m, bb, t0_s, fs):
        if count[0] >= args.plot_frames:
            return
        count[0] += 1
        path = Path(args.plot) / f"frame_{count[0] - 1:04d}_{m.pilot.t_start_s:.3f}s.png"
        plot_frame(
            path, m, bb, fs=fs, t0_s=t0_s, config=config, pilot=symbols, sound_speed_mps=sound_speed
        )

    return on_frame
