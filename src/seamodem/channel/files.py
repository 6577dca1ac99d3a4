"""The channel's file-level input and output: the input recording and its sidecar, OUT.wav and OUT.json.

:func:`read_input`, :func:`read_reference_input` and :func:`read_janus_input` read and check an
input recording (a frame beacon's, a reference beacon's or a JANUS beacon's); :func:`write_outputs`
runs a simulation into OUT.wav (through a temporary scratch file beside it)
and writes OUT.json, the two atomically.
"""

from __future__ import annotations

import copy
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import soundfile

from ..config import FrameConfig
from ..errors import ConfigError, InputFileError
from ..io.files import atomic_outputs
from ..io.sidecar import read_sidecar, sidecar_path, write_json
from ..io.wav import wav_info

__all__ = [
    "read_input",
    "read_reference_input",
    "read_janus_input",
    "OUTPUT_PEAK_LIMIT",
    "OUTPUT_PEAK",
    "write_outputs",
]


class _FileScratch:
    """Float64 samples in a temporary file beside the output (deleted on close)."""

    def __init__(self, folder: Path):
        fd, name = tempfile.mkstemp(prefix=".seamodem-channel.", suffix=".f64", dir=folder)
        self.path = Path(name)
        self.f = os.fdopen(fd, "w+b")

    def write(self, n0: int, block: np.ndarray) -> None:
        self.f.seek(8 * n0)
        self.f.write(np.ascontiguousarray(block, dtype=np.float64).tobytes())

    def read(self, n0: int, n1: int) -> np.ndarray:
        self.f.flush()
        self.f.seek(8 * n0)
        return np.fromfile(self.f, dtype=np.float64, count=n1 - n0)

    def close(self) -> None:
        self.f.close()
        self.path.unlink(missing_ok=True)


def read_input(in_wav: str | Path) -> tuple[soundfile._SoundFileInfo, dict, FrameConfig]:
    """Header, sidecar and frame configuration of an input recording, checked against each other.

    Parameters
    ----------
    in_wav : str or Path
        The recording; its sidecar is beside it.

    Returns
    -------
    info : soundfile info
        The WAV header.
    sidecar : dict
        The sidecar.
    config : FrameConfig
        The frame configuration it was made with.

    Raises
    ------
    InputFileError
        Missing or unreadable WAV or sidecar; a WAV sample rate that disagrees
        with the sidecar; a multichannel or empty WAV.
    """
    in_wav = Path(in_wav)
    info = wav_info(in_wav)
    side_in = read_sidecar(sidecar_path(in_wav))
    _check_input(in_wav, info, side_in)
    return info, side_in, FrameConfig.from_dict(side_in["config"])


def _check_input(in_wav: Path, info, side_in: dict) -> None:
    rate = side_in["recording"].get("sample_rate_hz")
    if int(info.samplerate) != rate:
        raise InputFileError(
            f"{in_wav}: WAV sample rate {info.samplerate} Hz disagrees with its sidecar's recording.sample_rate_hz = {rate}"
        )
    if info.channels != 1:
        raise InputFileError(f"{in_wav}: has {info.channels} channels; the channel simulator takes a mono recording")
    if info.frames == 0:
        raise InputFileError(f"recording {in_wav} holds no samples")


