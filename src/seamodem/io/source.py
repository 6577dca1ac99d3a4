"""One interface for every recording: a source of checked blocks, from a file or a stream.

A :class:`RecordingSource` knows its sample rate, its channels and (for a
file) its length, and yields blocks of samples × channels, float64, in order.
Every reader of recordings goes through it (the frame receiver, batch
decoding, the reference and array receivers, ``seamodem plot``), so all see
the same blocks and the same checks:

* NaN or infinite samples, and a read that stops before the samples the
  header promised, are one-line :class:`~seamodem.errors.InputFileError`\\ s
  naming the recording;
* clipped samples (as stretches, per channel) and silence are counted in a
  :class:`BlockStats` as the blocks go by;
* how the file was read when it is odd (a WAV header that lies about its
  length, a sample rate given twice and different) is kept in
  :attr:`RecordingSource.notes` and warned about once, as a
  :class:`~seamodem.io.wav.RecordingWarning`, when the source is opened.

Sources
-------
:func:`open_recording`
    A file: WAV, FLAC, RF64... (anything soundfile reads), or MATLAB ``.mat``
    v5 / v7.3 (:mod:`seamodem.io.matlab`).
:func:`~seamodem.io.stream.open_stream`
    A pipe or stdin: a WAV stream, or raw PCM given its rate, channels and
    sample format. Its length is unknown (``n_samples`` is None) and it is
    read once, front to back.

A sound card will be one more subclass: it implements
:meth:`RecordingSource._read` and sets ``n_samples=None``.
"""

from __future__ import annotations

import abc
import math
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._progress import progress_bar
from ..errors import InputFileError
from .matlab import is_mat, open_mat, resolve_rate
from .wav import AudioInfo, RecordingWarning, open_audio, wav_info

__all__ = [
    "BLOCK",
    "BlockStats",
    "RecordingSource",
    "AudioFileSource",
    "ArraySource",
    "clip_level",
    "columns",
    "open_recording",
    "read_recording",
]

#: samples per channel read per block, by every source
BLOCK = 1 << 20


def clip_level(subtype: str) -> float:
    """The |sample| at or above which a sample of an audio file counts as clipped.

    Parameters
    ----------
    subtype : str
        soundfile subtype ("PCM_16", "FLOAT", ...).

    Returns
    -------
    float
        Full scale less half an LSB of PCM-16 for PCM files, 1.0 (full scale) otherwise.
    """
    return 1.0 - 2.0**-15 if subtype.startswith("PCM") else 1.0


