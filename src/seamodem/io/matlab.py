"""MATLAB ``.mat`` recordings, v5 and v7.3 (HDF5), as field recorders write them.

:func:`open_mat` finds the samples and the rate in a file;
:func:`~seamodem.io.source.open_recording` makes the
:class:`~seamodem.io.source.RecordingSource` that reads them, as it does
for every other format.

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
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputFileError

__all__ = ["MAT_RATE_NAMES", "MatFile", "is_mat", "open_mat", "resolve_rate"]

MAT_RATE_NAMES = ("fs", "Fs", "FS", "sample_rate", "sample_rate_hz", "sampleRate", "SampleRate", "srate")


@dataclass(frozen=True)
class MatFile:
    """The samples of a ``.mat`` file, as found: in memory (v5) or read block by block (v7.3).

    Parameters
    ----------
    kind : str
        "mat5" or "mat73".
    n_samples, n_channels : int
    sample_rate_hz : float or None
        The file's rate [Hz], None when it has none.
    clip_level : float
        Integer samples clip at their type's largest value, floats at 1.0.
    samples : numpy.ndarray or None
        v5: shape (n_samples, n_channels), float64.
    reader : callable or None
        v7.3: ``reader(channels, start, stop, block)`` yields float64 blocks
        of shape (≤ block, len(channels)).
    """

    kind: str
    n_samples: int
    n_channels: int
    sample_rate_hz: float | None
    clip_level: float
    samples: np.ndarray | None = None
    reader: Callable[[list, int, int, int], Iterator[np.ndarray]] | None = None


def is_mat(path: str | Path) -> bool:
    """True for a ``.mat`` file name.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    return Path(path).suffix.lower() == ".mat"


def open_mat(path: Path, variable: str | None = None) -> MatFile:
    """Find the samples and the rate of a ``.mat`` file (v5 through scipy, v7.3 through h5py).

    Parameters
    ----------
    path : Path
        An existing ``.mat`` file.
    variable : str, optional
        The variable holding the samples (default: the only non-scalar numeric one).

    Returns
    -------
    MatFile

    Raises
    ------
    InputFileError
        Unreadable file; missing or ambiguous variable; complex, 3-D, empty or
        non-numeric samples; a sample-rate variable that is not one positive number.
    """
    return (_open_mat73 if _is_v73(path) else _open_mat5)(path, variable)


def _is_v73(path: Path) -> bool:
    """A MATLAB v7.3 file: HDF5, its signature at the start or after a user block of 512, 1024 or 2048 bytes."""
    with open(path, "rb") as f:
        head = f.read(2048 + 8)
    return head.startswith(b"MATLAB 7.3") or any(head[k:k + 8] == b"\x89HDF\r\n\x1a\n" for k in (0, 512, 1024, 2048))


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


def _open_mat5(path: Path, variable: str | None) -> MatFile:
    import scipy.io

    try:
        m = scipy.io.loadmat(str(path))
    except (ValueError, TypeError, OSError, NotImplementedError, IndexError, KeyError,
            scipy.io.matlab.MatReadError) as exc:
        raise InputFileError(f"{path} is not a readable MATLAB file: {str(exc).splitlines()[0] if str(exc) else exc!r}") from None
    except MemoryError:  # a damaged header declaring an array far larger than the file
        raise InputFileError(f"{path} is not a readable MATLAB file: it declares an array larger than memory "
                             f"(the file is {path.stat().st_size} bytes: damaged?)") from None
    data = {k: v for k, v in m.items() if not k.startswith("__")}
    numeric = {k for k, v in data.items() if isinstance(v, np.ndarray) and np.issubdtype(v.dtype, np.number)}
    name = _choose_variable({k: np.shape(v) for k, v in data.items()}, numeric, path, variable)
    x = np.asarray(data[name])
    n, n_ch, time_first = _check_shape(path, name, x.shape, x.dtype, np.iscomplexobj(x))
    x = np.squeeze(x) if x.ndim > 2 else x
    x2 = x.reshape(-1, 1) if x.ndim == 1 else (x if time_first else x.T)
    x2 = np.ascontiguousarray(x2, dtype=np.float64)
    return MatFile("mat5", n, n_ch, _rate_from(data, path), _mat_clip_level(x.dtype), samples=x2)