def read_reference_input(in_wav: str | Path) -> tuple[soundfile._SoundFileInfo, dict, float, tuple[float, float]] | None:
    """Header, sidecar, longest ping [s] and band [Hz] of a ``seamodem tx --reference`` schedule; None for others.

    Parameters
    ----------
    in_wav : str or Path
        The recording; its sidecar is beside it.

    Returns
    -------
    tuple or None
        (WAV header, sidecar, longest ping [s], (f_low, f_high) [Hz]), or None when the sidecar is
        missing, not JSON or not a reference beacon's.

    Raises
    ------
    InputFileError
        As :func:`read_input`; a reference sidecar without references or emissions.
    """
    import json

    in_wav = Path(in_wav)
    try:
        side_in = json.loads(sidecar_path(in_wav).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None  # not there or not JSON: read_input says which
    from ..transmit.reference import REFERENCE_SIDECAR_FORMAT, ReferenceWaveform

    if not isinstance(side_in, dict) or side_in.get("format") != REFERENCE_SIDECAR_FORMAT:
        return None
    if not side_in.get("references") or not side_in.get("frames") or "recording" not in side_in:
        raise InputFileError(f"reference sidecar {sidecar_path(in_wav)} lacks its references, frames or recording")
    try:
        refs = [ReferenceWaveform.from_dict(r) for r in side_in["references"]]
    except (ConfigError, TypeError, ValueError) as exc:
        raise InputFileError(f"reference sidecar {sidecar_path(in_wav)}: {exc}") from None
    info = wav_info(in_wav)
    _check_input(in_wav, info, side_in)
    band = (min(r.f_low_hz for r in refs), max(r.f_high_hz for r in refs))
    return info, side_in, max(r.duration_s for r in refs), band


def read_janus_input(in_wav: str | Path) -> tuple[soundfile._SoundFileInfo, dict, float, tuple[float, float], float] | None:
    """Header, sidecar, longest packet [s], band [Hz] and centre [Hz] of a ``seamodem tx --janus`` beacon; None for others.

    The frames' ``t_emit_s`` are their first preamble chips: the truth is the arrival of that chip.

    Raises
    ------
    InputFileError
        As :func:`read_input`; a JANUS sidecar without its parameter set or frames.
    """
    import json

    in_wav = Path(in_wav)
    try:
        side_in = json.loads(sidecar_path(in_wav).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    from ..transmit.janus.beacon import JANUS_SIDECAR_FORMAT

    if not isinstance(side_in, dict) or side_in.get("format") != JANUS_SIDECAR_FORMAT:
        return None
    try:
        pset = side_in["janus"]["pset"]
        chip_s = 2.0 ** pset["chip_len_exp"] / round(pset["bandwidth_hz"] / 26)
        longest = max(int(f["n_chips"]) for f in side_in["frames"]) * chip_s
        band = (pset["fc_hz"] - pset["bandwidth_hz"] / 2, pset["fc_hz"] + pset["bandwidth_hz"] / 2)
    except (KeyError, TypeError, ValueError):
        raise InputFileError(f"JANUS sidecar {sidecar_path(in_wav)} lacks its parameter set or frames") from None
    info = wav_info(in_wav)
    _check_input(in_wav, info, side_in)
    return info, side_in, longest, band, float(pset["fc_hz"])


#: An output whose peak exceeds this fraction of full scale is scaled down to OUTPUT_PEAK, so that
#: no sample reaches full scale (a receiver would take it for clipping). Truth and SNR are unchanged.
OUTPUT_PEAK_LIMIT = 0.9
OUTPUT_PEAK = 0.5


def _rescale_wav(path: Path, gain: float, fs: int, block: int = 1 << 20) -> None:
    """Multiply a float WAV by ``gain`` in place (through a temporary beside it, in blocks)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{Path(path).name}.", suffix=".gain", dir=Path(path).parent)
    os.close(fd)
    try:
        with soundfile.SoundFile(str(path)) as fin, soundfile.SoundFile(
            tmp, "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
        ) as fout:
            for chunk in fin.blocks(blocksize=block, dtype="float64"):
                fout.write(gain * chunk)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _frames_as_polls(side: dict, two_way: dict) -> None:
    """Two-way: each frame's ``t_emit_s`` becomes its poll's (vehicle clock), what ``rx --turnaround`` pairs it with.

    The input's emission time is kept as ``t_emit_input_s`` and the beacon's
    reply emission (true time) as ``t_reply_emit_s``.
    """
    for frame, t_poll, t_reply in zip(side["frames"], two_way["t_poll_s"], two_way["t_reply_emit_s"]):
        frame["t_emit_input_s"] = frame["t_emit_s"]
        frame["t_emit_s"] = t_poll
        frame["t_reply_emit_s"] = t_reply


def write_outputs(in_wav: str | Path, out_wav: str | Path, side_in: dict, produce, *, command: str) -> dict[str, Any]:
    """Run ``produce(fin, sink, make_scratch) -> (truth, channel)`` and write OUT.wav + OUT.json atomically.

    ``fin`` is the open input; ``sink(block)`` appends to OUT.wav (32-bit
    float); ``make_scratch(n)`` gives a temporary float64 file of n samples.
    An output whose peak exceeds :data:`OUTPUT_PEAK_LIMIT` is scaled to :data:`OUTPUT_PEAK`.

    Parameters
    ----------
    in_wav, out_wav : str or Path
        Input and output recordings (sidecars beside them).
    side_in : dict
        The input's sidecar, carried forward.
    produce : callable
        As above.
    command : str
        The command line, recorded in the sidecar.

    Returns
    -------
    dict
        OUT.json as written.
    """
    in_wav, out_wav = Path(in_wav), Path(out_wav)
    side = copy.deepcopy(side_in)
    rec = side_in["recording"]
    fs = int(rec["sample_rate_hz"])
    scratches: list[_FileScratch] = []

    def make_scratch(n):
        scratches.append(_FileScratch(out_wav.parent))
        return scratches[-1]

    peak = 0.0
    with atomic_outputs(out_wav, sidecar_path(out_wav)) as (tmp_wav, tmp_json):
        try:
            with soundfile.SoundFile(str(in_wav)) as fin, soundfile.SoundFile(
                str(tmp_wav), "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
            ) as fout:

                def sink(block):
                    nonlocal peak
                    if block.size:
                        peak = max(peak, float(np.max(np.abs(block))))
                    fout.write(block)

                truth, channel = produce(fin, sink, make_scratch)
        finally:
            for s in scratches:
                s.close()
        gain = 1.0
        if peak > OUTPUT_PEAK_LIMIT:
            gain = OUTPUT_PEAK / peak
            _rescale_wav(tmp_wav, gain, fs)
            peak *= gain
        channel["output"]["gain"] = gain
        channel["command"] = command
        channel["input"] = in_wav.name
        channel["input_recording"] = rec
        if "two_way" in channel:
            _frames_as_polls(side, channel["two_way"])
        side["channel"] = channel
        side["truth"] = truth
        side["recording"] = {
            "file": out_wav.name,
            "sample_rate_hz": fs,
            "n_samples": channel["output"]["n_samples"],
            "duration_s": channel["output"]["duration_s"],
            "subtype": "FLOAT",
            "scale": rec.get("scale"),
            "peak": peak,
        }
        write_json(tmp_json, side)
    return side
