"""The demo mission with JANUS beacons (``seamodem demo --waveform janus``): steps 2 and 4 with JANUS packets.

The beacon emits a JANUS base packet (parameter set 1, class 16 / application type 0, station 1,
no cargo) every T_com (:func:`seamodem.transmit.janus.beacon.write_janus_beacon`); the channel is
the frame demo's (:func:`seamodem.channel.simulate_file` takes JANUS beacons); the JANUS receiver
(:class:`seamodem.receive.janus.JanusReceiver`) writes the common measurement record, which the
same filters read.
"""

from __future__ import annotations

from pathlib import Path

from .config import JANUS_SAMPLE_RATE_HZ, DemoConfig, VehicleRun

__all__ = ["janus_packet", "emit_and_propagate_janus", "receive_janus_recording", "janus_outputs"]


def janus_packet():
    """The demo beacon's packet: class 16 / type 0, station 1, parameter set 1, no cargo.

    Returns
    -------
    JanusPacket
    """
    from ..transmit.janus import JanusPacket

    return JanusPacket.class16_app0(station_id=1, pset_id=1, cargo=b"")


def emit_and_propagate_janus(cfg: DemoConfig, vehicle: VehicleRun, folder: Path, *,
                             progress: bool | None = False) -> dict:
    """Write ``beacon.wav`` (JANUS packets every T_com) and ``received.wav`` (the hydrophone) in ``folder``.

    Parameters
    ----------
    cfg : DemoConfig
        The mission (``waveform="janus"``).
    vehicle : VehicleRun
        The true vehicle (its track is written to ``folder``/vehicle_track.csv for the channel).
    folder : Path
        Where the recordings go.
    progress : bool or None
        Progress bar of the channel (None: when stderr is a terminal).

    Returns
    -------
    dict
        The received recording's sidecar (with the channel's ``truth`` per packet).
    """
    from ..channel import parse_scenario, simulate_file
    from ..transmit import BeaconSchedule
    from ..transmit.janus.beacon import write_janus_beacon
    from .mission import make_scenario, write_track_csv

    folder = Path(folder)
    schedule = BeaconSchedule(count=cfg.frame_count(), period_s=cfg.tcom_s)
    write_janus_beacon(folder / "beacon.wav", [janus_packet()], cfg.janus_pset, JANUS_SAMPLE_RATE_HZ, schedule,
                       subtype="FLOAT", command="seamodem demo --waveform janus")
    track = folder / "vehicle_track.csv"
    write_track_csv(track, vehicle, cfg.depth_m)
    scenario = parse_scenario(make_scenario(cfg, track), base_dir=folder)
    return simulate_file(folder / "beacon.wav", scenario, folder / "received.wav",
                         command="seamodem demo --waveform janus", progress=progress)


def receive_janus_recording(recording: Path, sidecar: dict) -> list:
    """Detect, decode and measure every JANUS packet of ``recording`` (as ``seamodem rx --janus``).

    Parameters
    ----------
    recording : Path
        The received recording.
    sidecar : dict
        Its sidecar (parameter set, emission times, sound speed).

    Returns
    -------
    list of JanusRecord
        One per packet decoded, its ``frame_index`` the emission it belongs to.
    """
    from ..io.blocks import channel_blocks
    from ..io.source import open_recording
    from ..receive import Emissions
    from ..receive.janus import JanusReceiver, JanusSettings
    from ..transmit.janus import JanusParameterSet

    settings = JanusSettings(pset=JanusParameterSet(**sidecar["janus"]["pset"]),
                             sound_speed_mps=float(sidecar["channel"]["sound_speed_mps"]),
                             emissions=Emissions(times_s=[f["t_emit_s"] for f in sidecar["frames"]]))
    source = open_recording(recording)
    channel = source.one_channel(None)
    return list(JanusReceiver(source.sample_rate_hz, settings).run(channel_blocks(source, channel)))


def janus_outputs(config_json: dict, header: dict, sidecar: dict) -> tuple[dict, dict, dict]:
    """The JANUS demo's ``demo_config.json``, measurement header and columns (as ``seamodem rx --janus`` writes them).

    Parameters
    ----------
    config_json : dict
        The frame demo's ``demo_config.json`` (its ``frame`` entry becomes ``janus``: the parameter set).
    header : dict
        The frame demo's measurement header (its frame ``config`` gives way to the parameter set).
    sidecar : dict
        The received recording's sidecar.

    Returns
    -------
    config_json, header : dict
        Rewritten.
    columns : dict
        ``{"fields": JANUS_FIELDS}``: the common record's columns plus the packet's.
    """
    from ..receive.janus import JANUS_FIELDS

    pset = sidecar["janus"]["pset"]
    config_json = {k: v for k, v in config_json.items() if k != "frame"} | {"janus": sidecar["janus"]}
    header = {k: v for k, v in header.items() if k not in ("decode", "config")} | {
        "pset": pset, "t_arrival": "first preamble chip", "v_r_source": "whole packet (data-aided, after decoding)",
        "snr_definition": "in-band SNR over the available bandwidth B, from the whole-packet fit"}
    return config_json, header, {"fields": JANUS_FIELDS}
