"""``seamodem rx``: measure every frame of one or many recordings (range, radial speed, SNR, payload).

One recording streams through :func:`~seamodem.receive.recording.receive_file`;
several, or any of the batch options, go through
:func:`~seamodem.batch.decode.decode_files` (segments, processes or Dask) into
one file with a ``source`` column. Both build one
:class:`~seamodem.receive.settings.ReceiverSettings` per recording from the
options and its sidecar, and write the same header.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import warnings
from pathlib import Path
from typing import NamedTuple

from ..errors import ConfigError, InputFileError, SeamodemError
from ..io.files import check_writable
from ._common import (
    add_config_options,
    add_profile_option,
    command_line,
    config_from_args,
    emit_schedule,
    reported_warnings,
    sound_speed,
    sound_speed_profile,
    sound_speed_words,
)

#: the options that make ``seamodem rx`` a batch decode even for one recording
BATCH_OPTIONS = ("segment", "overlap", "workers", "scheduler", "resume")


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
        nargs="*",
        metavar="RECORDING",
        help="audio file (WAV...), any sample rate holding the band; several: decoded in parallel into one output; "
             "'-', a FIFO or /dev/stdin: a live stream (docs/live.md)",
    )
    add_config_options(p)
    p.add_argument("-o", "--output", required=True, metavar="MEAS", help="output .csv or .jsonl; '-': stdout, live")
    p.add_argument("--emit-start", type=float, metavar="T0", help="emission time of frame 0 [s] (PPS beacon)")
    p.add_argument("--emit-period", type=float, metavar="TCOM", help="time between emissions [s]")
    p.add_argument("--sound-speed", type=float, metavar="M/S",
                   help="c (default: the recording's sidecar's, else 1500 m/s; 1400-1600 m/s unless forced)")
    p.add_argument("--force-sound-speed", action="store_true",
                   help="accept a --sound-speed (or sidecar value) outside 1400-1600 m/s")
    g = p.add_argument_group("sound-speed profile")
    add_profile_option(g, what="range_m becomes the straight-line distance of the direct ray traced through it, "
                               "horizontal_range_m its horizontal range, c for Doppler the profile's at the vehicle "
                               "(needs --beacon-depth and --vehicle-depth; with the depths alone, a simulated "
                               "recording's [water] profile from its sidecar)")
    g.add_argument("--beacon-depth", type=float, metavar="M",
                   help="beacon depth [m]: the ray's end with --sound-speed-profile; with --vehicle-depth, also (alone "
                        "too) a surface image merged with the direct path: its bias on the arrival predicted and "
                        "taken out, the σ what the waves and the reflection leave of it")
    g.add_argument("--vehicle-depth", type=float, metavar="M", help="vehicle depth [m] (as --beacon-depth)")
    g.add_argument("--vehicle-depth-log", metavar="DEPTH.csv",
                   help="in place of --vehicle-depth for a vehicle that changes depth: its depth log (columns t_s "
                        "on the recording's clock and depth_m, as nav track --depth-log), each frame taking the "
                        "depth at its arrival")
    g.add_argument("--wave-amplitude", type=float, default=0.5, metavar="M",
                   help="with the depths: the waves' amplitude [m] (half their height) that the merged surface "
                        "image rides, in its σ's")
    g.add_argument("--wave-period", type=float, default=3.0, metavar="S",
                   help="with the depths: the waves' shortest period [s]")
    g.add_argument("--no-echo-geometry", dest="echo_geometry", action="store_false",
                   help="without the depths, do not take them from the echoes the decoded frames resolve (the "
                        "bottom and surface-bottom images of a flat waveguide: the merged surface image's bias then "
                        "stays in the range, covered only as far as the channel's bend shows it)")
    p.add_argument("--clock-offset", type=float, default=0.0, metavar="S", help="receiver minus beacon clock [s]")
    p.add_argument(
        "--turnaround",
        type=float,
        metavar="S",
        help="two-way ranging: the beacon's reply delay [s]; emission times are then the vehicle's polls",
    )
    p.add_argument("--channel", type=int, help="channel of a multichannel recording, numbered from 0")
    p.add_argument("--array", metavar="SPEC", help="all channels as a hydrophone array (as seamodem channel --array): "
                   "direction of arrival per frame, combined decoding (docs/array.md)")
    p.add_argument("--v-max", type=float, default=5.0, metavar="M/S", help="largest |v_r| searched (default 5 m/s)")
    p.add_argument("--lookahead", type=int, metavar="FRAMES",
                   help="frames measured after a record before it is written (default 5; live: 0): its range σ then "
                        "also covers a merged echo's bend that those frames show and its gap to their track, and its "
                        "v_r σ its gap to their ranges")
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
        "--no-blanking",
        dest="blank_impulses",
        action="store_false",
        help="keep impulses (clicks): no median/MAD impulse blanking of the input before the receiver",
    )
    p.add_argument(
        "--turbo-passes",
        type=int,
        default=3,
        metavar="N",
        help="most equaliser passes per frame; turbo passes run while the CRC fails (default 3; 1 = DFE only)",
    )
    p.add_argument("--plot", metavar="DIR", help="write figures of the first --plot-frames frames to DIR (created)")
    p.add_argument("--plot-frames", type=int, default=3, metavar="N", help="frames to plot (default 3)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    _add_batch_options(p)
    from .rx_live import add_live_options  # '-', FIFOs, raw PCM, a sound card

    add_live_options(p)
    p.set_defaults(run=run)
    from .rx_reference import add_reference_options  # --reference: ranging on other waveforms

    add_reference_options(p)
    from .janus import add_rx_options  # --janus: JANUS packets

    add_rx_options(p)


def _add_batch_options(p: argparse.ArgumentParser) -> None:
    """The options for several or long recordings (docs/batch.md)."""
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
        help="cut recordings longer than S seconds into overlapping segments decoded in parallel; a live stream "
             "with --array or --reference: new seconds between two runs of the receiver, so the most a record "
             "waits after its frame (default 5 s, docs/live.md)",
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


def _sidecar_for(config_option: str | None, recording: str) -> tuple[dict | None, bool]:
    """The sidecar named by --config (if it is one), else the recording's own, else None; and whether it is the own.

    A --config that is a preset or a plain configuration file still takes the
    emission times, pilot and payloads from the recording's own sidecar when
    one lies beside it.
    """
    from ..io.sidecar import read_sidecar, sidecar_path

    if config_option:
        path = Path(config_option)
        if path.suffix.lower() == ".json" and path.is_file():
            try:
                data = json.loads(path.read_text(encoding="utf-8"))
            except json.JSONDecodeError:
                return None, False  # load_config reports it with the file name
            if isinstance(data, dict) and "format" in data:
                return read_sidecar(path), False
    own = sidecar_path(recording)
    return (read_sidecar(own), True) if own.is_file() and own != Path(recording) else (None, False)


def _frame_emissions(args, recording: str, sidecar, duration_s: float):
    """--emit-start/--emit-period, else the sidecar's emission times (checked against the recording)."""
    import numpy as np

    from ..receive.settings import Emissions

    given = emit_schedule(args)
    if given is not None:
        return given
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
    if duration_s is not None and times[0] - args.clock_offset >= duration_s:
        raise InputFileError(
            f"sidecar does not match {recording}: its first emission is at {times[0]:g} s, "
            f"after the recording's end at {duration_s:g} s"
        )
    return Emissions(times_s=times)


