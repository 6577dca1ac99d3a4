"""One block reader for recordings: samples of one channel, checked as they are read.

The receiver (:func:`~seamodem.receive.recording.receive_file`) and batch
decoding (:func:`~seamodem.batch.decode.decode_part`) both read through
:func:`read_blocks`, so a whole file and its segments see the same blocks and
the same checks: NaN or infinite samples and a read that stops short are
errors; clipped and silent samples are counted in :class:`BlockStats`. A WAV
whose header lies about its length is read as far as its samples go
(:func:`~seamodem.io.wav.wav_info`, which reports it).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile

from .._progress import progress_bar
from ..errors import InputFileError
from .wav import AudioInfo, RecordingWarning, open_audio, wav_info

__all__ = ["BLOCK", "BlockStats", "clip_level", "read_blocks"]

#: samples read per block
BLOCK = 1 << 20


def clip_level(subtype: str) -> float:
    """|sample| at or above which a sample counts as clipped: full scale less half an LSB of PCM-16 for PCM files."""
    return 1.0 - 2.0**-15 if subtype.startswith("PCM") else 1.0


@dataclass
class BlockStats:
    """What :func:`read_blocks` saw over its counted range: clipped samples, and whether all were zero."""

    clipped: int = 0
    silent: bool = True
    read: int = 0


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
        Audio file.
    channel : int
        0-based channel.
    start, stop : int
        Sample range; ``stop`` is at most the samples present (``AudioInfo.frames``).
    counted : (int, int), optional
        Sample range over which clipping and silence are counted in ``stats``
        (default [start, stop); a segment counts only its own samples so that
        a file's totals add up).
    stats : BlockStats, optional
        Filled as blocks are read.
    name : str or Path, optional
        The recording as named in error messages (default ``path``).
    progress : bool, optional
        Progress bar (None: on a terminal).
    info : AudioInfo, optional
        The file's :func:`~seamodem.io.wav.wav_info`, when the caller has it
        (and has reported its note); else read here, silently.

    Raises
    ------
    InputFileError
        Truncated or corrupt file, NaN or infinite samples.
    """
    name = path if name is None else name
    lo, hi = (start, stop) if counted is None else counted
    stats = BlockStats() if stats is None else stats
    if info is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RecordingWarning)  # the caller's wav_channel has reported it
            info = wav_info(path)
    with open_audio(path, info) as f, progress_bar(
        total=stop - start, desc="rx", unit="sample", unit_scale=True, enabled=progress
    ) as bar:
        level = clip_level(f.subtype)
        if start:
            f.seek(start)
        pos = start
        while pos < stop:
            try:
                data = f.read(min(block, stop - pos), dtype="float64", always_2d=True)
            except (soundfile.LibsndfileError, RuntimeError) as exc:
                raise InputFileError(f"recording {name} is truncated or corrupt: {exc}") from None
            if data.shape[0] == 0:
                raise InputFileError(f"recording {name} is truncated: it ends at sample {pos}, before {stop}")
            x = np.ascontiguousarray(data[:, channel])
            bad = np.flatnonzero(~np.isfinite(x))
            if bad.size:
                raise InputFileError(f"recording {name} contains NaN or infinite samples (first at sample {pos + bad[0]})")
            a, b = max(pos, lo) - pos, min(pos + len(x), hi) - pos
            if b > a:
                stats.clipped += int(np.count_nonzero(np.abs(x[a:b]) >= level))
                stats.silent = stats.silent and not np.any(x[a:b])
            pos += len(x)
            stats.read = pos - start
            bar.update(len(x))
            yield x
