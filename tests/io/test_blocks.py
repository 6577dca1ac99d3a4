"""The one block reader: the same blocks for a whole file and its segments, and its checks."""

import numpy as np
import pytest
import soundfile

from seamodem.errors import InputFileError
from seamodem.io.blocks import BlockStats, clip_level, read_blocks

FS = 8000


@pytest.fixture
def pcm(tmp_path):
    x = np.zeros(10_000)
    x[[100, 4000, 9000]] = 1.0  # full scale: clipped in a PCM file
    x[5000:5100] = 0.25
    path = tmp_path / "x.wav"
    soundfile.write(path, x, FS, subtype="PCM_16")
    return path, soundfile.read(path)[0]


def test_whole_file_in_blocks_equals_the_file_and_counts_clipping(pcm):
    path, x = pcm
    stats = BlockStats()
    blocks = list(read_blocks(path, channel=0, stop=len(x), block=3000, stats=stats))
    assert [len(b) for b in blocks] == [3000, 3000, 3000, 1000]
    np.testing.assert_array_equal(np.concatenate(blocks), x)
    assert stats.clipped == 3 and not stats.silent and stats.read == len(x)


def test_segments_count_only_their_own_samples_so_that_totals_add_up(pcm):
    path, x = pcm
    bounds = [(0, 4000), (4000, 8000), (8000, 10_000)]
    totals = []
    for start, end in bounds:
        stats = BlockStats()
        lo, hi = max(0, start - 500), min(len(x), end + 500)  # read with an overlap
        data = np.concatenate(list(read_blocks(path, channel=0, start=lo, stop=hi, counted=(start, end), stats=stats)))
        np.testing.assert_array_equal(data, x[lo:hi])
        totals.append(stats)
    assert sum(s.clipped for s in totals) == 3
    assert [s.silent for s in totals] == [False, False, False]


def test_a_silent_float_file_and_the_clip_levels(tmp_path):
    path = tmp_path / "z.wav"
    soundfile.write(path, np.zeros(1000), FS, subtype="FLOAT")
    stats = BlockStats()
    list(read_blocks(path, channel=0, stop=1000, stats=stats))
    assert stats.silent and stats.clipped == 0
    assert clip_level("PCM_16") == 1 - 2.0**-15 and clip_level("FLOAT") == 1.0


def test_nan_and_truncation_are_one_line_input_errors(tmp_path):
    path = tmp_path / "n.wav"
    x = np.zeros(1000)
    x[700] = np.nan
    soundfile.write(path, x, FS, subtype="FLOAT")
    with pytest.raises(InputFileError, match="NaN or infinite samples"):
        list(read_blocks(path, channel=0, stop=1000))
    short = tmp_path / "s.wav"
    soundfile.write(short, np.zeros(1000), FS, subtype="FLOAT")
    with pytest.raises(InputFileError, match="is truncated: it ends at sample 1000, before 1200"):
        list(read_blocks(short, channel=0, stop=1200, block=300))  # a header that promised more