def _depth_log(args):
    """--vehicle-depth-log's (times, depths); None without it."""
    path = getattr(args, "vehicle_depth_log", None)
    if path is None:
        return None
    if args.vehicle_depth is not None:
        raise SeamodemError("vehicle-depth-log: give --vehicle-depth or --vehicle-depth-log, not both")
    from ..navigation.logs import read_depth

    log = read_depth(path, what="vehicle depth log")
    return log["t_s"], log["depth_m"]


def _vehicle_depth_given(args) -> bool:
    return args.vehicle_depth is not None or getattr(args, "vehicle_depth_log", None) is not None


def _water_profile(args, profile, sidecar: dict | None):
    """The profile of --sound-speed-profile, else (with both depths given) the simulated recording's sidecar's."""
    beacon, vehicle = args.beacon_depth is not None, _vehicle_depth_given(args)
    if profile is None and not (beacon or vehicle):
        return None
    if not (beacon and vehicle):
        raise SeamodemError("sound-speed-profile: needs --beacon-depth and --vehicle-depth (the ray joins the two)")
    if profile is None:
        traced = (((sidecar or {}).get("channel") or {}).get("model") or {}).get("sound_speed_profile")
        if traced is None:
            return None  # the depths alone: a straight ray at c, and the merged surface image's σ term
        from ..water import SoundSpeedProfile

        profile = SoundSpeedProfile.from_dict(traced, where="sidecar channel.model.sound_speed_profile")
    return profile


