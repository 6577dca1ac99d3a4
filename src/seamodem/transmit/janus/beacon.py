"""A JANUS beacon recording: packets on a schedule, WAV + JSON sidecar.

Packet k's first sample (its leading silence, then wake-up tones when sent) is at
``start + k·period``; the sidecar gives, as ``t_emit_s``, the emission of its first preamble chip:
the instant the receiver measures arrivals of. S16 output truncates as the reference transmitter does, so a single packet at
the reference's rate and options is the reference's file sample for sample.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...io.files import atomic_outputs
from ...io.sidecar import sidecar_path, write_json
from ..beacon import BeaconSchedule
from .frame import janus_waveform
from .modulate import to_s16
from .packet import JanusPacket
from .pset import JanusParameterSet

__all__ = ["write_janus_beacon", "JANUS_SIDECAR_FORMAT"]

JANUS_SIDECAR_FORMAT = "seamodem.janus/1"


def write_janus_beacon(
    path: str | Path,
    packets: list[JanusPacket],
    pset: JanusParameterSet,
    fs: int,
    schedule: BeaconSchedule,
    *,
    wake_up: bool = False,
    amplitude: float = 0.95,
    subtype: str = "PCM_16",
    command: str = "",
) -> dict:
    """Write ``packets`` (one per emission, cycled) to a WAV and its sidecar; returns the sidecar.

    Parameters
    ----------
    path : str or Path
        Output WAV; the sidecar is the same name with ``.json``.
    packets : list of JanusPacket
        Packet k of the schedule is ``packets[k % len(packets)]``.
    pset : JanusParameterSet
        Parameter set.
    fs : int
        Sample rate [Hz].
    schedule : BeaconSchedule
        Packet k's first sample at start + k·period [s].
    wake_up : bool
        Wake-up tones before each packet.
    amplitude : float
        Carrier amplitude (the reference's 0.95 by default).
    subtype : str
        soundfile subtype: ``PCM_16`` (truncated as the reference does), ``PCM_24`` or ``FLOAT``.
    command : str
        The command line, for the sidecar.
    """
    import soundfile

    waves = [janus_waveform(p, pset, fs, wake_up=wake_up, amplitude=amplitude) for p in packets]
    times = schedule.emission_times()
    placed = []
    for k, t in enumerate(times):
        w = waves[k % len(waves)]
        placed.append((int(round(t * fs)), w))
    # the last packet's end (one packet: the file is the packet), or the last period's
    end = max(first + w.x_pb.size for first, w in placed)
    n = end if schedule.count == 1 else max(end, int(round((times[-1] + schedule.period_s) * fs)))
    x = np.zeros(n)
    for first, w in placed:
        if np.any(x[first : first + w.x_pb.size]):
            raise ValueError(f"period must exceed a packet's length ({w.x_pb.size / fs:g} s), got {schedule.period_s:g}")
        x[first : first + w.x_pb.size] = w.x_pb
    frames = [
        {"index": k, "t_emit_s": (first + w.preamble_start) / fs, "packet_hex": w.packet.to_bytes().hex(),
         "cargo_hex": w.packet.cargo.hex(), "n_chips": w.n_chips}
        for k, (first, w) in enumerate(placed)
    ]
    sidecar = {
        "format": JANUS_SIDECAR_FORMAT,
        "created_by": command,
        "janus": {"pset": pset.to_dict(), "wake_up": wake_up, "amplitude": amplitude,
                  "emission_reference": "first preamble chip"},
        "recording": {"file": Path(path).name, "sample_rate_hz": fs, "samples": n, "duration_s": n / fs,
                      "subtype": subtype},
        "frames": frames,
    }
    side = sidecar_path(path)
    with atomic_outputs(path, side) as (tmp_wav, tmp_side):
        data = to_s16(x) if subtype == "PCM_16" else x
        soundfile.write(str(tmp_wav), data, int(fs), subtype=subtype, format="WAV")
        write_json(tmp_side, sidecar)
    return sidecar
