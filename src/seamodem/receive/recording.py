"""The recording entry point: every frame of a recording (a file or a stream), through the streaming receiver."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path

from ..config import FrameConfig
from ..io.blocks import channel_blocks
from ..io.source import BlockStats, RecordingSource, open_recording
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings
from .stream import Receiver, ReceiverWarning

__all__ = ["receive_file", "recording_warnings"]


def recording_warnings(path: str | Path, stats: BlockStats, *, n_frames: int | None) -> list[str]:
    """One-line notes on a whole recording: silent, clipped, no frame found.

    Parameters
    ----------
    path : str or Path
        The recording as named in the notes.
    stats : BlockStats
        What its blocks held.
    n_frames : int or None
        Frames found (0: a note says none was); None: not known (part of a recording).

    Returns
    -------
    list of str
    """
    notes = []
    if stats.silent:
        notes.append(f"recording {path} is silent (all samples are zero)")
    if stats.clipped:
        notes.append(f"recording {path}: {stats.clipped} samples are clipped at full scale; measurements may be biased")
    if n_frames == 0:
        notes.append(f"no frame found in {path}")
    return notes


def receive_file(
    path: str | Path | RecordingSource,
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
    path : str, Path or RecordingSource
        A recording file (:func:`~seamodem.io.source.open_recording`: WAV or
        any format soundfile reads, ``.mat``), or an open source (a file
        already opened, a stream); any sample rate that holds the band.
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
    source = path if isinstance(path, RecordingSource) else open_recording(path)
    ch = source.one_channel(channel)
    rx = Receiver(config, emissions=emissions, settings=settings, pilot=pilot, payloads=payloads, on_frame=on_frame)
    stats = BlockStats()
    blocks = channel_blocks(source, ch, stats=stats, progress=progress)
    n = 0
    for rec in rx.run(blocks, fs=source.sample_rate_hz):
        n += 1
        yield rec
    for note in recording_warnings(source.name, stats, n_frames=n):
        warnings.warn(note, ReceiverWarning, stacklevel=2)
