"""One channel of a recording in checked blocks: :func:`read_blocks`, a thin wrapper over the source.

Every reader goes through :class:`~seamodem.io.source.RecordingSource`; this
module keeps the one-channel form (1-D blocks) and the names it has had.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .source import BLOCK, BlockStats, RecordingSource, clip_level, open_recording
from .wav import AudioInfo

__all__ = ["BLOCK", "BlockStats", "clip_level", "read_blocks", "channel_blocks"]


def channel_blocks(source: RecordingSource, channel: int, **kwargs) -> Iterator[np.ndarray]:
    """One channel of a source as 1-D contiguous blocks.

    Parameters
    ----------
    source : RecordingSource
    channel : int
        Channel, numbered from 0.
    **kwargs
        As :meth:`RecordingSource.blocks` (``start``, ``stop``, ``counted``, ``stats``, ``block``, ``progress``).

    Yields
    ------
    numpy.ndarray, shape (n,)
        float64.
    """
    for data in source.blocks([channel], **kwargs):
        yield data[:, 0]


def read_blocks(
    path: str | Path,
    *,
    channel: int,
    start: int = 0,
    stop: int,
    counted: tuple[int, int] | None = None,
    stats: BlockStats | None = None,
    name: str | Path | None = None,
    block: int = BLOCK,
    progress: bool | None = False,
    info: AudioInfo | None = None,
) -> Iterator[np.ndarray]:
    """Samples [start, stop) of one channel of ``path``, in blocks of ``block`` samples.

    Parameters
    ----------
    path : str or Path
        Recording (:func:`~seamodem.io.source.open_recording`).
    channel : int
        0-based channel.
    start, stop : int
        Sample range [samples]; ``stop`` is at most the samples present.
    counted : (int, int), optional
        Sample range over which clipping and silence are counted in ``stats``
        (default [start, stop)).
    stats : BlockStats, optional
        Filled as blocks are read.
    name : str or Path, optional
        The recording as named in error messages (default ``path``).
    block : int
        Samples per block.
    progress : bool, optional
        Progress bar (None: on a terminal).
    info : AudioInfo, optional
        The file's :func:`~seamodem.io.wav.wav_info`, when the caller has it
        (and has reported its note); else read here, silently.

    Yields
    ------
    numpy.ndarray, shape (n,)
        float64.

    Raises
    ------
    InputFileError
        Truncated or corrupt file, NaN or infinite samples.
    """
    import warnings

    from .wav import RecordingWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingWarning)  # the caller has reported the file's notes
        source = open_recording(path, info=info, name=None if name is None else str(name))
    yield from channel_blocks(source, channel, start=start, stop=stop, counted=counted, stats=stats, block=block,
                              progress=progress)
