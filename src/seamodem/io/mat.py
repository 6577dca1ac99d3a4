"""Recordings as field recorders write them: any soundfile format, MATLAB ``.mat`` v5 and v7.3 (HDF5).

:func:`open_recording` gives a :class:`RecordingSource` that reads blocks of
every channel, whatever the format, and counts clipped stretches as it goes;
:func:`read_recording` reads one channel whole (template excerpts).

``.mat`` conventions
--------------------
* The samples are one real 1-D or 2-D numeric variable (``--mat-variable
  NAME``; without it, the file's only non-scalar numeric variable). Of a 2-D
  array the longer axis is time, the other the channels (MATLAB's
  n_samples × n_channels and its transpose both work).
* The sample rate comes from a scalar variable named ``fs``, ``Fs``, ``FS``,
  ``sample_rate``, ``sample_rate_hz``, ``sampleRate``, ``SampleRate`` or
  ``srate``, or from the command line (which wins, with a warning when the two
  differ).
* v5 files are read whole by ``scipy.io.loadmat``; v7.3 files (HDF5) through
  h5py, block by block, so their memory stays bounded.

A complex, 3-D, empty or non-numeric variable, a missing variable or sample
rate, and NaN or infinite samples are one-line :class:`InputFileError`s.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputFileError

__all__ = ["MAT_RATE_NAMES", "RecordingSource", "ClipReport", "open_recording", "read_recording", "is_mat", "RecordingWarning"]

MAT_RATE_NAMES = ("fs", "Fs", "FS", "sample_rate", "sample_rate_hz", "sampleRate", "SampleRate", "srate")
#: samples per block read
BLOCK = 1 << 18


class RecordingWarning(UserWarning):
    """A readable but odd recording (rates that disagree, clipped stretches)."""


def is_mat(path: str | Path) -> bool:
    """True for a ``.mat`` file name."""
    return Path(path).suffix.lower() == ".mat"


def _is_v73(path: Path) -> bool:
    with open(path, "rb") as f:
        head = f.read(128)
    return head.startswith(b"MATLAB 7.3") or head[:8] == b"\x89HDF\r\n\x1a\n"


@dataclass
class ClipReport:
    """Clipped samples seen so far, per channel, as stretches of consecutive samples."""

    level: float
    samples: dict[int, int] = field(default_factory=dict)
    stretches: dict[int, list[tuple[int, int]]] = field(default_factory=dict)

    def add(self, block: np.ndarray, start: int, channels: list[int]) -> None:
        for j, ch in enumerate(channels):
            clipped = np.abs(block[:, j]) >= self.level
            n = int(np.count_nonzero(clipped))
            if not n:
                continue
            self.samples[ch] = self.samples.get(ch, 0) + n
            edges = np.flatnonzero(np.diff(np.concatenate([[0], clipped.astype(np.int8), [0]])))
            runs = self.stretches.setdefault(ch, [])
            for a, b in zip(edges[::2], edges[1::2]):
                a, b = start + int(a), start + int(b)
                if runs and runs[-1][1] == a:
                    runs[-1] = (runs[-1][0], b)
                else:
                    runs.append((a, b))

    def notes(self, name: str, fs: float) -> list[str]:
        """One line per clipped channel."""
        out = []
        for ch in sorted(self.samples):
            runs = self.stretches[ch]
            first = runs[0][0] / fs
            longest = max(b - a for a, b in runs) / fs
            out.append(
                f"recording {name} channel {ch}: {self.samples[ch]} clipped samples in {len(runs)} stretch"
                f"{'es' if len(runs) != 1 else ''} (first at {first:.3f} s, longest {longest * 1e3:.2f} ms); "
                "detections there may be biased"
            )
        return out

    def clipped_between(self, channel: int, lo: int, hi: int) -> int:
        """Clipped samples of ``channel`` in [lo, hi)."""
        return sum(max(0, min(b, hi) - max(a, lo)) for a, b in self.stretches.get(channel, []))


class RecordingSource:
    """Blocks of every channel of a recording, with its rate and length.

    Use :func:`open_recording` to make one.

    Attributes
    ----------
    path : Path
    sample_rate_hz : float
    n_samples, n_channels : int
    kind : str
        "audio" (soundfile), "mat5" or "mat73".
    clips : ClipReport
        Filled as blocks are read.
    """

    def __init__(self, path: Path, sample_rate_hz: float, n_samples: int, n_channels: int, kind: str, reader, level: float):
        self.path, self.sample_rate_hz = path, float(sample_rate_hz)
        self.n_samples, self.n_channels, self.kind = int(n_samples), int(n_channels), kind
        self._reader = reader
        self.clips = ClipReport(level)

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    def check_channel(self, channel: int | None) -> list[int]:
        """The channels to read: ``[channel]``, or all of them for None."""
        if channel is None:
            return list(range(self.n_channels))
        if not 0 <= channel < self.n_channels:
            raise InputFileError(f"channel {channel} does not exist in {self.path} ({self.n_channels} channels)")
        return [int(channel)]

    def blocks(self, channels: list[int], *, block: int = BLOCK) -> Iterator[np.ndarray]:
        """Blocks of shape (n, len(channels)), float64, in order; NaN or infinite samples are an error."""
        pos = 0
        for data in self._reader(channels, block):
            if not np.all(np.isfinite(data)):
                raise InputFileError(f"recording {self.path} contains NaN or infinite samples (near sample {pos})")
            self.clips.add(data, pos, channels)
            pos += len(data)
            yield data
        if pos < self.n_samples:
            raise InputFileError(f"recording {self.path} is truncated: it ends at sample {pos}, before {self.n_samples}")


def _rate_from(candidates: dict, path: Path) -> float | None:
    for name in MAT_RATE_NAMES:
        if name in candidates:
            value = np.asarray(candidates[name]).reshape(-1)
            if value.size != 1 or not np.issubdtype(value.dtype, np.number) or np.iscomplexobj(value):
                raise InputFileError(f"{path}: sample-rate variable {name!r} must be one real number")
            rate = float(value[0])
            if not (math.isfinite(rate) and rate > 0):
                raise InputFileError(f"{path}: sample-rate variable {name!r} must be positive, got {rate!r}")
            return rate
    return None


def _choose_variable(shapes: dict[str, tuple], numeric: set[str], path: Path, name: str | None) -> str:
    if name is not None:
        if name not in shapes:
            listed = ", ".join(sorted(shapes)) or "none"
            raise InputFileError(f"{path} has no variable {name!r} (variables: {listed})")
        return name
    arrays = [k for k in shapes if k in numeric and math.prod(shapes[k]) > 1]
    if len(arrays) != 1:
        listed = ", ".join(sorted(arrays)) or "none"
        raise InputFileError(f"{path}: choose the variable holding the samples with --mat-variable (arrays: {listed})")
    return arrays[0]


def _check_shape(path: Path, name: str, shape: tuple, dtype, complex_: bool) -> tuple[int, int, bool]:
    """(n_samples, n_channels, time_first) of a sample array, or a one-line error."""
    if complex_:
        raise InputFileError(f"{path}: variable {name!r} is complex; a recording must be real samples")
    if dtype is not None and not (np.issubdtype(dtype, np.number) or dtype == np.bool_):
        raise InputFileError(f"{path}: variable {name!r} is not a numeric array ({dtype})")
    dims = [d for d in shape]
    if len(dims) > 2 and sum(d > 1 for d in dims) > 2:
        raise InputFileError(f"{path}: variable {name!r} is {len(dims)}-D {tuple(shape)}; expected samples × channels")
    dims2 = [d for d in dims if d > 1] or [1]
    if len(dims) > 2:
        dims = dims2 + [1] * (2 - len(dims2))
    if len(dims) == 1:
        return int(dims[0]), 1, True
    if min(dims) == 0:
        raise InputFileError(f"{path}: variable {name!r} is empty")
    time_first = dims[0] >= dims[1]
    return (int(dims[0]), int(dims[1]), True) if time_first else (int(dims[1]), int(dims[0]), False)


def _resolve_rate(path: Path, in_file: float | None, given: float | None) -> float:
    if given is not None:
        if not (math.isfinite(given) and given > 0):
            raise InputFileError(f"sample-rate: must be a positive number of Hz, got {given!r}")
        if in_file is not None and abs(in_file - given) > 1e-9 * given:
            warnings.warn(
                f"{path}: the file says {in_file:g} Hz, the command line {given:g} Hz; using {given:g} Hz",
                RecordingWarning,
                stacklevel=3,
            )
        return float(given)
    if in_file is None:
        raise InputFileError(
            f"{path}: no sample rate in the file (a scalar named {', '.join(MAT_RATE_NAMES[:3])}, ...); give --sample-rate"
        )
    return in_file


def _open_mat5(path: Path, variable: str | None, rate: float | None) -> RecordingSource:
    import scipy.io

    try:
        m = scipy.io.loadmat(str(path))
    except (ValueError, TypeError, OSError, NotImplementedError, IndexError, KeyError) as exc:
        raise InputFileError(f"{path} is not a readable MATLAB file: {str(exc).splitlines()[0] if str(exc) else exc!r}") from None
    data = {k: v for k, v in m.items() if not k.startswith("__")}
    numeric = {k for k, v in data.items() if isinstance(v, np.ndarray) and np.issubdtype(v.dtype, np.number)}
    name = _choose_variable({k: np.shape(v) for k, v in data.items()}, numeric, path, variable)
    x = np.asarray(data[name])
    n, n_ch, time_first = _check_shape(path, name, x.shape, x.dtype, np.iscomplexobj(x))
    x = np.squeeze(x) if x.ndim > 2 else x
    x2 = x.reshape(-1, 1) if x.ndim == 1 else (x if time_first else x.T)
    x2 = np.ascontiguousarray(x2, dtype=np.float64)
    fs = _resolve_rate(path, _rate_from(data, path), rate)

    def reader(channels, block):
        for lo in range(0, n, block):
            yield x2[lo : lo + block, channels]

    return RecordingSource(path, fs, n, n_ch, "mat5", reader, _mat_clip_level(x.dtype))


def _mat_clip_level(dtype) -> float:
    """Integer samples clip at their type's extremes; floats at ±1 (full scale of normalised audio)."""
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return 1.0