def _settings(args, sidecar: dict | None, profile=None):
    """The options (and the sidecar's channel section) as the receiver's settings, built here once, and
    where their sound speed came from (with a profile and no --sound-speed: the profile's c at the vehicle)."""
    from ..receive.settings import ReceiverSettings

    channel = (sidecar or {}).get("channel") or {}
    turnaround = args.turnaround
    two_way = channel.get("two_way")
    if two_way and turnaround is None and args.emit_start is None:
        # a two-way exchange (seamodem channel with [two_way]): its frames' t_emit_s are the polls
        turnaround = float(two_way["turnaround_s"])
        if not args.quiet:
            print(f"two-way recording: turnaround {turnaround:g} s from its sidecar")
    c, origin = sound_speed(args, sidecar)
    log = _depth_log(args)
    if profile is not None and args.sound_speed is None:
        if log is None:
            c, origin = float(profile.c(args.vehicle_depth)), f"sound-speed profile at the vehicle's {args.vehicle_depth:g} m"
        else:
            depth = statistics.median(log[1])
            c, origin = float(profile.c(depth)), f"sound-speed profile at the vehicle's median depth {depth:g} m"
    return ReceiverSettings(
        sound_speed_mps=c,
        clock_offset_s=args.clock_offset,
        turnaround_s=turnaround,
        v_max_mps=args.v_max,
        false_alarms_per_hour=args.false_alarms_per_hour,
        decode=args.decode,
        turbo_passes=args.turbo_passes,
        blank_impulses=args.blank_impulses,
        # the depths give the arrival's σ its merged-surface-image term (with or without a profile)
        beacon_depth_m=args.beacon_depth,
        vehicle_depth_m=args.vehicle_depth,
        vehicle_depth_log=log,
        wave_amplitude_m=getattr(args, "wave_amplitude", 0.5),
        wave_period_s=getattr(args, "wave_period", 3.0),
        echo_geometry=getattr(args, "echo_geometry", True),
        **({} if getattr(args, "lookahead", None) is None else {"lookahead_frames": args.lookahead}),
    ), origin


class _Inputs(NamedTuple):
    """What the receiver of one recording needs: the open recording, and what the options and its sidecar say."""

    path: str
    source: object
    config: object
    emissions: object
    settings: object
    pilot: object
    payloads: list | None
    sound_speed_origin: str
    profile: object = None


