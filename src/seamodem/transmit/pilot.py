"""Pilot sequence: BPSK with low aperiodic autocorrelation sidelobes.

The sequence is found by a deterministic search that depends only on the
length and the seed (its own integer generator, not numpy's, so that the same
seed gives the same pilot on any numpy version): 40 pseudo-random starts are
each improved by single-bit flips until no flip lowers the peak sidelobe level
(PSL), then the integrated sidelobe level (ISL); the best one wins. The sidecar also stores the bits
themselves, so a recording stays decodable whatever this search becomes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["pilot_bits", "pilot_symbols", "autocorrelation_sidelobes"]

_MASK64 = (1 << 64) - 1


def _splitmix64(state: int):
    while True:
        state = (state + 0x9E3779B97F4A7C15) & _MASK64
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
        yield z ^ (z >> 31)


def autocorrelation_sidelobes(symbols: np.ndarray) -> tuple[float, float]:
    """Peak and integrated aperiodic autocorrelation sidelobes (PSL, ISL).

    Returns
    -------
    (psl, isl) : tuple of float
        max |r[k]| and Σ |r[k]|² over lags k ≠ 0, unnormalised.
    """
    x = np.asarray(symbols)
    r = np.correlate(x, x, mode="full")[x.size :]
    return float(np.max(np.abs(r))), float(np.sum(np.abs(r) ** 2))


def _cost(x: np.ndarray) -> tuple[int, int]:
    r = np.correlate(x, x, mode="full")[x.size :]
    return int(np.max(np.abs(r))), int(np.sum(r * r))


_RESTARTS = 40


def _descend(x: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    best = _cost(x)
    improved = True
    while improved:
        improved = False
        for i in range(x.size):
            x[i] = -x[i]
            cost = _cost(x)
            if cost < best:
                best = cost
                improved = True
            else:
                x[i] = -x[i]
    return best, x


@lru_cache(maxsize=32)
def _search(n: int, seed: int) -> bytes:
    gen = _splitmix64(seed)
    winner = None
    for _ in range(_RESTARTS):
        start = np.array([1 if (next(gen) >> 63) else -1 for _ in range(n)], dtype=np.int64)
        result = _descend(start)
        if winner is None or result[0] < winner[0]:
            winner = result
    return bytes(((1 - winner[1]) // 2).astype(np.uint8))


def pilot_bits(n_pilot: int, seed: int) -> np.ndarray:
    """Bits (0 → +1, 1 → −1) of the ``n_pilot``-symbol pilot for ``seed``.

    Parameters
    ----------
    n_pilot : int
        Pilot length [symbols].
    seed : int
        Pilot seed (``FrameConfig.pilot_seed``); the same seed always gives
        the same pilot.

    Returns
    -------
    numpy.ndarray, shape (n_pilot,), uint8
        The pilot's bits.
    """
    return np.frombuffer(_search(int(n_pilot), int(seed)), dtype=np.uint8).copy()


def pilot_symbols(n_pilot: int, seed: int) -> np.ndarray:
    """BPSK pilot symbols (±1, complex) of length ``n_pilot``.

    Parameters
    ----------
    n_pilot : int
        Pilot length [symbols].
    seed : int
        Pilot seed (see :func:`pilot_bits`).

    Returns
    -------
    numpy.ndarray, shape (n_pilot,), complex
        1 − 2·:func:`pilot_bits`.
    """
    return (1.0 - 2.0 * pilot_bits(n_pilot, seed)).astype(complex)
