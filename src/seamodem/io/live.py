"""A recording read live from a pipe, stdin or a FIFO: a WAV stream or raw PCM, as the samples arrive.

:class:`LiveSource` is a :class:`~seamodem.io.source.RecordingSource` of
unknown length (``n_samples`` is None) that reads a file descriptor itself,
without libsndfile, so that it can

* hand on samples as soon as a short block has arrived (``block_s``), which
  keeps the receiver's latency to a fraction of a second;
* notice a producer that has stopped writing (``stall_timeout_s``) and a
  request to stop (``stop``, e.g. set by Ctrl-C), and end the stream cleanly
  so that the receiver measures what it has;
* say why the stream ended (:attr:`LiveSource.end_reason`).

Samples are scaled as libsndfile scales them (PCM by 2^(bits−1), floats as
they are), so a stream gives the same float64 samples as the same WAV file
read by :func:`~seamodem.io.source.open_recording`.

Raw formats use ALSA's names (``arecord -f``): ``S16_LE``, ``S24_LE`` (24 bits
in a 4-byte container, as ALSA stores it), ``S24_3LE`` (packed 3 bytes, as
``sox -b 24`` writes), ``S32_LE``, ``FLOAT_LE`` (32-bit float).
"""

from __future__ import annotations

import fcntl
import os
import queue
import select
import stat
import struct
import termios
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputFileError
from .matlab import refuse_huge_rate
from .source import RecordingSource, columns

__all__ = ["RAW_FORMATS", "PcmFormat", "LiveSource", "is_live_input", "open_live"]


@dataclass(frozen=True)
class PcmFormat:
    """How one sample is stored.

    Parameters
    ----------
    name : str
        ALSA name (``S16_LE``...).
    width : int
        Bytes per sample in the stream.
    kind : {"int", "int24", "float"}
        Integer (``width`` bytes), 24-bit packed integer, or IEEE float.
    bits : int
        Significant bits: the scale of an integer sample is 2^(bits−1).
    """

    name: str
    width: int
    kind: str
    bits: int

    def decode(self, raw: bytes | memoryview, n_channels: int) -> np.ndarray:
        """Whole sample frames of ``raw`` as float64, shape (n, n_channels) (full scale ±1)."""
        if self.kind == "float":
            x = np.frombuffer(raw, dtype=f"<f{self.width}").astype(np.float64)
        elif self.kind == "int24":
            b = np.frombuffer(raw, dtype=np.uint8).reshape(-1, 3).astype(np.int32)
            v = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
            x = (v - ((v & 0x800000) << 1)).astype(np.float64) / 2.0**23
        else:
            v = np.frombuffer(raw, dtype=f"<i{self.width}")
            if self.bits < 8 * self.width:  # S24_LE: 24 bits in 4 bytes, sign-extend the low 24
                v = (v.astype(np.int32) << (32 - self.bits)) >> (32 - self.bits)
            x = v.astype(np.float64) / 2.0 ** (self.bits - 1)
        return x.reshape(-1, n_channels)

    @property
    def subtype(self) -> str:
        """The soundfile subtype of the same samples (for the clip level)."""
        return "FLOAT" if self.kind == "float" else f"PCM_{self.bits}"


#: raw PCM formats by their ALSA name (``arecord -f``)
RAW_FORMATS = {
    "S16_LE": PcmFormat("S16_LE", 2, "int", 16),
    "S24_LE": PcmFormat("S24_LE", 4, "int", 24),
    "S24_3LE": PcmFormat("S24_3LE", 3, "int24", 24),
    "S32_LE": PcmFormat("S32_LE", 4, "int", 32),
    "FLOAT_LE": PcmFormat("FLOAT_LE", 4, "float", 32),
    "FLOAT64_LE": PcmFormat("FLOAT64_LE", 8, "float", 64),
}

_POLL_S = 0.1  # how often a blocked read looks at the stop flag and the stall clock