def _open_mat73(path: Path, variable: str | None, rate: float | None) -> RecordingSource:
    try:
        import h5py
    except ImportError:
        raise InputFileError(
            f"{path} is a MATLAB v7.3 (HDF5) file: reading it needs h5py (pip install 'seamodem[mat]')"
        ) from None
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputFileError(f"{path} is not a readable MATLAB v7.3 file: {exc}") from None
    with f:
        datasets = {k: v for k, v in f.items() if isinstance(v, h5py.Dataset)}
        shapes = {k: tuple(v.shape) for k, v in datasets.items()}
        numeric = {k for k, v in datasets.items() if v.dtype.names is None and np.issubdtype(v.dtype, np.number)}
        complex_ = {
            k for k, v in datasets.items()
            if (v.dtype.names and {"real", "imag"} <= set(v.dtype.names)) or np.issubdtype(v.dtype, np.complexfloating)
        }
        numeric -= complex_
        name = _choose_variable(shapes, numeric | complex_, path, variable)
        ds = datasets[name]
        if ds.dtype.names is not None and name not in complex_:
            raise InputFileError(f"{path}: variable {name!r} is not a numeric array")
        n, n_ch, time_first = _check_shape(path, name, ds.shape, None if name in complex_ else ds.dtype, name in complex_)
        in_file = _rate_from({k: datasets[k][()] for k in MAT_RATE_NAMES if k in numeric}, path)
        level = _mat_clip_level(ds.dtype)
    fs = _resolve_rate(path, in_file, rate)
    squeeze = len(ds.shape) > 2

    def reader(channels, block):
        with h5py.File(path, "r") as f:
            d = f[name]
            for lo in range(0, n, block):
                hi = min(n, lo + block)
                if squeeze:
                    part = np.squeeze(d[()])
                    part = part.reshape(-1, 1) if part.ndim == 1 else part
                    part = part[lo:hi] if time_first else part[:, lo:hi].T
                elif len(d.shape) == 1:
                    part = d[lo:hi].reshape(-1, 1)
                elif time_first:
                    part = d[lo:hi, :]
                else:
                    part = d[:, lo:hi].T
                yield np.asarray(part, dtype=np.float64).reshape(hi - lo, n_ch)[:, channels]

    return RecordingSource(path, fs, n, n_ch, "mat73", reader, level)


