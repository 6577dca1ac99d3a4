"""WAV (and other audio) input and output through soundfile, with checked inputs.

numpy and soundfile are imported by the functions that use them: the command
line reads :data:`SUBTYPES` for its help without waiting for either.
"""

from __future__ import annotations

import contextlib
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

if TYPE_CHECKING:
    import numpy as np
    import soundfile

from ..errors import InputFileError

__all__ = ["SUBTYPES", "AudioInfo", "RecordingWarning", "open_audio", "write_wav_blocks", "read_wav", "wav_info",
           "wav_channel"]

#: CLI names of the sample formats → soundfile subtypes.
SUBTYPES = {"float32": "FLOAT", "pcm16": "PCM_16", "pcm24": "PCM_24"}


def write_wav_blocks(path: str | Path, blocks: Iterable[np.ndarray], *, fs: int, subtype: str = "FLOAT") -> int:
    """Write mono blocks to a WAV file; returns the number of samples written.

    ``subtype`` is a soundfile subtype (``"FLOAT"``, ``"PCM_16"``, ``"PCM_24"``);
    PCM values are clipped by soundfile at ±1 full scale.

    Parameters
    ----------
    path : str or Path
        Output WAV file, overwritten.
    blocks : iterable of numpy.ndarray
        Consecutive real sample blocks, each of shape ``(n_block,)``, full
        scale ±1.
    fs : int
        Sample rate [Hz].
    subtype : str, optional
        Sample format; default 32-bit float.

    Returns
    -------
    int
        Number of samples written.
    """
    import numpy as np
    import soundfile

    n = 0
    with soundfile.SoundFile(str(path), "w", samplerate=int(fs), channels=1, subtype=subtype, format="WAV") as f:
        for block in blocks:
            f.write(np.asarray(block, dtype=np.float64))
            n += len(block)
    return n


#: bytes per sample of the PCM and float subtypes whose sample count follows from the data chunk's length
_SAMPLE_BYTES = {"PCM_U8": 1, "PCM_S8": 1, "PCM_16": 2, "PCM_24": 3, "PCM_32": 4, "FLOAT": 4, "DOUBLE": 8}


class RecordingWarning(UserWarning):
    """A recording that is read, but not as its header describes it (a crashed or streaming recorder)."""


@dataclass(frozen=True)
class AudioInfo:
    """What a recording holds, as read: sample rate, channels, the samples actually present.

    Attributes
    ----------
    samplerate : int
        [Hz].
    channels : int
    frames : int
        Samples per channel that can be read (fewer than the header says for a
        cut file; the data present for a header that says 0).
    subtype : str
        soundfile subtype ("PCM_16", "FLOAT"...).
    data_offset : int or None
        Byte offset of the samples when they must be read past the header
        (a data chunk declared 0 bytes long); None otherwise.
    note : str or None
        One line on how the header lied, None for a sound file.
    """

    samplerate: int
    channels: int
    frames: int
    subtype: str
    data_offset: int | None = None
    note: str | None = None

    @property
    def duration(self) -> float:
        """[s]."""
        return self.frames / self.samplerate


def _riff_data_chunk(path: Path) -> tuple[int, int, int] | None:
    """(offset of the samples, bytes the data chunk declares, bytes present) of a RIFF/WAVE file, else None."""
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
            return None
        pos = 12
        while pos + 8 <= size:
            f.seek(pos)
            chunk = f.read(8)
            declared = int.from_bytes(chunk[4:8], "little")
            if chunk[:4] == b"data":
                return pos + 8, declared, size - pos - 8
            pos += 8 + declared + (declared & 1)
    return None


def _header_note(path: Path, declared: int, present: int, frames: int, width: int) -> str | None:
    """One line on a data chunk whose declared length is not what the file holds; None when it is."""
    if declared == 0xFFFFFFFF:
        said = "an unknown length (0xFFFFFFFF, a streaming recorder's placeholder)"
    elif declared == 0 and present:
        said = "0 bytes (a recorder that never closed the file)"
    elif declared > present:
        said = f"{declared // width} samples"
    else:
        return None
    cut = f"; the last {present % width} byte(s) are an incomplete sample" if present % width else ""
    return f"recording {path}: the header says {said}, the file holds {frames} samples: reading those{cut}"