@dataclass
class BlockStats:
    """What a source saw over the range it counted: clipped samples and silence.

    Parameters
    ----------
    clipped : int
        Clipped samples, every channel read.
    silent : bool
        True while every sample counted is zero.
    read : int
        Samples per channel read so far (the whole read range, overlap included).
    stretches : dict of int to list of (int, int)
        Per channel, the clipped stretches [first, end) [samples from the
        recording's start]; a stretch continued in the next block is one.
    """

    clipped: int = 0
    silent: bool = True
    read: int = 0
    stretches: dict[int, list[tuple[int, int]]] = field(default_factory=dict)

    def count(self, block: np.ndarray, pos: int, channels: list[int], level: float, lo: float, hi: float) -> None:
        """Count the samples of ``block`` that lie in [lo, hi).

        Parameters
        ----------
        block : numpy.ndarray, shape (n, len(channels))
            Samples from sample ``pos`` on.
        pos : int
            Index of the block's first sample in the recording [samples].
        channels : list of int
            The recording's channel of each column.
        level : float
            Clip level (:attr:`RecordingSource.clip_level`).
        lo, hi : float
            The counted range [samples].
        """
        a, b = max(pos, lo) - pos, min(pos + len(block), hi) - pos
        if b <= a:
            return
        part = block[a:b]
        # two reductions without temporaries first: the mask is made only for a block that reaches the level
        # (a 60 s four-channel recording: 0.30 s for the mask on every block, 7 % of `seamodem rx`)
        top, bottom = float(np.max(part, initial=0.0)), float(np.min(part, initial=0.0))
        if top >= level or -bottom >= level or not (math.isfinite(top) and math.isfinite(bottom)):
            clipped = np.abs(part) >= level
            n = int(np.count_nonzero(clipped))
            if n:
                self.clipped += n
                for j, ch in enumerate(channels):
                    self._add_stretches(ch, clipped[:, j], pos + a)
        self.silent = self.silent and top == 0.0 and bottom == 0.0

    def _add_stretches(self, channel: int, clipped: np.ndarray, start: int) -> None:
        edges = np.flatnonzero(np.diff(np.concatenate([[0], clipped.astype(np.int8), [0]])))
        runs = self.stretches.setdefault(channel, [])
        for a, b in zip(edges[::2], edges[1::2]):
            a, b = start + int(a), start + int(b)
            if runs and runs[-1][1] == a:
                runs[-1] = (runs[-1][0], b)
            else:
                runs.append((a, b))
        if not runs:
            del self.stretches[channel]

    def clipped_between(self, channel: int, lo: int, hi: int) -> int:
        """Clipped samples of one channel in a range.

        Parameters
        ----------
        channel : int
            Channel of the recording.
        lo, hi : int
            The range [lo, hi) [samples].

        Returns
        -------
        int
        """
        return sum(max(0, min(b, hi) - max(a, lo)) for a, b in self.stretches.get(channel, []))

    def notes(self, name: str, fs: float) -> list[str]:
        """One line per clipped channel: how many samples, in how many stretches, the first and the longest.

        Parameters
        ----------
        name : str
            The recording as named in the line.
        fs : float
            Sample rate [Hz].

        Returns
        -------
        list of str
        """
        out = []
        for ch in sorted(self.stretches):
            runs = self.stretches[ch]
            first = runs[0][0] / fs
            longest = max(b - a for a, b in runs) / fs
            out.append(
                f"recording {name} channel {ch}: {sum(b - a for a, b in runs)} clipped samples in {len(runs)} stretch"
                f"{'es' if len(runs) != 1 else ''} (first at {first:.3f} s, longest {longest * 1e3:.2f} ms); "
                "detections there may be biased"
            )
        return out