def _open_audio(path: Path, rate: float | None) -> RecordingSource:
    import soundfile

    from .blocks import clip_level
    from .wav import wav_info

    info = wav_info(path)
    if info.frames == 0:
        raise InputFileError(f"recording {path} holds no samples")
    fs = _resolve_rate(path, float(info.samplerate), rate)

    def reader(channels, block):
        with soundfile.SoundFile(str(path)) as f:
            while True:
                try:
                    data = f.read(block, dtype="float64", always_2d=True)
                except (soundfile.LibsndfileError, RuntimeError) as exc:
                    raise InputFileError(f"recording {path} is truncated or corrupt: {exc}") from None
                if data.shape[0] == 0:
                    return
                yield data[:, channels]

    return RecordingSource(path, fs, info.frames, info.channels, "audio", reader, clip_level(info.subtype))


def open_recording(
    path: str | Path, *, mat_variable: str | None = None, sample_rate_hz: float | None = None
) -> RecordingSource:
    """Open a recording of any supported format.

    Parameters
    ----------
    path : str or Path
        Audio file (WAV, FLAC, ... anything soundfile reads) or ``.mat`` (v5 or v7.3).
    mat_variable : str, optional
        ``.mat``: the variable holding the samples.
    sample_rate_hz : float, optional
        Overrides (``.mat``: supplies) the file's sample rate [Hz].

    Raises
    ------
    InputFileError
        Missing, empty or unreadable file; missing variable or rate; complex,
        3-D or empty samples.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"recording not found: {path}")
    if path.stat().st_size == 0:
        raise InputFileError(f"recording {path} is empty (0 bytes)")
    if is_mat(path):
        opener = _open_mat73 if _is_v73(path) else _open_mat5
        return opener(path, mat_variable, sample_rate_hz)
    if mat_variable:
        raise InputFileError(f"mat-variable: {path} is not a .mat file")
    return _open_audio(path, sample_rate_hz)


def read_recording(
    path: str | Path, *, mat_variable: str | None = None, sample_rate_hz: float | None = None, channel: int = 0
) -> tuple[np.ndarray, float]:
    """One channel of a recording, whole: (samples (n_samples,), fs [Hz])."""
    src = open_recording(path, mat_variable=mat_variable, sample_rate_hz=sample_rate_hz)
    (ch,) = src.check_channel(channel)
    x = np.concatenate([b[:, 0] for b in src.blocks([ch])])
    return x, src.sample_rate_hz
