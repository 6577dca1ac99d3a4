"""``seamodem tx --janus`` and ``seamodem rx --janus``: JANUS (STANAG 4748) packets, options named after its fields.

Hooked into ``tx`` and ``rx`` by :func:`add_tx_options` and :func:`add_rx_options`; heavy imports
stay inside the functions (fast command line).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputFileError, SeamodemError
from ..io.files import check_writable
from ._common import command_line, emit_schedule, output_path, sound_speed, sound_speed_words

__all__ = ["add_tx_options", "run_tx", "add_rx_options", "run_rx", "parameter_sets_text"]


def _pset_options(g) -> None:
    g.add_argument("--pset-id", type=int, default=1, metavar="ID", help="JANUS parameter set (default 1: fc 11520 Hz, B 4160 Hz)")
    g.add_argument("--pset-center-freq", type=float, metavar="HZ", help="override the set's centre frequency fc")
    g.add_argument("--pset-bandwidth", type=float, metavar="HZ", help="override the set's available bandwidth B")
    g.add_argument("--chip-len-exp", type=int, default=0, metavar="E", help="chip duration 2**E / cf (default 0)")


def add_tx_options(p: argparse.ArgumentParser) -> None:
    """The ``tx --janus`` options (the rate is ``--sample-rate``, the schedule ``--count/--period/--start``)."""
    g = p.add_argument_group(
        "JANUS packets (docs/janus.md)",
        "With --janus, each emission is a JANUS packet (STANAG 4748), made as the reference janus-tx makes it: "
        "--format pcm16 writes its samples exactly; the rate is --sample-rate (default 96000 Hz). --count defaults to 1 (the file is then the packet alone); "
        "packet k's first sample is at START + k·PERIOD, and the sidecar's t_emit_s is its first preamble chip.",
    )
    g.add_argument("--janus", action="store_true", help="emit JANUS packets instead of seamodem frames")
    _pset_options(g)
    g.add_argument("--packet-mobility", type=int, choices=(0, 1), default=0, help="mobility flag")
    g.add_argument("--packet-tx-rx", type=int, choices=(0, 1), default=1, help="tx/rx capability flag (default 1)")
    g.add_argument("--packet-forward", type=int, choices=(0, 1), default=0, help="forwarding capability flag")
    g.add_argument("--packet-class-id", type=int, default=16, metavar="N", help="class user identifier (default 16)")
    g.add_argument("--packet-app-type", type=int, default=0, metavar="N", help="application type (default 0)")
    g.add_argument("--packet-app-data", type=lambda s: int(s, 0), metavar="N",
                   help="34-bit application data (classes other than 16 / type 0)")
    g.add_argument("--packet-app-fields", metavar="K=V,...",
                   help="class 16 / type 0 fields: StationIdentifier=N,ParameterSetIdentifier=N")
    g.add_argument("--packet-cargo", metavar="TEXT", help="cargo text (class 16 / type 0: ≤ 480 bytes, zero-padded)")
    g.add_argument("--wut", type=int, choices=(0, 1), default=0, help="wake-up tones before each packet")
    g.add_argument("--amplitude", type=float, default=0.95, help="carrier amplitude (default 0.95, the reference's)")


def _pset(args):
    from ..transmit.janus import get_parameter_set

    overrides = {"chip_len_exp": args.chip_len_exp}
    if args.pset_center_freq is not None:
        overrides["fc_hz"] = args.pset_center_freq
    if args.pset_bandwidth is not None:
        overrides["bandwidth_hz"] = args.pset_bandwidth
    return get_parameter_set(args.pset_id, **overrides)


def _packet(args):
    from ..transmit.janus import JanusPacket

    cargo = (args.packet_cargo or "").encode("utf-8")
    if args.packet_class_id == 16 and args.packet_app_type == 0:
        if args.packet_app_data is not None:
            raise SeamodemError("packet-app-data: class 16 / type 0 takes --packet-app-fields and --packet-cargo")
        fields = {}
        for item in filter(None, (args.packet_app_fields or "").split(",")):
            key, sep, value = item.partition("=")
            if not sep or key.strip() not in ("StationIdentifier", "ParameterSetIdentifier"):
                raise SeamodemError(f"packet-app-fields: expected StationIdentifier=N,ParameterSetIdentifier=N, got {item!r}")
            try:
                fields[key.strip()] = int(value, 0)
            except ValueError:
                raise SeamodemError(f"packet-app-fields: {key.strip()} must be an integer, got {value!r}") from None
        return JanusPacket.class16_app0(
            station_id=fields.get("StationIdentifier", 0), pset_id=fields.get("ParameterSetIdentifier", 0), cargo=cargo,
            mobility=bool(args.packet_mobility), tx_rx=bool(args.packet_tx_rx), forward=bool(args.packet_forward))
    if args.packet_app_fields or cargo:
        raise SeamodemError("packet-app-fields: application fields and cargo are defined for class 16 / type 0 only")
    return JanusPacket(mobility=bool(args.packet_mobility), tx_rx=bool(args.packet_tx_rx),
                       forward=bool(args.packet_forward), class_user_id=args.packet_class_id,
                       application_type=args.packet_app_type, application_data=args.packet_app_data or 0)


def run_tx(args: argparse.Namespace) -> int:
    """Write the JANUS beacon."""
    from ..io.wav import SUBTYPES
    from ..transmit.beacon import BeaconSchedule
    from ..transmit.janus.beacon import write_janus_beacon

    if args.payload_text or args.payload_file:
        raise SeamodemError("payload-text: JANUS carries --packet-cargo (drop --payload-text/--payload-file)")
    if args.reference:
        raise SeamodemError("janus: give --janus or --reference, not both")
    out = output_path(args.output, ".wav")
    fs = args.sample_rate
    if fs != int(fs):
        raise SeamodemError(f"sample-rate: must be a whole number of Hz for a WAV, got {fs!r}")
    pset = _pset(args)
    packet = _packet(args)
    schedule = BeaconSchedule(count=1 if args.count is None else args.count, period_s=args.period, start_s=args.start)
    sidecar = write_janus_beacon(out, [packet], pset, int(fs), schedule, wake_up=bool(args.wut),
                                 amplitude=args.amplitude, subtype=SUBTYPES[args.format], command=command_line())
    if not args.quiet:
        rec = sidecar["recording"]
        print(f"wrote {out} ({schedule.count} JANUS packet{'s' if schedule.count > 1 else ''} "
              f"{packet.to_bytes().hex(' ').upper()}, {rec['duration_s']:.4f} s at {rec['sample_rate_hz']} Hz, "
              f"{args.format}) and {out.with_suffix('.json')}")
    return 0


def add_rx_options(p: argparse.ArgumentParser) -> None:
    """The ``rx --janus`` options; ``--sound-speed``, ``--v-max``, ``--emit-*`` are the receiver's own."""
    g = p.add_argument_group(
        "JANUS packets (docs/janus.md)",
        "With --janus, RECORDING is searched for JANUS packets: one record per packet with a valid CRC, its "
        "fields and cargo, and its arrival (first preamble chip) and v_r with their σ. Emission times: "
        "--emit-start/--emit-period, or the sidecar `seamodem tx --janus` wrote.",
    )
    g.add_argument("--janus", action="store_true", help="receive JANUS packets")
    _pset_options(g)
    frames_run = p.get_default("run")

    def run(args: argparse.Namespace) -> int:
        return run_rx(args) if args.janus else frames_run(args)

    p.set_defaults(run=run)


