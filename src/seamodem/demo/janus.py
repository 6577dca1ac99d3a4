"""The demo mission with JANUS beacons (``seamodem demo --waveform janus``): steps 2 and 4 with JANUS packets.

The beacon emits a JANUS base packet (:meth:`~.config.DemoConfig.janus_packet`: parameter set 1,
class 16 / application type 0, station 1, no cargo) every T_com
(:func:`seamodem.transmit.janus.beacon.write_janus_beacon`); the channel is the frame demo's
(:func:`seamodem.channel.simulate_file` takes JANUS beacons); the JANUS receiver
(:class:`seamodem.receive.janus.JanusReceiver`) writes the common measurement record, which the
same filters read.
"""

from __future__ import annotations

from pathlib import Path

from .config import JANUS_SAMPLE_RATE_HZ, DemoConfig

__all__ = ["write_janus_demo_beacon", "receive_janus_recording", "janus_outputs"]


def write_janus_demo_beacon(path: Path, cfg: DemoConfig, schedule) -> dict:
    """Write the beacon: ``cfg.janus_packet()`` on ``schedule`` at 96 kHz, float samples (step 2).

    Parameters
    ----------
    path : Path
        The beacon WAV (its sidecar beside it).
    cfg : DemoConfig
        The mission (``waveform="janus"``).
    schedule : BeaconSchedule
        A packet every T_com from 0.

    Returns
    -------
    dict
        The beacon's sidecar.
    """
    from ..transmit.janus.beacon import write_janus_beacon

    return write_janus_beacon(path, [cfg.janus_packet()], cfg.janus_pset, JANUS_SAMPLE_RATE_HZ, schedule,
                              subtype="FLOAT", command="seamodem demo --waveform janus")


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