def _inputs(args: argparse.Namespace, recording: str, source=None) -> _Inputs:
    """The recording (opened once, or the live ``source`` given), its configuration, emissions, receiver settings,
    pilot and payloads."""
    from ..io.sidecar import sidecar_path, sidecar_payloads, sidecar_pilot_bits
    from ..io.source import open_recording

    # a .mat recording: its variable and, when it holds none, its rate (the same options as --reference)
    profile = sound_speed_profile(args)
    if source is None:
        source = open_recording(recording, mat_variable=getattr(args, "mat_variable", None),
                                sample_rate_hz=getattr(args, "sample_rate", None))
    source.one_channel(0 if args.array else args.channel)
    sidecar, own = _sidecar_for(args.config, recording)
    profile = _water_profile(args, profile, sidecar)
    config = config_from_args(args, config_file=str(sidecar_path(recording)) if own else None)
    emissions = _frame_emissions(args, recording, sidecar, source.duration_s)
    pilot = None
    bits = sidecar_pilot_bits(sidecar) if sidecar is not None else None
    if bits is not None and bits.size == config.n_pilot:
        pilot = (1.0 - 2.0 * bits).astype(complex)
    settings, origin = _settings(args, sidecar, profile)
    log = settings.vehicle_depth_log
    duration = source.duration_s
    if log is not None and duration and (log[0][0] > 0.0 or log[0][-1] < duration):
        warnings.warn(f"vehicle depth log {args.vehicle_depth_log} covers {log[0][0]:g}-{log[0][-1]:g} s of the "
                      f"recording's 0-{duration:g} s: its first and last depths are held outside it", UserWarning,
                      stacklevel=2)
    # an older or hand-made sidecar without payloads: decode without counting bit errors
    payloads = sidecar_payloads(sidecar) if sidecar is not None and settings.decode else None
    return _Inputs(recording, source, config, emissions, settings, pilot, payloads, origin, profile)


def _described(inputs: _Inputs) -> dict:
    """What the receiver of one recording was told: its rate, every setting, the frame configuration."""
    fs = inputs.source.sample_rate_hz
    return {
        "sample_rate_hz": int(fs) if float(fs).is_integer() else fs,  # an audio file's rate is an integer
        **inputs.settings.to_dict(),
        "config": inputs.config.to_dict(),
    }


def _header(inputs: list[_Inputs], *, segment_s: float | None = None, batch: bool = False) -> dict:
    """The measurement file's header: the command, and what the receiver was told (shared by all, for a batch)."""
    described = [_described(i) for i in inputs]
    if not batch:
        return {"created_by": command_line(), "recording": str(inputs[0].path), **described[0]}
    header = {"created_by": command_line()}
    # what every recording shares goes in the header, as for a single recording
    for key in described[0] if described else ():
        values = [d[key] for d in described]
        if all(v == values[0] for v in values):
            header[key] = values[0]
    return header | {"segment_s": segment_s}


def run(args: argparse.Namespace) -> int:
    from .rx_live import check_live_options, live_requested

    if not args.recording and args.device is None:
        raise SeamodemError("recording: give a RECORDING ('-' for stdin) or --device")
    if live_requested(args):
        check_live_options(args)
        out = None if args.output == "-" else check_writable(args.output)
        if out is not None and out.suffix.lower() not in (".csv", ".jsonl"):
            raise SeamodemError(f"output: must end in .csv or .jsonl, or be '-' (stdout), got {str(out)!r}")
        return _run_one(args, out, live=True)
    batch = len(args.recording) > 1 or any(getattr(args, name) not in (None, False) for name in BATCH_OPTIONS)
    out = check_writable(args.output)
    if out.suffix.lower() not in (".csv", ".jsonl"):
        raise SeamodemError(f"output: must end in .csv or .jsonl, got {str(out)!r}")
    if batch and args.array:
        raise SeamodemError("array: a hydrophone array is received from a single recording (give one file)")
    if batch and (args.sound_speed_profile or args.beacon_depth is not None or _vehicle_depth_given(args)):
        raise SeamodemError("sound-speed-profile: applied to a single recording only (give one file)")
    if batch and args.plot:
        raise SeamodemError("plot: figures are drawn for a single recording only (drop --plot, or give one file)")
    if args.workers is not None and args.workers < 1:
        raise SeamodemError(f"workers: must be >= 1, got {args.workers}")
    if args.turbo_passes < 1:
        raise SeamodemError(f"turbo-passes: must be >= 1, got {args.turbo_passes}")
    if args.plot and Path(args.plot).exists() and not Path(args.plot).is_dir():
        raise SeamodemError(f"plot: {args.plot} exists and is not a folder")
    return (_run_many if batch else _run_one)(args, out)


