"""The streaming JANUS receiver: blocks of a recording in, records out as packets end.

It keeps a window of the stream (``window_s``, 20 s by default) and receives it with
:func:`~seamodem.receive.janus.receiver.receive_segment`; preambles too close to the window's end
for their base packet, and packets whose cargo runs past it, wait for the next window, which
starts a preamble's length before the first preamble not yet dealt with.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from .receiver import JanusSettings, receive_segment
from .records import JanusRecord

__all__ = ["JanusReceiver"]


class JanusReceiver:
    """Receive JANUS packets from consecutive blocks of one channel.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    settings : JanusSettings, optional
        Receiver settings.
    window_s : float
        Stream held and received at once [s] (at least 4 base packets).

    Examples
    --------
    >>> import numpy as np
    >>> from seamodem.transmit.janus import JanusPacket, get_parameter_set, janus_waveform
    >>> x = janus_waveform(JanusPacket(), get_parameter_set(1), 48000).x_pb
    >>> rx = JanusReceiver(48000)
    >>> records = [r for block in np.array_split(np.tile(x, 3), 7) for r in rx.process(block)] + rx.flush()
    >>> [round(r.t_arrival_s, 5) for r in records]
    [0.03125, 1.19375, 2.35625]
    """

    def __init__(self, fs: float, settings: JanusSettings | None = None, *, window_s: float = 20.0):
        self.fs = float(fs)
        self.settings = settings or JanusSettings()
        pset = self.settings.pset
        self.settings.pset.check_rate(self.fs)
        base_s = (33 + 144) * pset.chip_s
        if window_s < 4 * base_s:
            raise ValueError(f"window_s must be at least 4 base packets ({4 * base_s:g} s), got {window_s!r}")
        self._window = int(window_s * self.fs)
        # the next window starts this much before the first preamble not dealt with
        self._margin = int((33 * pset.chip_s + 0.02) * self.fs)
        self._blocks: list[np.ndarray] = []
        self._held = 0
        self._t0 = 0  # stream sample of the held stretch's first sample
        self._done_s = -np.inf
        self._next_run = self._window

    def process(self, block: np.ndarray) -> list[JanusRecord]:
        """Take the next block; return the packets it completed."""
        block = np.asarray(block, dtype=np.float64).ravel()
        self._blocks.append(block)
        self._held += block.size
        return self._run(final=False) if self._held >= self._next_run else []

    def flush(self) -> list[JanusRecord]:
        """The stream has ended: the packets left in the held stretch."""
        return self._run(final=True) if self._held else []

    def run(self, blocks: Iterable[np.ndarray]) -> Iterator[JanusRecord]:
        """Records of every packet in ``blocks``, yielded as they are found."""
        for block in blocks:
            yield from self.process(block)
        yield from self.flush()

    def _run(self, *, final: bool) -> list[JanusRecord]:
        x = np.concatenate(self._blocks)
        records, done_s = receive_segment(x, self.fs, self.settings, t0_s=self._t0 / self.fs, after_s=self._done_s,
                                          final=final)
        self._done_s = done_s
        keep = min(max(int(np.floor(done_s * self.fs)) - self._margin - self._t0, 0), x.size)
        x = x[keep:]
        self._t0 += keep
        self._blocks = [x]
        self._held = x.size
        # a long cargo can hold the stretch: run again once half a window more has come
        self._next_run = max(self._window, self._held + self._window // 2)
        return records