class RecordingSource(abc.ABC):
    """Blocks of samples × channels of one recording, checked as they are read.

    Subclasses implement :meth:`_read`; :meth:`blocks` adds the checks and
    the statistics.

    Parameters
    ----------
    name : str
        The recording as named in messages (a path, ``"stdin"``).
    sample_rate_hz : float
        [Hz].
    n_channels : int
    n_samples : int or None
        Samples per channel; None for a stream (unknown until it ends).
    kind : str
        "audio" (soundfile), "mat5", "mat73", "array" (samples in memory) or "stream".
    clip_level : float
        |sample| at or above which a sample counts as clipped.
    notes : list of str, optional
        How the recording was read when it is odd (warned when opened).
    path : Path, optional
        The file (None for a stream).

    Attributes
    ----------
    stats : BlockStats
        Filled by the latest :meth:`blocks` as it reads.
    """

    def __init__(self, name: str, sample_rate_hz: float, n_channels: int, n_samples: int | None, *, kind: str,
                 clip_level: float, notes: list[str] | None = None, path: Path | None = None):
        self.name, self.sample_rate_hz, self.n_channels = str(name), float(sample_rate_hz), int(n_channels)
        self.n_samples = None if n_samples is None else int(n_samples)
        self.kind, self.clip_level, self.path = kind, float(clip_level), path
        self.notes = list(notes or [])
        self.stats = BlockStats()

    def __repr__(self) -> str:
        return (f"{type(self).__name__}({self.name!r}, {self.sample_rate_hz:g} Hz, {self.n_channels} channel(s), "
                f"{self.n_samples} samples)")

    @property
    def duration_s(self) -> float | None:
        """Length [s]; None for a stream."""
        return None if self.n_samples is None else self.n_samples / self.sample_rate_hz

    def check_channel(self, channel: int | None) -> list[int]:
        """The channels to read.

        Parameters
        ----------
        channel : int or None
            A channel, numbered from 0; None: all of them.

        Returns
        -------
        list of int
            ``[channel]``, or every channel for None.

        Raises
        ------
        InputFileError
            A channel the recording does not have.
        """
        if channel is None:
            return list(range(self.n_channels))
        if not 0 <= channel < self.n_channels:
            raise InputFileError(
                f"channel {channel} does not exist in {self.name}: it has {self.n_channels} channel(s), numbered "
                f"from 0 (0 to {self.n_channels - 1})"
            )
        return [int(channel)]

    def one_channel(self, channel: int | None) -> int:
        """The one channel a single-channel receiver reads: ``channel``, or 0 of a mono recording.

        Parameters
        ----------
        channel : int or None
            Channel asked for (``--channel``), numbered from 0.

        Returns
        -------
        int

        Raises
        ------
        InputFileError
            No samples; several channels and ``channel`` not given; a channel
            that does not exist.
        """
        if self.n_samples == 0:
            raise InputFileError(f"recording {self.name} holds no samples")
        if self.n_channels > 1 and channel is None:
            raise InputFileError(
                f"recording {self.name} has {self.n_channels} channels: choose one with --channel "
                f"(0 to {self.n_channels - 1})"
            )
        (ch,) = self.check_channel(0 if channel is None else int(channel))
        return ch

    def blocks(
        self,
        channels: list[int] | None = None,
        *,
        start: int = 0,
        stop: int | None = None,
        counted: tuple[int, int] | None = None,
        stats: BlockStats | None = None,
        block: int = BLOCK,
        progress: bool | None = False,
    ) -> Iterator[np.ndarray]:
        """Samples [start, stop) of some channels, in blocks of ``block`` samples (the last one shorter).

        Parameters
        ----------
        channels : list of int, optional
            Channels to read (default: all), checked.
        start : int
            First sample [samples].
        stop : int, optional
            End [samples], at most :attr:`n_samples`; default: the end of the
            recording (of a stream: until it closes).
        counted : (int, int), optional
            Range over which clipping and silence are counted (default [start,
            stop); a segment counts only its own samples so that a file's
            totals add up).
        stats : BlockStats, optional
            Filled as blocks are read (default: a new one); also kept as :attr:`stats`.
        block : int
            Samples per block.
        progress : bool, optional
            Progress bar (None: on a terminal).

        Yields
        ------
        numpy.ndarray, shape (n, len(channels))
            float64, contiguous.

        Raises
        ------
        InputFileError
            Truncated or corrupt recording, NaN or infinite samples, a channel
            that does not exist.
        """
        channels = self.check_channel(None) if channels is None else [c for ch in channels for c in self.check_channel(ch)]
        stop = self.n_samples if stop is None else int(stop)
        lo, hi = (start, math.inf if stop is None else stop) if counted is None else counted
        self.stats = stats = BlockStats() if stats is None else stats
        total = None if stop is None else stop - start
        with progress_bar(total=total, desc="rx", unit="sample", unit_scale=True, enabled=progress) as bar:
            pos = start
            for data in self._read(channels, start, stop, block):
                if not np.isfinite(data).all():
                    bad = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0])
                    raise InputFileError(
                        f"recording {self.name} contains NaN or infinite samples (first at sample {pos + bad})"
                    )
                stats.count(data, pos, channels, self.clip_level, lo, hi)
                pos += len(data)
                stats.read = pos - start
                bar.update(len(data))
                yield data
        if stop is not None and pos < stop:
            raise InputFileError(f"recording {self.name} is truncated: it ends at sample {pos}, before {stop}")

    @abc.abstractmethod
    def _read(self, channels: list[int], start: int, stop: int | None, block: int) -> Iterator[np.ndarray]:
        """Raw blocks of samples [start, stop) of ``channels``: float64 arrays of shape (≤ block, len(channels)).

        Parameters
        ----------
        channels : list of int
            Checked channels.
        start : int
            First sample.
        stop : int or None
            End; None: until the stream ends.
        block : int
            Most samples per block.

        Yields
        ------
        numpy.ndarray
            Stop early (return) when the recording ends; :meth:`blocks` reports a short read.
        """