def _run_one(args: argparse.Namespace, out: Path | None, *, live: bool = False) -> int:
    """One recording, streamed: records are written as frames are found (live: each flushed as it is measured)."""
    from contextlib import nullcontext

    from .rx_live import LiveRun, live_settings, open_live_input, warm_up, write_live

    with reported_warnings("rx"), (LiveRun() if live else nullcontext()) as run:
        if live:
            run.warm_up = warm_up(args)  # while the producer starts
        source = open_live_input(args, run.event) if live else None
        # before the receiver's imports: a bad input fails at once
        inputs = _inputs(args, args.recording[0] if args.recording else f"device {args.device}", source)
        if live:
            inputs = inputs._replace(settings=live_settings(inputs.settings, args))

        from ..receive.recording import receive_file
        from ..receive.records import write_measurements
        from ._array import array_header, array_records, load_array

        header = _header([inputs])
        if args.plot:
            Path(args.plot).mkdir(parents=True, exist_ok=True)
        if args.array:
            array = load_array(args.array)
            records = array_records(array, inputs, segment_s=args.segment if live else None)
            header |= array_header(array, args.array)
            if live:  # received in segments of the stream (batch.live)
                from ..batch.live import DEFAULT_SEGMENT_S

                header |= {"segment_s": DEFAULT_SEGMENT_S if args.segment is None else args.segment}
        else:
            on_frame = _plotter(Path(args.plot), args.plot_frames, inputs) if args.plot else None
            records = receive_file(inputs.source, inputs.config, emissions=inputs.emissions, settings=inputs.settings,
                                   channel=args.channel, pilot=inputs.pilot, payloads=inputs.payloads,
                                   on_frame=on_frame, progress=False if args.quiet or live else None)
        if inputs.profile is not None:
            records = _along_the_ray(records, inputs, args)
            header |= {"sound_speed_profile": inputs.profile.to_dict(), "beacon_depth_m": args.beacon_depth,
                       "vehicle_depth_m": args.vehicle_depth,
                       "range_m": "straight-line distance of the direct ray traced through the profile"}
        if getattr(args, "vehicle_depth_log", None) is not None:
            header["vehicle_depth_log_file"] = args.vehicle_depth_log  # (its samples: vehicle_depth_log)
        if live:
            return write_live(args, out, records, header, inputs.source, run)
        counted = _Counted(records)
        try:
            n = write_measurements(out, counted, header)
        except ConfigError as exc:  # what the recording cannot hold (its rate, its band): name it
            raise exc.in_file(f"recording {inputs.path}") from None
        _warn_unmatched(counted.unmatched)
    if not args.quiet:
        print(f"wrote {out}: {n} frame{'s' if n != 1 else ''} measured ({sound_speed_words(inputs.settings.sound_speed_mps, inputs.sound_speed_origin)})"
              + (f"; {len(counted.unmatched)} arrival(s) before the first emission not written"
                 if counted.unmatched else ""))
        if args.decode and counted.decoded:
            line = f"payloads: {counted.crc_ok} of {counted.decoded} decoded frames pass the CRC"
            if counted.ber_frames:
                line += f"; bit error rate {counted.ber_sum / counted.ber_frames:.2e} after decoding"
            print(line)
        if args.beacon_depth is None or not _vehicle_depth_given(args):
            note = lloyd_mirror_note(counted.ranges_m, counted.sigmas_m, inputs.config,
                                     sound_speed_mps=inputs.settings.sound_speed_mps)
            if note:
                print(note)
    return 0


#: the shallowest a modem's transducer is taken to be [m] (a hull, a mooring) for :func:`lloyd_mirror_note`
_SHALLOWEST_END_M = 1.5


