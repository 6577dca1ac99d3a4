"""Recordings read as they arrive: a pipe, stdin, a socket; a WAV stream or raw PCM.

A :class:`StreamSource` is a :class:`~seamodem.io.source.RecordingSource`
whose length is unknown (``n_samples`` is None): it is read once, front to
back, with the same checks and statistics as a file.
"""

from __future__ import annotations

import math
from typing import IO

import numpy as np

from ..errors import InputFileError
from .matlab import refuse_huge_rate
from .source import RecordingSource, columns, clip_level
from .wav import SUBTYPES

__all__ = ["StreamSource", "open_stream"]


class StreamSource(RecordingSource):
    """A recording read as it arrives: a pipe, stdin, a socket (read once, front to back).

    Use :func:`open_stream` to make one.

    Parameters
    ----------
    sound : soundfile.SoundFile
        Open for reading.
    name : str
        The stream as named in messages.
    """

    def __init__(self, sound, *, name: str):
        super().__init__(name, sound.samplerate, sound.channels, None, kind="stream",
                         clip_level=clip_level(sound.subtype))
        self._sound, self._pos = sound, 0

    def _read(self, channels, start, stop, block):
        import soundfile

        if start < self._pos:
            raise InputFileError(f"recording {self.name} is a stream: it is read once, from sample {self._pos} on")
        while self._pos < start:  # skip to start
            if not len(self._chunk(min(block, start - self._pos))):
                return
        while stop is None or self._pos < stop:
            want = block if stop is None else min(block, stop - self._pos)
            try:
                data = self._chunk(want)
            except (soundfile.LibsndfileError, RuntimeError) as exc:
                raise InputFileError(f"recording {self.name} is corrupt: {exc}") from None
            if not len(data):
                return
            yield columns(data, channels)

    def _chunk(self, n: int) -> np.ndarray:
        data = self._sound.read(n, dtype="float64", always_2d=True)
        self._pos += len(data)
        return data

    def close(self) -> None:
        """Close the stream."""
        self._sound.close()


def open_stream(
    stream: IO[bytes] | int,
    *,
    sample_rate_hz: float | None = None,
    n_channels: int = 1,
    sample_format: str | None = None,
    name: str = "stdin",
) -> StreamSource:
    """A recording arriving on a pipe, stdin or any binary file object.

    Parameters
    ----------
    stream : binary file object or int
        ``sys.stdin.buffer``, an ``os.pipe()`` end, an open file, a BytesIO;
        or a file descriptor. A pipe is read through its descriptor (nothing
        of it must have been read before).
    sample_rate_hz : float, optional
        Raw PCM: its rate [Hz]. Without it the stream is a WAV stream (its
        header gives rate, channels and format; its length is ignored).
    n_channels : int
        Raw PCM: interleaved channels.
    sample_format : str, optional
        Raw PCM: "pcm16" (default), "pcm24" or "float32" (little-endian).
    name : str
        The stream as named in messages.

    Returns
    -------
    StreamSource

    Raises
    ------
    InputFileError
        Not a WAV stream; a bad raw format.
    """
    import soundfile

    src = stream
    if not isinstance(stream, int):
        seekable = getattr(stream, "seekable", lambda: False)()
        if not seekable and hasattr(stream, "fileno"):
            src = stream.fileno()  # libsndfile reads a pipe through its descriptor
    closefd = False
    try:
        if sample_rate_hz is None:
            if sample_format is not None:
                raise InputFileError(f"{name}: a sample format is given for a raw stream only (give its rate too)")
            sound = soundfile.SoundFile(src, closefd=closefd) if isinstance(src, int) else soundfile.SoundFile(src)
        else:
            fmt = "pcm16" if sample_format is None else sample_format
            if fmt not in SUBTYPES:
                raise InputFileError(f"{name}: raw sample format must be one of {', '.join(SUBTYPES)}, got {fmt!r}")
            if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0) or int(n_channels) < 1:
                raise InputFileError(f"{name}: a raw stream needs a positive rate and channels >= 1")
            refuse_huge_rate(sample_rate_hz, "sample-rate")
            kwargs = dict(samplerate=int(round(sample_rate_hz)), channels=int(n_channels), subtype=SUBTYPES[fmt],
                          format="RAW", endian="LITTLE")
            sound = soundfile.SoundFile(src, closefd=closefd, **kwargs) if isinstance(src, int) else \
                soundfile.SoundFile(src, **kwargs)
    except (soundfile.LibsndfileError, RuntimeError) as exc:
        raise InputFileError(f"{name} is not a readable audio stream: {exc}") from None
    if sample_rate_hz is None:
        try:
            refuse_huge_rate(sound.samplerate, name, " (a damaged header?)")
        except InputFileError:
            sound.close()
            raise
    out = StreamSource(sound, name=name)
    if sample_rate_hz is not None:
        out.sample_rate_hz = float(sample_rate_hz)
    return out