def columns(data: np.ndarray, channels: list[int]) -> np.ndarray:
    """Some columns of a samples × channels array, contiguous.

    Parameters
    ----------
    data : numpy.ndarray, shape (n, n_channels)
    channels : list of int

    Returns
    -------
    numpy.ndarray, shape (n, len(channels))
        ``data`` itself when ``channels`` is all of them, in order; else a copy.
    """
    if channels == list(range(data.shape[1])):
        return data
    return np.ascontiguousarray(data[:, channels])


class AudioFileSource(RecordingSource):
    """A file soundfile reads (WAV, FLAC, RF64, ...), as far as its samples go (:func:`~seamodem.io.wav.wav_info`).

    Parameters
    ----------
    path : str or Path
        Audio file.
    info : AudioInfo, optional
        Its :func:`~seamodem.io.wav.wav_info` when the caller has it (then not
        read, nor warned about, again).
    sample_rate_hz : float, optional
        Overrides the header's rate [Hz] (warned when they differ).
    name : str, optional
        The recording as named in messages (default: the path).
    """

    def __init__(self, path: str | Path, *, info: AudioInfo | None = None, sample_rate_hz: float | None = None,
                 name: str | None = None):
        path = Path(path)
        notes = []
        if info is None:
            info = wav_info(path)
            notes = [info.note] if info.note else []
        fs = resolve_rate(path, float(info.samplerate), sample_rate_hz, notes)
        super().__init__(path if name is None else name, fs, info.channels, info.frames, kind="audio",
                         clip_level=clip_level(info.subtype), notes=notes, path=path)
        self.info = info

    def _read(self, channels, start, stop, block):
        import soundfile

        with open_audio(self.path, self.info) as f:
            if start:
                f.seek(start)
            pos = start
            while pos < stop:
                try:
                    data = f.read(min(block, stop - pos), dtype="float64", always_2d=True)
                except (soundfile.LibsndfileError, RuntimeError) as exc:
                    raise InputFileError(f"recording {self.name} is truncated or corrupt: {exc}") from None
                if data.shape[0] == 0:
                    return
                pos += len(data)
                yield columns(data, channels)


class ArraySource(RecordingSource):
    """Samples already in memory (a ``.mat`` v5 file, a test), as a source.

    Parameters
    ----------
    samples : numpy.ndarray, shape (n_samples, n_channels)
        Real samples.
    sample_rate_hz : float
        [Hz].
    name : str
        The recording as named in messages.
    kind : str
        As :class:`RecordingSource` (default "array").
    clip_level : float
        As :class:`RecordingSource` (default 1.0, full scale).
    notes : list of str, optional
    path : Path, optional
    """

    def __init__(self, samples: np.ndarray, sample_rate_hz: float, *, name: str, kind: str = "array",
                 clip_level: float = 1.0, notes: list[str] | None = None, path: Path | None = None):
        samples = np.asarray(samples)
        samples = samples.reshape(-1, 1) if samples.ndim == 1 else samples
        super().__init__(name, sample_rate_hz, samples.shape[1], samples.shape[0], kind=kind, clip_level=clip_level,
                         notes=notes, path=path)
        self._samples = samples

    def _read(self, channels, start, stop, block):
        for lo in range(start, stop, block):
            yield np.asarray(self._samples[lo:min(stop, lo + block), channels], dtype=np.float64)