def lloyd_mirror_note(ranges_m, sigmas_m, config, *, sound_speed_mps: float) -> str:
    """A note for ranges measured without the ends' depths, or '' when none is due.

    At range R a surface image arrives δ = 2·z_b·z_v/(R·c) after the direct path; below the resolution
    1/B (z_b·z_v < R·c/(2B)) it merges with it and makes the range about 0.45·δ·c = 0.9·z_b·z_v/R long
    (docs/receiver.md), unseen at the SNRs where the channel's curvature stays within its noise. With
    the depths it is taken out (``--beacon-depth``, ``--vehicle-depth``), and so it is where the decoded
    frames' echoes give them (``ReceiverSettings.echo_geometry``: a flat waveguide's bottom and
    surface–bottom images resolved); otherwise the note says for which depth products that bias exceeds 3
    of the median σ, when there are any.

    >>> from seamodem import get_preset
    >>> print(lloyd_mirror_note([900.0], [0.001], get_preset("jmse2024"), sound_speed_mps=1500.0))
    ... # doctest: +NORMALIZE_WHITESPACE
    note: ranges measured without the ends' depths (--beacon-depth, --vehicle-depth or --vehicle-depth-log): at
    the median range of 900 m, a surface image merged with the direct path (Lloyd's mirror) makes the range about 0.9·z_b·z_v/R
    long, beyond 3 of the median σ (1 mm) for depths whose product is 3-75 m² (both ends 1.7-8.7 m
    deep), and the σ does not include it unless the decoded frames' echoes gave the depths (docs/receiver.md)
    >>> lloyd_mirror_note([15.0], [0.001], get_preset("jmse2024"), sound_speed_mps=1500.0)
    ''
    """
    if not ranges_m:
        return ""
    r, s = statistics.median(ranges_m), statistics.median(sigmas_m)
    low, high = max(3 * s * r / 0.9, _SHALLOWEST_END_M**2), r * sound_speed_mps / (2 * config.bandwidth_hz)
    if not low < high:
        return ""
    return (f"note: ranges measured without the ends' depths (--beacon-depth, --vehicle-depth or --vehicle-depth-log): "
            f"at the median range "
            f"of {r:.3g} m, a surface image merged with the direct path (Lloyd's mirror) makes the range about "
            f"0.9·z_b·z_v/R long, beyond 3 of the median σ ({s * 1e3:.2g} mm) for depths whose product is "
            f"{low:.2g}-{high:.2g} m² (both ends {math.sqrt(low):.2g}-{math.sqrt(high):.2g} m deep), and the σ "
            "does not include it unless the decoded frames' echoes gave the depths (docs/receiver.md)")


def _along_the_ray(records, inputs: _Inputs, args):
    """Each record's tof_s turned into ranges along the ray traced through the profile (σ carried over)."""
    import dataclasses

    from ..water.ranging import ProfileRanging

    c_max = float(inputs.profile.c_mps.max())
    s = inputs.settings
    log = s.vehicle_depth_log
    ranging = ProfileRanging(inputs.profile, args.beacon_depth, [args.vehicle_depth] if log is None else log[1],
                             max_range_m=min((inputs.source.duration_s or math.inf) * c_max, 20_000.0) + 10.0)
    c = s.sound_speed_mps
    for rec in records:
        if math.isfinite(rec.tof_s):
            depth = s.vehicle_depth_at(rec.t_arrival_s)  # (with a depth log, the vehicle's at the arrival)
            r = float(ranging.horizontal_range(rec.tof_s, depth))
            if math.isfinite(r):
                slant = float(ranging.slant_range(rec.tof_s, depth))
                per_s = float(ranging.range_per_second(rec.tof_s, depth)) * r / max(slant, 1e-9)
                rec = dataclasses.replace(rec, range_m=slant, horizontal_range_m=r,
                                          sigma_range_m=rec.sigma_range_m / c * per_s)
        yield rec


