"""One recording source: files (WAV, FLAC, .mat v5/v7.3) and streams (a pipe, raw PCM) give the same samples and checks."""

import io
import os
import threading
import warnings

import h5py
import numpy as np
import pytest
import scipy.io
import soundfile

from seamodem.errors import InputFileError
from seamodem.io import open_recording, open_stream
from seamodem.io.blocks import read_blocks
from seamodem.io.source import BlockStats, RecordingSource
from seamodem.io.wav import RecordingWarning

FS = 8000


@pytest.fixture
def stereo(tmp_path):
    rng = np.random.default_rng(1)
    x = 0.1 * rng.standard_normal((30_000, 2))
    x[[100, 101, 102, 20_000], 1] = 1.0  # clipped in a PCM file: a stretch of 3 and one sample
    path = tmp_path / "x.wav"
    soundfile.write(path, x, FS, subtype="PCM_16")
    return path, soundfile.read(path, always_2d=True)[0]


def _wav_bytes(path) -> bytes:
    return path.read_bytes()


def _through_pipe(data: bytes, read):
    """``read(file object)`` on the read end of an os.pipe() while a thread writes ``data`` into it."""
    r, w = os.pipe()

    def feed():
        with os.fdopen(w, "wb") as f:
            f.write(data)

    t = threading.Thread(target=feed, daemon=True)
    t.start()
    with os.fdopen(r, "rb") as f:
        out = read(f)
    t.join(timeout=10)
    return out


def _all(source: RecordingSource, **kw) -> np.ndarray:
    return np.concatenate(list(source.blocks(**kw)))


def test_a_file_in_blocks_is_the_file_and_counts_clipped_stretches(stereo):
    path, x = stereo
    src = open_recording(path)
    assert (src.sample_rate_hz, src.n_channels, src.n_samples, src.kind) == (FS, 2, len(x), "audio")
    blocks = list(src.blocks(block=7000))
    assert [b.shape for b in blocks] == [(7000, 2)] * 4 + [(2000, 2)]
    np.testing.assert_array_equal(np.concatenate(blocks), x)
    assert src.stats.clipped == 4 and src.stats.stretches == {1: [(100, 103), (20_000, 20_001)]}
    assert src.stats.clipped_between(1, 0, 101) == 1 and not src.stats.silent
    # one channel, a range: read_blocks is the same source, as 1-D blocks
    one = np.concatenate(list(read_blocks(path, channel=1, start=50, stop=25_000, block=4096)))
    np.testing.assert_array_equal(one, x[50:25_000, 1])
    np.testing.assert_array_equal(_all(src, channels=[1], start=50, stop=25_000)[:, 0], one)


def test_a_wav_stream_through_a_pipe_gives_the_files_samples(stereo):
    path, x = stereo

    def read(f):
        src = open_stream(f, name="pipe")
        assert src.n_samples is None and src.duration_s is None and src.n_channels == 2
        assert src.sample_rate_hz == FS and src.kind == "stream"
        return src, list(src.blocks([1], block=5000))

    src, blocks = _through_pipe(_wav_bytes(path), read)
    np.testing.assert_array_equal(np.concatenate(blocks)[:, 0], x[:, 1])
    assert src.stats.clipped == 4 and src.stats.read == len(x)
    # the file source and the stream source: same blocks
    for a, b in zip(open_recording(path).blocks([1], block=5000), blocks):
        np.testing.assert_array_equal(a, b)


def test_a_stream_from_a_file_object_and_a_range(stereo):
    path, x = stereo
    src = open_stream(io.BytesIO(_wav_bytes(path)))
    np.testing.assert_array_equal(_all(src, start=1000, stop=9000, block=3000), x[1000:9000])
    with pytest.raises(InputFileError, match="is a stream: it is read once"):
        list(src.blocks(start=0))


@pytest.mark.parametrize("fmt, subtype", [("pcm16", "PCM_16"), ("pcm24", "PCM_24"), ("float32", "FLOAT")])
def test_raw_pcm_through_a_pipe(tmp_path, stereo, fmt, subtype):
    _, x = stereo
    raw = tmp_path / "x.raw"
    soundfile.write(raw, x, FS, subtype=subtype, format="RAW", endian="LITTLE")
    expected = soundfile.read(raw, samplerate=FS, channels=2, subtype=subtype, format="RAW", endian="LITTLE",
                              always_2d=True)[0]
    src, data = _through_pipe(
        raw.read_bytes(),
        lambda f: (lambda s: (s, _all(s, block=4000)))(open_stream(f, sample_rate_hz=FS, n_channels=2, sample_format=fmt)),
    )
    np.testing.assert_array_equal(data, expected)
    assert src.sample_rate_hz == FS and src.n_channels == 2


