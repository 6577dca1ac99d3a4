"""A sound card as a recording source, through PortAudio (``sounddevice``, the optional extra ``seamodem[live]``).

:class:`DeviceSource` is a :class:`~seamodem.io.source.RecordingSource` of
unknown length: PortAudio's callback queues the blocks it captures, and
:meth:`~seamodem.io.source.RecordingSource.blocks` hands them on in order. The
stream's t = 0 is its first captured sample.

An input overflow (the program did not take the samples in time, and the
card dropped some) breaks the stream's clock — every later arrival would be
early by the samples lost, an unknown number — so the source ends there
(``end_reason`` "overrun"): the frames before it are measured, nothing after
it is trusted.
"""

from __future__ import annotations

import queue
import threading

import numpy as np

from ..errors import InputFileError
from .matlab import refuse_huge_rate
from .source import RecordingSource, columns

__all__ = ["DeviceSource", "open_device", "BUFFER_S"]

#: The capture buffer PortAudio is asked for [s] (its input "latency"): room for the samples that arrive while
#: the receiver holds the interpreter. Blocks are still handed on every ``block_s``: the records are not later.
BUFFER_S = 1.0


def _sounddevice():
    try:
        import sounddevice
    except ImportError:
        raise InputFileError("device: reading a sound card needs sounddevice and PortAudio: "
                             "pip install 'seamodem[live]' (and the libportaudio2 system package)") from None
    except OSError as exc:  # sounddevice installed, PortAudio library missing
        raise InputFileError(f"device: PortAudio is not available ({exc}): install the libportaudio2 package") \
            from None
    return sounddevice


class DeviceSource(RecordingSource):
    """Samples captured from a sound card, as they arrive.

    Use :func:`open_device` to make one.

    Parameters
    ----------
    stream_factory : callable
        ``stream_factory(callback)`` → a started-on-``start()`` PortAudio input stream, called when the
        samples are first read.
    name : str
        The device as named in messages.
    sample_rate_hz : float
        [Hz].
    n_channels : int
    stop : threading.Event, optional
        Ends the capture when set.

    Attributes
    ----------
    end_reason : str or None
        "interrupted" (``stop`` set), "overrun" (samples lost), "end of stream" (the device closed).
    overruns : int
        Input overflows reported by PortAudio.
    """

    def __init__(self, stream_factory, *, name: str, sample_rate_hz: float, n_channels: int,
                 stop: threading.Event | None = None):
        super().__init__(name, sample_rate_hz, n_channels, None, kind="stream", clip_level=1.0)
        self._queue: queue.Queue = queue.Queue()
        self._factory = stream_factory
        self._stream = None
        self.stop = stop
        self.end_reason: str | None = None
        self.overruns = 0

    def _callback(self, indata, frames, time_info, status):
        self._queue.put((np.array(indata, dtype=np.float64), bool(getattr(status, "input_overflow", False))))

    def _read(self, channels, start, stop, block):
        pos = 0
        # opened here, when the reader is ready, not before: a device opened early captures into its buffer
        # (ALSA's PulseAudio plugin does) and silently drops what does not fit before the first read
        self._stream = self._factory(self._callback)
        self._stream.start()
        try:
            while stop is None or pos < stop:
                if self.stop is not None and self.stop.is_set():
                    self.end_reason = "interrupted"
                    return
                try:
                    data, overflow = self._queue.get(timeout=0.1)
                except queue.Empty:
                    if not self._stream.active:
                        self.end_reason = "end of stream"
                        return
                    continue
                if overflow:
                    self.overruns += 1
                    self.end_reason = "overrun"
                    return
                lo = max(0, start - pos)
                pos += len(data)
                if lo < len(data):
                    yield columns(np.ascontiguousarray(data[lo:]), channels)
        finally:
            self._stream.stop()
            self._stream.close()


def open_device(device: str, *, sample_rate_hz: float | None, n_channels: int = 1,
                stop: threading.Event | None = None, block_s: float = 0.05) -> DeviceSource:
    """Open a sound card's input.

    Parameters
    ----------
    device : str
        PortAudio device name (or part of it) or index (``python -m sounddevice`` lists them).
    sample_rate_hz : float
        Capture rate [Hz] (required: the card is asked for it).
    n_channels : int
        Channels to capture.
    stop : threading.Event, optional
        Ends the capture when set.
    block_s : float
        Samples per PortAudio callback [s].

    Returns
    -------
    DeviceSource

    Raises
    ------
    InputFileError
        sounddevice or PortAudio missing, no rate, a device that does not exist or refuses the settings.
    """
    if sample_rate_hz is None or not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise InputFileError(f"sample-rate: a sound card needs its capture rate > 0 [Hz], got {sample_rate_hz!r}")
    refuse_huge_rate(sample_rate_hz, "sample-rate")
    sd = _sounddevice()
    dev = int(device) if str(device).isdigit() else device
    try:
        info = sd.query_devices(dev, "input")
        sd.check_input_settings(device=dev, channels=n_channels, samplerate=sample_rate_hz, dtype="float32")
    except (ValueError, sd.PortAudioError) as exc:
        raise InputFileError(f"device {device!r}: {exc}") from None

    def factory(callback):
        return sd.InputStream(device=dev, channels=n_channels, samplerate=sample_rate_hz, dtype="float32",
                              blocksize=max(1, int(round(block_s * sample_rate_hz))), latency=BUFFER_S,
                              callback=callback)

    return DeviceSource(factory, name=f"device {info['name']}", sample_rate_hz=sample_rate_hz,
                        n_channels=n_channels, stop=stop)
