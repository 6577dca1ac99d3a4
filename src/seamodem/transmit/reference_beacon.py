"""The reference beacon: a schedule of reference pings (and their packets) written to a WAV and its sidecar."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from .reference_waveform import REFERENCE_SIDECAR_FORMAT, ReferenceWaveform
from .replica import Replica, reference_waveform

__all__ = ["emission_times", "write_reference_beacon"]


def emission_times(references: list[ReferenceWaveform], *, count: int, period_s: float, start_s: float) -> list[dict]:
    """Every emission of a beacon schedule: reference i of n at start + k·period + i·period/n, then the rest
    of its packet (:meth:`ReferenceWaveform.packet`: train, postamble).

    Parameters
    ----------
    references : list of ReferenceWaveform
        The references, in turn within each period.
    count : int
        Periods.
    period_s : float
        Period [s].
    start_s : float
        First emission [s].

    Returns
    -------
    list of dict
        ``frame_index``, ``t_emit_s``, ``reference`` (name), ``role`` ("ping", "preamble", "postamble"),
        ``train_position`` (the chirp's place in its train), sorted by time.
    """
    out = []
    n = len(references)
    for k in range(count):
        for i, ref in enumerate(references):
            t = start_s + k * period_s + i * period_s / n
            for offset, role, position in ref.packet():
                out.append({"frame_index": k, "t_emit_s": t + offset, "reference": ref.name, "role": role,
                            "train_position": position})
    return sorted(out, key=lambda e: e["t_emit_s"])


def write_reference_beacon(
    path: str | Path,
    replicas: list[Replica],
    *,
    count: int,
    period_s: float,
    start_s: float = 0.0,
    fs: float,
    subtype: str = "FLOAT",
    peak: float = 0.5,
    command: str = "",
) -> dict[str, Any]:
    """Write a beacon schedule of reference pings to a WAV and its sidecar (``.json``); returns the sidecar.

    Emissions as :func:`emission_times`; each ping has unit peak before the
    file's scaling to ``peak`` of full scale. The two files appear together or
    not at all.

    Parameters
    ----------
    path : str or Path
        The WAV; the sidecar is written beside it with the suffix ``.json``.
    replicas : list of Replica
        The references' replicas (:func:`~seamodem.transmit.replica.reference_replica`).
    count, period_s, start_s
        The schedule, as :func:`emission_times`.
    fs : float
        Sample rate [Hz].
    subtype : str
        WAV sample format (soundfile subtype).
    peak : float
        Peak of the file, a fraction of full scale in (0, 1].
    command : str
        The command line, recorded in the sidecar.

    Returns
    -------
    dict
        The sidecar as written.

    Raises
    ------
    ConfigError
        Bad schedule, overlapping emissions, a band above fs/2.
    """
    from .._version import __version__
    from ..io.files import atomic_outputs
    from ..io.sidecar import write_json
    from ..io.wav import write_wav_blocks

    if not (isinstance(count, int) and count >= 1):
        raise ConfigError("count", f"must be an integer >= 1, got {count!r}")
    if not (math.isfinite(period_s) and period_s > 0):
        raise ConfigError("period", f"must be > 0 s, got {period_s!r}")
    if not (math.isfinite(start_s) and start_s >= 0):
        raise ConfigError("start", f"must be >= 0 s, got {start_s!r}")
    if not 0 < peak <= 1:
        raise ConfigError("peak", f"must be in (0, 1], got {peak!r}")
    refs = [rep.reference for rep in replicas]
    waves = {rep.reference.name: reference_waveform(rep, fs) for rep in replicas}
    emissions = emission_times(refs, count=count, period_s=period_s, start_s=start_s)
    for a, b in zip(emissions, emissions[1:]):
        if a["t_emit_s"] + len(waves[a["reference"]]) / fs > b["t_emit_s"]:
            raise ConfigError(
                "period", f"emissions overlap: {a['reference']} at {a['t_emit_s']:g} s runs past {b['t_emit_s']:g} s"
            )
    n_total = int(math.ceil((emissions[-1]["t_emit_s"] + replicas[0].duration_s) * fs)) + int(0.1 * fs)
    n_total = max(n_total, int(math.ceil((start_s + count * period_s) * fs)))
    starts = [(int(round(e["t_emit_s"] * fs)), waves[e["reference"]]) for e in emissions]
    for e, (i0, _) in zip(emissions, starts):
        e["t_emit_s"] = i0 / fs  # emissions start on a sample: the sidecar states the exact time

    def blocks(size=1 << 18):
        for lo in range(0, n_total, size):
            hi = min(n_total, lo + size)
            out = np.zeros(hi - lo)
            for i0, w in starts:
                a, b = max(lo, i0), min(hi, i0 + len(w))
                if a < b:
                    out[a - lo : b - lo] += w[a - i0 : b - i0]
            yield peak * out

    path = Path(path)
    sidecar = {
        "format": REFERENCE_SIDECAR_FORMAT,
        "created_by": f"seamodem {__version__}",
        "command": command,
        "references": [r.to_dict() for r in refs],
        "schedule": {"count": count, "period_s": period_s, "start_s": start_s},
        "recording": {"file": path.name, "sample_rate_hz": fs, "n_samples": n_total, "duration_s": n_total / fs,
                      "subtype": subtype, "scale": peak},
        "frames": emissions,
    }
    with atomic_outputs(path, path.with_suffix(".json")) as (tmp_wav, tmp_json):
        write_wav_blocks(tmp_wav, blocks(), fs=int(round(fs)), subtype=subtype)
        write_json(tmp_json, sidecar)
    return sidecar