def wav_info(path: str | Path) -> AudioInfo:
    """What an audio file holds, with a one-line error for a missing, empty or unreadable file.

    A WAV whose header lies about its length (0xFFFFFFFF or 0 from a streaming
    or crashed recorder, or more bytes than the file holds) is read as far as
    its samples go; :attr:`AudioInfo.note` says so, and a
    :class:`RecordingWarning` carries it.

    Parameters
    ----------
    path : str or Path
        An audio file readable by soundfile (WAV, FLAC, ...).

    Returns
    -------
    AudioInfo
        Sample rate, channels, the samples present and, for a lying header,
        the data offset and a note.

    Raises
    ------
    InputFileError
        Missing, empty, or unreadable file.
    """
    import soundfile

    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"recording not found: {path}")
    if path.stat().st_size == 0:
        raise InputFileError(f"recording {path} is empty (0 bytes)")
    try:
        sf = soundfile.info(str(path))
    except (soundfile.LibsndfileError, RuntimeError) as exc:
        raise InputFileError(f"recording {path} is not a readable audio file: {exc}") from None
    info = AudioInfo(int(sf.samplerate), int(sf.channels), int(sf.frames), sf.subtype)
    chunk = _riff_data_chunk(path) if sf.subtype in _SAMPLE_BYTES else None
    if chunk is not None:
        offset, declared, present = chunk
        width = _SAMPLE_BYTES[sf.subtype] * info.channels
        frames = present // width
        # libsndfile reads what is there for a too-long header (it counts the samples itself), nothing for 0
        info = replace(info, frames=min(info.frames, frames) if info.frames else frames,
                       data_offset=offset if not info.frames and frames else None)
        info = replace(info, note=_header_note(path, declared, present, info.frames, width))
    if info.note:
        warnings.warn(info.note, RecordingWarning, stacklevel=2)
    return info


class _Window:
    """The bytes of a file from ``offset`` on, as a file object (soundfile reads them as RAW samples)."""

    def __init__(self, path: Path, offset: int, length: int):
        self._f, self._offset, self._length = open(path, "rb"), offset, length
        self._f.seek(offset)

    def seek(self, pos: int, whence: int = 0) -> int:
        base = (self._offset, self._f.tell(), self._offset + self._length)[whence]
        return self._f.seek(base + pos) - self._offset

    def tell(self) -> int:
        return self._f.tell() - self._offset

    def read(self, n: int = -1) -> bytes:
        left = max(self._offset + self._length - self._f.tell(), 0)
        return self._f.read(left if n < 0 else min(n, left))

    def close(self) -> None:
        self._f.close()


@contextlib.contextmanager
def open_audio(path: str | Path, info: AudioInfo | None = None):
    """A :class:`soundfile.SoundFile` over the samples of ``path`` that :func:`wav_info` found, for reading."""
    import soundfile

    path = Path(path)
    info = wav_info(path) if info is None else info
    if info.data_offset is None:
        with soundfile.SoundFile(str(path)) as f:
            yield f
        return
    width = _SAMPLE_BYTES[info.subtype] * info.channels
    window = _Window(path, info.data_offset, info.frames * width)
    try:
        with soundfile.SoundFile(window, samplerate=info.samplerate, channels=info.channels, subtype=info.subtype,
                                 format="RAW", endian="LITTLE") as f:
            yield f
    finally:
        window.close()


def wav_channel(path: str | Path, *, channel: int | None = None) -> tuple[AudioInfo, int]:
    """Header of a recording that holds samples, and the channel to read (0 for mono).

    Raises
    ------
    InputFileError
        As :func:`wav_info`; no samples; several channels and ``channel`` not
        given; a channel that does not exist.
    """
    info = wav_info(path)
    if info.frames == 0:
        raise InputFileError(f"recording {path} holds no samples")
    if info.channels > 1 and channel is None:
        raise InputFileError(
            f"recording {path} has {info.channels} channels: choose one with --channel (0 to {info.channels - 1})"
        )
    ch = 0 if channel is None else int(channel)
    if not 0 <= ch < info.channels:
        raise InputFileError(
            f"channel {ch} does not exist in {path}: it has {info.channels} channel(s), numbered from 0 "
            f"(0 to {info.channels - 1})"
        )
    return info, ch


def read_wav(path: str | Path, *, channel: int | None = None) -> tuple[np.ndarray, int]:
    """Read one channel of an audio file as float64 in [−1, 1].

    Parameters
    ----------
    path : str or Path
    channel : int, optional
        Channel index of a multichannel file (required when it has several).

    Returns
    -------
    samples : numpy.ndarray, shape (n_samples,)
    fs : int
        Sample rate from the file [Hz].

    Raises
    ------
    InputFileError
        Missing, empty, truncated or unreadable file; no samples; NaN or
        infinite samples; a channel that does not exist.
    """
    import numpy as np
    import soundfile

    info, ch = wav_channel(path, channel=channel)
    try:
        with open_audio(path, info) as f:
            data = f.read(info.frames, dtype="float64", always_2d=True)
    except (soundfile.LibsndfileError, RuntimeError) as exc:
        raise InputFileError(f"recording {path} is corrupt: {exc}") from None
    if data.shape[0] < info.frames:
        raise InputFileError(f"recording {path} is truncated: it holds {info.frames} samples, read {data.shape[0]}")
    x = np.ascontiguousarray(data[:, ch])
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise InputFileError(f"recording {path} contains NaN or infinite samples (first at sample {bad[0]})")
    return x, info.samplerate