class _ChunkSource(RecordingSource):
    """A file read by a function that gives its blocks from the start (``.mat`` v7.3 through h5py)."""

    def __init__(self, reader: Callable[[list[int], int, int, int], Iterator[np.ndarray]], **kwargs):
        super().__init__(**kwargs)
        self._reader = reader

    def _read(self, channels, start, stop, block):
        return self._reader(channels, start, stop, block)


def open_recording(
    path: str | Path,
    *,
    mat_variable: str | None = None,
    sample_rate_hz: float | None = None,
    name: str | None = None,
    info: AudioInfo | None = None,
) -> RecordingSource:
    """Open a recording file of any supported format.

    Odd but readable files (a WAV header that lies about its length, a rate
    that differs from ``sample_rate_hz``) are warned about here, once, as
    :class:`~seamodem.io.wav.RecordingWarning`; the lines stay in
    :attr:`RecordingSource.notes`.

    Parameters
    ----------
    path : str or Path
        Audio file (WAV, FLAC, RF64, ... anything soundfile reads) or ``.mat``
        (v5 or v7.3, :mod:`seamodem.io.matlab`).
    mat_variable : str, optional
        ``.mat``: the variable holding the samples.
    sample_rate_hz : float, optional
        Overrides (``.mat``: supplies) the file's sample rate [Hz].
    name : str, optional
        The recording as named in messages (default: the path).
    info : AudioInfo, optional
        An audio file's :func:`~seamodem.io.wav.wav_info`, when the caller
        has it (and has reported its note).

    Returns
    -------
    RecordingSource

    Raises
    ------
    InputFileError
        Missing, empty or unreadable file; missing variable or rate; complex,
        3-D or empty samples.
    """
    path = Path(path)
    if info is None:
        if not path.is_file():
            raise InputFileError(f"recording not found: {path}")
        if path.stat().st_size == 0:
            raise InputFileError(f"recording {path} is empty (0 bytes)")
    if is_mat(path):
        notes: list[str] = []
        opened = open_mat(path, mat_variable)
        fs = resolve_rate(path, opened.sample_rate_hz, sample_rate_hz, notes)
        common = dict(name=str(path) if name is None else name, kind=opened.kind, clip_level=opened.clip_level,
                      notes=notes, path=path)
        if opened.samples is not None:
            source: RecordingSource = ArraySource(opened.samples, fs, **common)
        else:
            source = _ChunkSource(opened.reader, sample_rate_hz=fs, n_channels=opened.n_channels,
                                  n_samples=opened.n_samples, **common)
    else:
        if mat_variable:
            raise InputFileError(f"mat-variable: {path} is not a .mat file")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RecordingWarning)  # warned below, with the other notes
            source = AudioFileSource(path, info=info, sample_rate_hz=sample_rate_hz, name=name)
        if source.n_samples == 0:
            raise InputFileError(f"recording {source.name} holds no samples")
    for note in source.notes:
        warnings.warn(note, RecordingWarning, stacklevel=2)
    return source


def read_recording(
    path: str | Path, *, mat_variable: str | None = None, sample_rate_hz: float | None = None, channel: int = 0
) -> tuple[np.ndarray, float]:
    """One channel of a recording, whole (template excerpts).

    Parameters
    ----------
    path : str or Path
        As :func:`open_recording`.
    mat_variable : str, optional
        ``.mat``: the variable holding the samples.
    sample_rate_hz : float, optional
        Overrides (``.mat``: supplies) the file's rate [Hz].
    channel : int
        Channel, numbered from 0.

    Returns
    -------
    samples : numpy.ndarray, shape (n_samples,)
    fs : float
        [Hz].
    """
    src = open_recording(path, mat_variable=mat_variable, sample_rate_hz=sample_rate_hz)
    (ch,) = src.check_channel(channel)
    x = np.concatenate([b[:, 0] for b in src.blocks([ch])])
    return x, src.sample_rate_hz