def test_stream_errors_are_one_line(tmp_path):
    with pytest.raises(InputFileError, match="pipe is not a readable audio stream"):
        _through_pipe(b"not a wav file at all" * 10, lambda f: open_stream(f, name="pipe"))
    with pytest.raises(InputFileError, match="raw sample format must be one of"):
        open_stream(io.BytesIO(b"\0" * 100), sample_rate_hz=FS, sample_format="pcm8")
    x = np.zeros(1000)
    x[300] = np.inf
    buf = io.BytesIO()
    soundfile.write(buf, x, FS, subtype="DOUBLE", format="WAV")
    buf.seek(0)
    with pytest.raises(InputFileError, match=r"stdin contains NaN or infinite samples \(first at sample 300\)"):
        list(open_stream(buf).blocks(block=128))


def test_mat_files_and_flac_read_as_the_wav(tmp_path, stereo):
    path, x = stereo
    scipy.io.savemat(tmp_path / "v5.mat", {"x": x, "fs": float(FS)})
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        f["x"] = x.T  # MATLAB stores arrays transposed
        f["fs"] = np.array([[float(FS)]])
    soundfile.write(tmp_path / "x.flac", x, FS, subtype="PCM_16", format="FLAC")
    for name, kind in [("v5.mat", "mat5"), ("v73.mat", "mat73"), ("x.flac", "audio")]:
        src = open_recording(tmp_path / name)
        assert (src.kind, src.sample_rate_hz, src.n_channels, src.n_samples) == (kind, FS, 2, len(x))
        np.testing.assert_array_equal(_all(src, channels=[1], start=10, stop=20_010, block=3000)[:, 0], x[10:20_010, 1])
    with pytest.raises(InputFileError, match="channel 2 does not exist in .*v5.mat: it has 2 channel"):
        open_recording(tmp_path / "v5.mat").check_channel(2)



def test_a_sample_rate_no_acoustic_recording_has_is_refused_naming_the_file(tmp_path, stereo):
    """A .mat v7.3 whose rate's last byte a flipped bit turned into 5.8e28 Hz sized arrays beyond memory
    ("Maximum allowed size exceeded", no file named: found by tests/io/test_fuzz_readers.py)."""
    path, x = stereo
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        f["x"] = x.T
        f["fs"] = np.array([[5.8e28]])
    with pytest.raises(InputFileError, match=r"v73.mat: a sample rate of 5.8e\+28 Hz is above 1e\+08 Hz"):
        open_recording(tmp_path / "v73.mat")
    assert open_recording(tmp_path / "v73.mat", sample_rate_hz=FS).sample_rate_hz == FS  # given: used
    with pytest.raises(InputFileError, match=r"sample-rate: a sample rate of 1e\+09 Hz is above"):
        open_recording(path, sample_rate_hz=1e9)


def test_every_stream_source_shares_the_rate_bound(tmp_path, stereo):
    """Pipes, live streams and sound cards refuse the rate a file would (they checked only > 0 before)."""
    from seamodem.io.device import open_device
    from seamodem.io.live import open_live

    path, _ = stereo
    damaged = bytearray(_wav_bytes(path))
    damaged[24:28] = (500_000_000).to_bytes(4, "little")  # the fmt chunk's rate: 500 MHz
    (tmp_path / "damaged.wav").write_bytes(bytes(damaged))
    with pytest.raises(InputFileError, match=r"pipe: a sample rate of 5e\+08 Hz is above 1e\+08 Hz.*damaged header"):
        open_stream(io.BytesIO(bytes(damaged)), name="pipe")
    with pytest.raises(InputFileError, match=r"damaged.wav: a sample rate of 5e\+08 Hz .*damaged WAV header"):
        open_live(str(tmp_path / "damaged.wav"))
    for opened in (lambda: open_stream(io.BytesIO(b"\0" * 64), sample_rate_hz=1e9, n_channels=1),
                   lambda: open_live(str(path), raw_format="S16_LE", sample_rate_hz=1e9),
                   lambda: open_device("0", sample_rate_hz=1e9)):
        with pytest.raises(InputFileError, match=r"^sample-rate: a sample rate of 1e\+09 Hz is above 1e\+08 Hz"):
            opened()
    assert open_stream(io.BytesIO(_wav_bytes(path))).sample_rate_hz == FS  # the bound is not in the way


def test_notes_are_warned_once_when_opened(tmp_path, stereo):
    path, _ = stereo
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        src = open_recording(path, sample_rate_hz=FS * 2)
    assert [str(w.message) for w in caught] == src.notes and issubclass(caught[0].category, RecordingWarning)
    assert "the file says 8000 Hz, the command line 16000 Hz" in src.notes[0] and src.sample_rate_hz == 2 * FS
    from seamodem.io.mat import RecordingWarning as MatWarning
    from seamodem.io.mat import open_recording as mat_open

    assert MatWarning is RecordingWarning and mat_open is open_recording


def test_counted_range_and_segments_add_up(stereo):
    path, x = stereo
    src = open_recording(path)
    totals = []
    for start, end in [(0, 10_000), (10_000, 20_000), (20_000, 30_000)]:
        stats = BlockStats()
        data = _all(src, channels=[1], start=max(0, start - 500), stop=min(len(x), end + 500), counted=(start, end),
                    stats=stats)
        np.testing.assert_array_equal(data[:, 0], x[max(0, start - 500):min(len(x), end + 500), 1])
        totals.append(stats.clipped)
    assert totals == [3, 0, 1]