def _warn_unmatched(times_s: list[float]) -> None:
    """One warning for the arrivals no emission precedes (left out of the file: they have no range)."""
    if times_s:
        listed = ", ".join(f"{round(t, 3) + 0.0:.3f}" for t in times_s[:3]) + (" ..." if len(times_s) > 3 else "")
        warnings.warn(
            f"{len(times_s)} arrival(s) before the first emission (at t = {listed} s) have no emission time and so "
            "no range: not written (listed in the sidecar's unmatched_arrivals_s; check --emit-start or "
            "--clock-offset)",
            UserWarning,
            stacklevel=2,
        )


def _run_many(args: argparse.Namespace, out: Path) -> int:
    """Several or long recordings, in parallel; 0 when all succeeded, 1 when any failed."""
    from ..batch.decode import PartFailure, Recording, decode_files
    from ..receive.records import is_matched

    recordings, failures, inputs = [], [], []
    with reported_warnings("rx"):
        for path in args.recording:
            try:
                one = _inputs(args, path)
            except SeamodemError as exc:
                failures.append(PartFailure(str(path), str(exc)))
                continue
            inputs.append(one)
            recordings.append(
                Recording(path, one.config, one.emissions, args.channel, one.settings, one.pilot, one.payloads)
            )
    result = decode_files(
        recordings,
        segment_s=args.segment,
        overlap_s=args.overlap,
        output=out,
        header=_header(inputs, segment_s=args.segment, batch=True),
        resume=args.resume,
        backend="dask" if args.scheduler else "processes",
        workers=args.workers,
        scheduler=args.scheduler,
        progress=False if args.quiet else None,
        failed=failures,
    )
    for f in result.failures:
        print(f"seamodem rx: failed: {f.label}: {f.error}", file=sys.stderr)
    unmatched = [r.t_arrival_s for r in result.records if not is_matched(r)]
    with reported_warnings("rx"):
        for note in result.warnings:
            warnings.warn(note, UserWarning, stacklevel=1)
        _warn_unmatched(unmatched)
    n = len(result.records) - len(unmatched)
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


class _Counted:
    """Pass the records through, counting decoded frames, CRC passes and bit errors of those an emission precedes.

    The times of the arrivals without an emission (no range) are kept in ``unmatched``.
    """

    def __init__(self, records):
        self.records = records
        self.decoded = self.crc_ok = self.ber_frames = 0
        self.ber_sum = 0.0
        self.unmatched: list[float] = []
        self.ranges_m: list[float] = []
        self.sigmas_m: list[float] = []

    def __iter__(self):
        from ..receive.records import is_matched

        for rec in self.records:
            if not is_matched(rec):
                self.unmatched.append(rec.t_arrival_s)
                yield rec  # left out of the file, and listed in its sidecar, by write_measurements
                continue
            if math.isfinite(rec.range_m) and math.isfinite(rec.sigma_range_m):
                self.ranges_m.append(rec.range_m)
                self.sigmas_m.append(rec.sigma_range_m)
            if rec.crc_ok is not None:
                self.decoded += 1
                self.crc_ok += int(rec.crc_ok)
            if math.isfinite(rec.ber):
                # every frame carries the same information block: the mean of the ber is the bit error rate
                self.ber_frames += 1
                self.ber_sum += rec.ber
            yield rec


def _plotter(folder: Path, n_frames: int, inputs: _Inputs):
    """on_frame callback that saves a figure of each of the first ``n_frames`` frames in ``folder``."""
    from ..receive.plots import plot_frame
    from ..transmit.pilot import pilot_symbols

    config, sound_speed = inputs.config, inputs.settings.sound_speed_mps
    symbols = pilot_symbols(config.n_pilot, config.pilot_seed) if inputs.pilot is None else inputs.pilot
    count = [0]

    def on_frame(m, bb, t0_s, fs):
        if count[0] >= n_frames:
            return
        count[0] += 1
        path = folder / f"frame_{count[0] - 1:04d}_{m.pilot.t_start_s:.3f}s.png"
        plot_frame(
            path, m, bb, fs=fs, t0_s=t0_s, config=config, pilot=symbols, sound_speed_mps=sound_speed
        )

    return on_frame