def _mat_clip_level(dtype) -> float:
    """Integer samples clip at their type's extremes; floats at ±1 (full scale of normalised audio)."""
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return 1.0


def _open_mat73(path: Path, variable: str | None) -> MatFile:
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
    try:
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
    except InputFileError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:  # h5py on a damaged file
        raise InputFileError(f"{path} is not a readable MATLAB v7.3 file: {exc}") from None
    squeeze = len(ds.shape) > 2

    def reader(channels, start, stop, block):
        try:
            yield from _read73(channels, start, stop, block)
        except InputFileError:
            raise
        except (OSError, RuntimeError, KeyError, ValueError, TypeError) as exc:  # damaged data blocks
            raise InputFileError(f"recording {path}: its samples cannot be read (damaged file?): {exc}") from None

    def _read73(channels, start, stop, block):
        with h5py.File(path, "r") as f:
            d = f[name]
            for lo in range(start, stop, block):
                hi = min(stop, lo + block)
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

    return MatFile("mat73", n, n_ch, in_file, level, reader=reader)


#: the highest sample rate [Hz] taken for an acoustic recording: hydrophone ADCs run at up to a few MHz; a
#: damaged .mat's rate (a flipped bit: 5.8e28 Hz) would otherwise size arrays beyond memory
MAX_SAMPLE_RATE_HZ = 100e6


def refuse_huge_rate(rate_hz: float, what: str, hint: str = "") -> None:
    """Raise when ``rate_hz`` is above :data:`MAX_SAMPLE_RATE_HZ`, the one bound every source shares.

    Parameters
    ----------
    rate_hz : float
        A positive, finite rate [Hz] (checked by the caller, whose message names its option).
    what : str
        What gave it: a file, ``stdin``, ``sample-rate``; it opens the message.
    hint : str
        Appended to the message, e.g. ``" (a damaged file?); give --sample-rate"``.

    Raises
    ------
    InputFileError
        Above :data:`MAX_SAMPLE_RATE_HZ`.

    Examples
    --------
    >>> refuse_huge_rate(96000.0, "x.wav")
    >>> refuse_huge_rate(5.8e28, "x.mat")
    Traceback (most recent call last):
    ...
    seamodem.errors.InputFileError: x.mat: a sample rate of 5.8e+28 Hz is above 1e+08 Hz, not an acoustic recording's
    """
    if rate_hz > MAX_SAMPLE_RATE_HZ:
        raise InputFileError(f"{what}: a sample rate of {rate_hz:g} Hz is above {MAX_SAMPLE_RATE_HZ:g} Hz, "
                             f"not an acoustic recording's{hint}")


def resolve_rate(path: Path, in_file: float | None, given: float | None, notes: list[str]) -> float:
    """The sample rate: the one given (a note when the file's differs), else the file's.

    Parameters
    ----------
    path : Path
        The recording, named in messages.
    in_file : float or None
        The file's rate [Hz].
    given : float or None
        The caller's (``--sample-rate``) [Hz].
    notes : list of str
        A disagreement is appended here too.

    Returns
    -------
    float
        [Hz].

    Raises
    ------
    InputFileError
        A given rate that is not positive; no rate at all; a rate above :data:`MAX_SAMPLE_RATE_HZ`.
    """
    if given is not None:
        if not (math.isfinite(given) and given > 0):
            raise InputFileError(f"sample-rate: must be a positive number of Hz, got {given!r}")
        refuse_huge_rate(given, "sample-rate")
        if in_file is not None and abs(in_file - given) > 1e-9 * given:
            notes.append(f"{path}: the file says {in_file:g} Hz, the command line {given:g} Hz; using {given:g} Hz")
        return float(given)
    if in_file is None:
        raise InputFileError(
            f"{path}: no sample rate in the file (a scalar named {', '.join(MAT_RATE_NAMES[:3])}, ...); give --sample-rate"
        )
    refuse_huge_rate(in_file, str(path), " (a damaged file?); give --sample-rate")
    return in_file
