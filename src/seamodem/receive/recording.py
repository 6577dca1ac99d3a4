"""The file entry point: every frame of an audio file, through the streaming receiver."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path

from ..config import FrameConfig
from ..io.blocks import BlockStats, read_blocks
from ..io.wav import wav_channel
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings
from .stream import Receiver, ReceiverWarning

__all__ = ["receive_file", "recording_warnings"]


def recording_warnings(path: str | Path, stats: BlockStats, *, n_frames: int | None) -> list[str]:
    """One-line notes on a whole recording: silent, clipped, no frame found (``n_frames=0``)."""
    notes = []
    if stats.silent:
        notes.append(f"recording {path} is silent (all samples are zero)")
    if stats.clipped:
        notes.append(f"recording {path}: {stats.clipped} samples are clipped at full scale; measurements may be biased")
    if n_frames == 0:
        notes.append(f"no frame found in {path}")
    return notes


def receive_file(
    path: str | Path,
    config: FrameConfig,
    *,
    emissions: Emissions,
    settings: ReceiverSettings | None = None,
    channel: int | None = None,
    pilot=None,
    payloads=None,
    on_frame=None,
    progress: bool | None = None,
) -> Iterator[MeasurementRecord]:
    """Measurement records of every frame in an audio file, yielded as frames are found.

    Parameters
    ----------
    path : str or Path
        WAV (or any format soundfile reads); any sample rate that holds the band.
    config : FrameConfig
    emissions : Emissions
    settings : ReceiverSettings, optional
        Default: ``ReceiverSettings()``.
    channel : int, optional
        Channel of a multichannel file (required then).
    pilot, payloads, on_frame
        As :class:`~seamodem.receive.stream.Receiver`.
    progress : bool, optional
        Progress bar (default: on a terminal).

    Raises
    ------
    InputFileError
        Missing, empty or non-audio file, NaN or infinite samples; bad channel.

    Warns
    -----
    RecordingWarning
        A header that lies about the length (a crashed or streaming recorder):
        the samples present are processed; a frame cut by the end is
        recorded undecoded.
    ReceiverWarning
        Silent or clipped recording; no frame found.
    """
    path = Path(path)
    info, ch = wav_channel(path, channel=channel)
    rx = Receiver(config, emissions=emissions, settings=settings, pilot=pilot, payloads=payloads, on_frame=on_frame)
    stats = BlockStats()
    blocks = read_blocks(path, channel=ch, stop=info.frames, stats=stats, progress=progress, info=info)
    n = 0
    for rec in rx.run(blocks, fs=info.samplerate):
        n += 1
        yield rec
    for note in recording_warnings(path, stats, n_frames=n):
        warnings.warn(note, ReceiverWarning, stacklevel=2)