def is_live_input(name: str) -> bool:
    """Whether a RECORDING argument names a stream: ``-``, a FIFO, a character device (``/dev/stdin`` on a pipe).

    Parameters
    ----------
    name : str
        As given on the command line.

    Returns
    -------
    bool
    """
    if name == "-":
        return True
    try:
        mode = os.stat(name).st_mode
    except OSError:
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode) or stat.S_ISSOCK(mode)


class _Reader:
    """Bytes from a descriptor, waiting with a poll so that a stop request and a stall are seen."""

    def __init__(self, fd: int, name: str, stall_timeout_s: float | None, stop: threading.Event | None):
        self.fd, self.name, self.stall_timeout_s, self.stop = fd, name, stall_timeout_s, stop
        self.end_reason: str | None = None
        self.last_data = time.monotonic()
        self.n_bytes = 0
        self._left: int | None = None  # bytes still to read after a stop request

    def read(self, n: int) -> bytes:
        """Up to ``n`` bytes as soon as some are there; b"" at the end (``end_reason`` says which)."""
        while True:
            if self.stop is not None and self.stop.is_set():
                return self._drain(n)
            ready, _, _ = select.select([self.fd], [], [], _POLL_S)
            if ready:
                data = os.read(self.fd, n)
                if not data:
                    self.end_reason = "end of stream"
                    return b""
                self.last_data = time.monotonic()
                self.n_bytes += len(data)
                return data
            if self.stall_timeout_s is not None and time.monotonic() - self.last_data > self.stall_timeout_s:
                self.end_reason = "stalled"
                return b""

    def _drain(self, n: int) -> bytes:
        """After a stop request: what was already in the pipe then (not what arrives later), then the end."""
        if self._left is None:
            try:
                self._left = struct.unpack("i", fcntl.ioctl(self.fd, termios.FIONREAD, b"\0\0\0\0"))[0]
            except OSError:  # not a pipe (a file, a device): nothing is waiting in a buffer
                self._left = 0
        if self._left > 0:
            data = os.read(self.fd, min(n, self._left))
            self._left = self._left - len(data) if data else 0
            if data:
                self.n_bytes += len(data)
                return data
        self.end_reason = "interrupted"
        return b""

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def exactly(self, n: int, what: str) -> bytes:
        """``n`` bytes of the header, or a one-line error naming the stream."""
        out = bytearray()
        while len(out) < n:
            data = self.read(n - len(out))
            if not data:
                got = self.n_bytes
                why = {"stalled": f"the producer wrote nothing for {self.stall_timeout_s} s",
                       "interrupted": "interrupted"}.get(self.end_reason, "the stream ended")
                if not got:
                    raise InputFileError(f"{self.name}: {why} before any byte arrived (no audio)")
                raise InputFileError(f"{self.name}: {why} before the WAV header was complete ({got} bytes, "
                                     f"reading its {what})")
            out += data
        return bytes(out)


class _Buffered:
    """A :class:`_Reader` run in a thread: the pipe is emptied as it fills, whatever the receiver is doing.

    The producer (``arecord``) never blocks on a full pipe while the receiver is busy (starting up,
    decoding a hard frame): what it wrote waits here, counted in :attr:`backlog`.
    """

    def __init__(self, reader: _Reader):
        self.reader, self.name = reader, reader.name
        self.end_reason: str | None = None
        self.backlog = 0  # bytes read from the pipe and not yet taken
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._pending = b""
        threading.Thread(target=self._run, daemon=True, name=f"read {reader.name}").start()

    def _run(self) -> None:
        while True:
            try:
                data = self.reader.read(1 << 16)
            except OSError:  # closed under the thread: the run is over
                data = b""
            with self._lock:
                self.backlog += len(data)
            self._queue.put(data)
            if not data:
                return

    def read(self, n: int) -> bytes:
        """Up to ``n`` bytes, waiting for some; b"" at the end (``end_reason`` then says which)."""
        if not self._pending:
            self._pending = self._queue.get()
            if not self._pending:
                self.end_reason = self.reader.end_reason
                return b""
        data, self._pending = self._pending[:n], self._pending[n:]
        with self._lock:
            self.backlog -= len(data)
        return data

    def close(self) -> None:
        self.reader.close()


