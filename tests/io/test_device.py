"""The sound-card source with a stand-in for sounddevice (no card here): blocks in order, Ctrl-C, overrun, errors."""

import sys
import threading
import types

import numpy as np
import pytest

from seamodem.errors import InputFileError
from seamodem.io.device import DeviceSource, open_device


class FakeStream:
    """PortAudio's InputStream as the source uses it: start() delivers the blocks to the callback."""

    def __init__(self, callback, blocks, overflow_at=None):
        self.callback, self.blocks, self.overflow_at = callback, blocks, overflow_at
        self.active = False
        self.closed = False

    def start(self):
        self.active = True
        for i, b in enumerate(self.blocks):
            self.callback(b.astype(np.float32), len(b), None,
                          types.SimpleNamespace(input_overflow=i == self.overflow_at))
        self.active = False  # the device stopped after the last block

    def stop(self):
        self.active = False

    def close(self):
        self.closed = True


def _blocks(n=5, size=480, channels=2):
    rng = np.random.default_rng(3)
    return [rng.uniform(-0.5, 0.5, (size, channels)).astype(np.float32) for _ in range(n)]


def test_captured_blocks_come_out_in_order_then_the_end():
    blocks = _blocks()
    made = []
    src = DeviceSource(lambda cb: made.append(FakeStream(cb, blocks)) or made[-1], name="fake", sample_rate_hz=48000,
                       n_channels=2)
    got = list(src.blocks([1]))
    np.testing.assert_array_equal(np.concatenate(got)[:, 0], np.concatenate(blocks)[:, 1].astype(np.float64))
    assert src.end_reason == "end of stream" and made[0].closed and src.n_samples is None


def test_an_overrun_ends_the_stream_before_the_lost_samples():
    src = DeviceSource(lambda cb: FakeStream(cb, _blocks(), overflow_at=3), name="fake", sample_rate_hz=48000,
                       n_channels=2)
    got = list(src.blocks())
    assert sum(len(b) for b in got) == 3 * 480  # the blocks before the overflow, none after
    assert src.end_reason == "overrun" and src.overruns == 1


def test_stop_event_ends_the_capture():
    stop = threading.Event()
    stop.set()
    src = DeviceSource(lambda cb: FakeStream(cb, _blocks()), name="fake", sample_rate_hz=48000, n_channels=2,
                       stop=stop)
    assert list(src.blocks()) == [] and src.end_reason == "interrupted"


def test_without_sounddevice_the_error_is_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "sounddevice", None)  # import fails as when it is not installed
    with pytest.raises(InputFileError, match=r"pip install 'seamodem\[live\]'"):
        open_device("0", sample_rate_hz=96000)
    with pytest.raises(InputFileError, match="a sound card needs its capture rate"):
        open_device("0", sample_rate_hz=None)
