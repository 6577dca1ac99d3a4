"""WAV (and other audio) input and output through soundfile, with checked inputs.

numpy and soundfile are imported by the functions that use them: the command
line reads :data:`SUBTYPES` for its help without waiting for either.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Iterable

if TYPE_CHECKING:
    import numpy as np
    import soundfile

from ..errors import InputFileError

__all__ = ["SUBTYPES", "write_wav_blocks", "read_wav", "wav_info", "wav_channel"]

#: CLI names of the sample formats → soundfile subtypes.
SUBTYPES = {"float32": "FLOAT", "pcm16": "PCM_16", "pcm24": "PCM_24"}


def write_wav_blocks(path: str | Path, blocks: Iterable[np.ndarray], *, fs: int, subtype: str = "FLOAT") -> int:
    """Write mono blocks to a WAV file; returns the number of samples written.

    ``subtype`` is a soundfile subtype (``"FLOAT"``, ``"PCM_16"``, ``"PCM_24"``);
    PCM values are clipped by soundfile at ±1 full scale.
    """
    import numpy as np
    import soundfile

    n = 0
    with soundfile.SoundFile(str(path), "w", samplerate=int(fs), channels=1, subtype=subtype, format="WAV") as f:
        for block in blocks:
            f.write(np.asarray(block, dtype=np.float64))
            n += len(block)
    return n


def _check_riff_complete(path: Path) -> None:
    """Raise if a RIFF/WAVE file's data chunk is shorter than its header says.

    libsndfile silently reads what is there; a cut recording must not pass for a whole one.
    """
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
            return
        pos = 12
        while pos + 8 <= size:
            f.seek(pos)
            chunk = f.read(8)
            declared = int.from_bytes(chunk[4:8], "little")
            if chunk[:4] == b"data":
                available = size - pos - 8
                if available < declared:
                    raise InputFileError(
                        f"recording {path} is truncated: its data chunk declares {declared} bytes, "
                        f"only {available} are present"
                    )
                return
            pos += 8 + declared + (declared & 1)


def wav_info(path: str | Path) -> soundfile._SoundFileInfo:
    """Header of an audio file, with a one-line error for a missing, empty, truncated or unreadable file."""
    import soundfile

    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"recording not found: {path}")
    if path.stat().st_size == 0:
        raise InputFileError(f"recording {path} is empty (0 bytes)")
    try:
        info = soundfile.info(str(path))
    except (soundfile.LibsndfileError, RuntimeError) as exc:
        raise InputFileError(f"recording {path} is not a readable audio file: {exc}") from None
    _check_riff_complete(path)
    return info


def wav_channel(path: str | Path, *, channel: int | None = None) -> tuple[soundfile._SoundFileInfo, int]:
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
        raise InputFileError(f"recording {path} has {info.channels} channels: choose one with --channel")
    ch = 0 if channel is None else int(channel)
    if not 0 <= ch < info.channels:
        raise InputFileError(f"channel {ch} does not exist in {path} ({info.channels} channels)")
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
        data, fs = soundfile.read(str(path), dtype="float64", always_2d=True)
    except (soundfile.LibsndfileError, RuntimeError) as exc:
        raise InputFileError(f"recording {path} is truncated or corrupt: {exc}") from None
    if data.shape[0] < info.frames:
        raise InputFileError(f"recording {path} is truncated: header says {info.frames} samples, read {data.shape[0]}")
    x = np.ascontiguousarray(data[:, ch])
    if not np.all(np.isfinite(x)):
        raise InputFileError(f"recording {path} contains NaN or infinite samples")
    return x, int(fs)