def _wav_format(fmt: bytes, name: str) -> tuple[PcmFormat, int, float]:
    """(sample format, channels, rate) of a WAV ``fmt `` chunk."""
    tag, channels, rate, _, _, bits = struct.unpack("<HHIIHH", fmt[:16])
    if tag == 0xFFFE and len(fmt) >= 26:
        tag = struct.unpack("<H", fmt[24:26])[0]  # WAVE_FORMAT_EXTENSIBLE: the sub-format's tag
    width = (bits + 7) // 8
    if tag == 1 and bits in (16, 24, 32):
        pcm = PcmFormat(f"S{bits}", width, "int24" if bits == 24 else "int", bits)
    elif tag == 3 and bits in (32, 64):
        pcm = PcmFormat(f"FLOAT{bits}", width, "float", bits)
    else:
        raise InputFileError(f"{name}: WAV stream of format tag {tag} with {bits}-bit samples is not supported "
                             "(16-, 24-, 32-bit PCM or 32-, 64-bit float)")
    if channels < 1 or rate <= 0:
        raise InputFileError(f"{name}: WAV header gives {channels} channel(s) at {rate} Hz")
    refuse_huge_rate(rate, name, " (a damaged WAV header?)")
    return pcm, channels, float(rate)


def _read_wav_header(reader: _Reader) -> tuple[PcmFormat, int, float]:
    """Read a WAV (or RF64) header up to its data chunk; the stream then holds samples."""
    riff = reader.exactly(12, "RIFF header")
    if riff[:4] not in (b"RIFF", b"RF64") or riff[8:12] != b"WAVE":
        raise InputFileError(f"{reader.name} is not a WAV stream (it starts with {riff[:4]!r}): for raw PCM give "
                             "--raw FORMAT, --sample-rate and --channels")
    fmt = None
    while True:
        chunk_id, size = struct.unpack("<4sI", reader.exactly(8, "chunk header"))
        if chunk_id == b"data":
            if fmt is None:
                raise InputFileError(f"{reader.name}: WAV stream has its data before its 'fmt ' chunk")
            return fmt
        body = reader.exactly(size + (size & 1), f"{chunk_id.decode('latin-1')!r} chunk")
        if chunk_id == b"fmt ":
            fmt = _wav_format(body, reader.name)


class LiveSource(RecordingSource):
    """A recording arriving on a file descriptor, handed on in short blocks as it arrives.

    Use :func:`open_live` to make one.

    Parameters
    ----------
    reader : object
        The descriptor's reader (made by :func:`open_live`).
    pcm : PcmFormat
        Sample format.
    n_channels : int
    sample_rate_hz : float
        [Hz].
    name : str
        The stream as named in messages.
    block_s : float
        Longest wait for a block [s of samples]: a block is handed on once it
        holds this much, or at the end.

    Attributes
    ----------
    end_reason : str or None
        Why the stream ended: ``"end of stream"`` (the producer closed it),
        ``"stalled"`` (nothing for ``stall_timeout_s``), ``"interrupted"``
        (the stop event was set); None while it runs.
    dropped_bytes : int
        Bytes of an incomplete last sample frame, not read as samples.
    """

    def __init__(self, reader: _Reader, pcm: PcmFormat, *, n_channels: int, sample_rate_hz: float, name: str,
                 block_s: float = 0.05):
        from .source import clip_level

        super().__init__(name, sample_rate_hz, n_channels, None, kind="stream", clip_level=clip_level(pcm.subtype))
        self._reader, self.pcm, self.block_s = _Buffered(reader), pcm, float(block_s)
        self._pos, self._rest = 0, b""
        self.dropped_bytes = 0

    @property
    def end_reason(self) -> str | None:
        """Why the stream ended (None while it runs)."""
        return self._reader.end_reason

    @property
    def backlog_s(self) -> float:
        """Stream read from the pipe and not yet handed to the receiver [s]: how far behind it is."""
        return self._reader.backlog / (self.pcm.width * self.n_channels * self.sample_rate_hz)

    def _read(self, channels, start, stop, block):
        if start < self._pos:
            raise InputFileError(f"recording {self.name} is a stream: it is read once, from sample {self._pos} on")
        frame_bytes = self.pcm.width * self.n_channels
        want = max(1, min(block, int(round(self.block_s * self.sample_rate_hz))))
        while stop is None or self._pos < stop:
            buf = bytearray(self._rest)
            while len(buf) < want * frame_bytes:
                data = self._reader.read(max(want * frame_bytes - len(buf), 4096))
                if not data:
                    break
                buf += data
            n = len(buf) // frame_bytes
            if stop is not None:
                n = min(n, stop - self._pos)
            self._rest = bytes(buf[n * frame_bytes:])
            if n:
                x = self.pcm.decode(memoryview(buf)[: n * frame_bytes], self.n_channels)
                lo = max(0, start - self._pos)
                self._pos += n
                if lo < n:
                    yield columns(np.ascontiguousarray(x[lo:]), channels)
            if self._reader.end_reason is not None:
                self.dropped_bytes = len(self._rest)
                return

    def close(self) -> None:
        """Close the descriptor."""
        self._reader.close()