def run_rx(args: argparse.Namespace) -> int:
    """Decode and measure every JANUS packet of one recording."""
    if len(args.recording) != 1:
        raise SeamodemError("janus: give one recording with --janus")
    if args.reference:
        raise SeamodemError("janus: give --janus or --reference, not both")
    out = check_writable(args.output)
    if out.suffix.lower() not in (".csv", ".jsonl"):
        raise SeamodemError(f"output: must end in .csv or .jsonl, got {str(out)!r}")
    recording = Path(args.recording[0])
    if not recording.is_file():
        raise InputFileError(f"recording not found: {recording}")
    import json

    from ..io.blocks import channel_blocks
    from ..io.sidecar import sidecar_path
    from ..io.source import open_recording
    from ..receive.janus import JANUS_FIELDS, JanusReceiver, JanusSettings
    from ..receive.records import write_measurements
    from ..receive.settings import Emissions
    from ..transmit.janus.beacon import JANUS_SIDECAR_FORMAT

    side_path = sidecar_path(recording)
    side = None
    if side_path.is_file() and side_path != recording:
        try:
            side = json.loads(side_path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputFileError(f"sidecar {side_path} is not valid JSON: {exc}") from None
        side = side if isinstance(side, dict) and side.get("format") == JANUS_SIDECAR_FORMAT else None
    emissions = emit_schedule(args)
    if emissions is None and side is not None:
        emissions = Emissions(times_s=[f["t_emit_s"] for f in side["frames"]])
    c, origin = sound_speed(args, side)
    source = open_recording(recording)
    channel = source.one_channel(args.channel)
    fs = source.sample_rate_hz
    settings = JanusSettings(pset=_pset(args), sound_speed_mps=c, v_max_mps=args.v_max, emissions=emissions,
                             clock_offset_s=args.clock_offset)
    # streamed: records reach the file as packets are found, and a long recording is held 20 s at a time
    records = JanusReceiver(fs, settings).run(channel_blocks(source, channel))
    header = {
        "created_by": command_line(), "recording": str(recording), "sample_rate_hz": fs, "channel": channel,
        "sound_speed_mps": c,
        "v_max_mps": settings.v_max_mps, "clock_offset_s": settings.clock_offset_s, "pset": settings.pset.to_dict(),
        "t_arrival": "first preamble chip", "v_r_source": "whole packet (data-aided, after decoding)",
        "snr_definition": "in-band SNR over the available bandwidth B, from the whole-packet fit",
    }
    n = write_measurements(out, records, header, fields=JANUS_FIELDS, keep_unmatched=True)
    if n == 0:
        print(f"seamodem rx: warning: no JANUS packet found in {recording}", file=sys.stderr)
    if not args.quiet:
        print(f"wrote {out}: {n} JANUS packet{'s' if n != 1 else ''} ({sound_speed_words(c, origin)})")
    return 0


def parameter_sets_text() -> str:
    """The JANUS parameter sets, one line each (``seamodem config --list``)."""
    from ..transmit.janus import PARAMETER_SETS

    lines = []
    for k, ps in PARAMETER_SETS.items():
        lines.append(f"janus pset {k}: {ps.name}: fc {ps.fc_hz:g} Hz, B {ps.bandwidth_hz:g} Hz, tones "
                     f"{ps.f_low_hz:g}-{ps.f_high_hz:g} Hz every {ps.chip_hz:g} Hz, chip {ps.chip_s * 1e3:g} ms "
                     f"(2**{ps.chip_len_exp} / cf), {ps.n_slots} slots")
    return "\n".join(lines)
