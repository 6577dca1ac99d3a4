"""The impulse blanker (receive/impulse.py) against its rule computed naively: every chunk's median."""

from __future__ import annotations

import numpy as np
import pytest

from seamodem.receive import impulse
from seamodem.receive.impulse import ImpulseBlanker


def _naive(x: np.ndarray, *, threshold=5.0, chunk=256, extend=2.5, reach=1, guard=0) -> np.ndarray:
    """Steps 1–3 of the module docstring on a whole buffer, every chunk's scale computed (the first
    (n_chunks − 1)·chunk samples: what one push of the buffer returns)."""
    mag = np.abs(x)
    n = len(x) // chunk
    scales = np.median(mag[: n * chunk].reshape(n, chunk), axis=1) * (1 / 0.6744897501960817)
    ext = np.concatenate([[scales[0]], scales, [scales[-1]]])
    ref = np.maximum(np.maximum(ext[:-2], ext[1:-1]), ext[2:])
    level = np.repeat(np.where(ref > 0, threshold * ref, np.inf), chunk)
    hit = mag[: n * chunk] > level
    mask = impulse._stretches(mag[: n * chunk], hit, level * (extend / threshold), reach, guard)
    y = x[: (n - 1) * chunk].copy()
    y[mask[: (n - 1) * chunk]] = 0.0
    return y, scales


@pytest.mark.parametrize("case", ["white", "white with clicks", "click beside a loud chunk", "ringing into a quiet chunk",
                                  "silence"])
def test_blanker_equals_every_chunks_median(case):
    """The blanker takes a chunk's median only where an impulse can be (its peak above threshold × a bound on
    its scale): the output must be the one every median gives, bit for bit."""
    rng = np.random.default_rng(7)
    x = rng.standard_normal(256 * 400)
    if case == "white with clicks":
        x[rng.integers(0, x.size, 40)] += 40 * rng.standard_normal(40)
    elif case == "click beside a loud chunk":
        x[256 * 100 : 256 * 101] *= 8  # a loud chunk: its neighbours' level is its
        x[256 * 101 + 10] = 30.0  # 30 σ for its own chunk, under 5 × the loud neighbour's 8 σ: not an impulse
        x[256 * 200 + 10] = 30.0  # the same away from it: an impulse
    elif case == "ringing into a quiet chunk":
        # 40 σ at the end of a chunk, then 4 σ (under the impulse level, over the stretch's 2.5 σ) into the next,
        # whose own peak proves it holds no impulse: the stretch must still run on through it
        x[256 * 300 - 3 : 256 * 300] = 40.0
        x[256 * 300 : 256 * 300 + 12] = 4.0
    elif case == "silence":
        x[256 * 50 : 256 * 60] = 0.0
    b = ImpulseBlanker()
    y = b.push(x)
    expected, scales = _naive(x)
    assert np.array_equal(y, expected)
    assert b._prev_scale == scales[-2]  # the next call's left neighbour: the last chunk output
    if case == "click beside a loud chunk":
        assert y[256 * 101 + 10] == 30.0 and y[256 * 200 + 10] == 0.0
    if case == "ringing into a quiet chunk":
        assert np.all(y[256 * 300 - 3 : 256 * 300 + 12] == 0.0)