def open_live(
    name: str,
    *,
    raw_format: str | None = None,
    sample_rate_hz: float | None = None,
    n_channels: int | None = None,
    stall_timeout_s: float | None = None,
    stop: threading.Event | None = None,
    block_s: float = 0.05,
) -> LiveSource:
    """Open a stream: ``-`` (stdin), a FIFO, ``/dev/stdin``; a WAV stream or raw PCM.

    Parameters
    ----------
    name : str
        ``-`` or a path.
    raw_format : str, optional
        Raw PCM in this format (:data:`RAW_FORMATS`); None: a WAV stream.
    sample_rate_hz : float, optional
        Raw PCM: its rate [Hz] (required with ``raw_format``).
    n_channels : int, optional
        Raw PCM: interleaved channels (default 1).
    stall_timeout_s : float, optional
        End the stream when nothing arrives for this long [s] (None: wait for ever).
    stop : threading.Event, optional
        End the stream when set (checked at least every 0.1 s).
    block_s : float
        Samples handed on per block, at most [s].

    Returns
    -------
    LiveSource

    Raises
    ------
    InputFileError
        Not a WAV stream (and no raw format given), a bad raw format or rate,
        a stream that ends or stalls before its header is complete.
    """
    shown = "stdin" if name in ("-", "/dev/stdin") else name
    if raw_format is None:
        if sample_rate_hz is not None or n_channels is not None:
            raise InputFileError(f"{shown}: --sample-rate and --channels describe raw PCM: give --raw FORMAT too "
                                 "(a WAV stream's header gives them)")
    else:
        if raw_format not in RAW_FORMATS:
            raise InputFileError(f"raw: format must be one of {', '.join(RAW_FORMATS)}, got {raw_format!r}")
        if sample_rate_hz is None or not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
            raise InputFileError(f"sample-rate: raw PCM needs its rate > 0 [Hz], got {sample_rate_hz!r}")
        refuse_huge_rate(sample_rate_hz, "sample-rate")
        if n_channels is not None and n_channels < 1:
            raise InputFileError(f"channels: must be >= 1, got {n_channels}")
    if stall_timeout_s is not None and not (np.isfinite(stall_timeout_s) and stall_timeout_s > 0):
        raise InputFileError(f"stall-timeout: must be > 0 [s], got {stall_timeout_s!r}")
    if name == "-":
        fd = os.dup(0)
    else:
        try:
            fd = os.open(Path(name), os.O_RDONLY)
        except OSError as exc:
            raise InputFileError(f"cannot open stream {name}: {exc.strerror}") from None
    reader = _Reader(fd, shown, stall_timeout_s, stop)
    if raw_format is None:
        pcm, channels, rate = _read_wav_header(reader)
    else:
        pcm, channels, rate = RAW_FORMATS[raw_format], int(n_channels or 1), float(sample_rate_hz)
    return LiveSource(reader, pcm, n_channels=channels, sample_rate_hz=rate, name=shown, block_s=block_s)
