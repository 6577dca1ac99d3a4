"""JANUS channel coding: the K = 9 rate-1/2 code (753, 561), the prime-stride interleaver and the hopping pattern.

Each block (the 64-bit base packet, then the cargo) is coded on its own: the encoder starts in
state 0, 8 zero tail bits close it, and the 753 output precedes the 561 output for every bit.
The coded chips of a block of length L are interleaved by a stride p, the first prime ≥ 5 with
⌊L/p⌋ < p and L mod p ≠ 0: output chip i is input chip (i·p) mod L.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..coding import conv_encode
from .pset import JanusParameterSet

__all__ = [
    "JANUS_GENERATORS",
    "JANUS_CONSTRAINT_LENGTH",
    "PREAMBLE_BITS",
    "conv_encode_janus",
    "interleave_stride",
    "interleaver_permutation_janus",
    "hop_slots",
    "block_chips",
]

#: Generators of the JANUS code (octal 753, 561); the MSB taps the newest input bit.
JANUS_GENERATORS = (0o753, 0o561)
JANUS_CONSTRAINT_LENGTH = 9
_TAIL = JANUS_CONSTRAINT_LENGTH - 1

#: The 32 preamble chips' bits: 0xAEC7CD20, MSB first.
PREAMBLE_BITS = np.unpackbits(np.frombuffer((0xAEC7CD20).to_bytes(4, "big"), dtype=np.uint8))
PREAMBLE_BITS.setflags(write=False)


def block_chips(n_bits: int) -> int:
    """Chips of a coded block of ``n_bits`` information bits: 2·(n_bits + 8)."""
    return 2 * (n_bits + _TAIL)


def conv_encode_janus(bits: np.ndarray) -> np.ndarray:
    """Encode with the (753, 561) K = 9 code and 8 zero tail bits.

    Parameters
    ----------
    bits : numpy.ndarray, shape (n,)
        Information bits (0/1).

    Returns
    -------
    numpy.ndarray, shape (2·(n + 8),), uint8
        c0[0], c1[0], c0[1], … (c0 from 753, c1 from 561).
    """
    return conv_encode(bits, generators=JANUS_GENERATORS, constraint_length=JANUS_CONSTRAINT_LENGTH)


def interleave_stride(n: int) -> int:
    """The interleaver's stride for a block of ``n`` chips (13 for the 144-chip base packet)."""
    p = 5
    while True:
        if all(p % d for d in range(2, int(p**0.5) + 1)) and n // p < p and n % p != 0:
            return p
        p += 1


@lru_cache(maxsize=64)
def interleaver_permutation_janus(n: int) -> np.ndarray:
    """Permutation of a block of ``n`` chips: ``sent = coded[perm]``, ``coded[perm] = sent`` undoes it."""
    perm = (np.arange(n) * interleave_stride(n)) % n
    perm.setflags(write=False)
    return perm


def hop_slots(n_chips: int, pset: JanusParameterSet) -> np.ndarray:
    """Frequency slot of chips 0 … n_chips − 1 (chip 0 is the first preamble chip).

    Slot for chip i: b = α^((i mod (Q−1)) + 1) mod Q, u1 = 1 + ⌊i / ((Q−1)·Q)⌋, u2 = ⌊i / (Q−1)⌋,
    slot = b·(u1 + u2·b) mod Q.
    """
    q, alpha = pset.n_slots, pset.alpha
    i = np.arange(n_chips, dtype=np.int64)
    powers = np.array([pow(alpha, k + 1, q) for k in range(q - 1)], dtype=np.int64)
    b = powers[i % (q - 1)]
    u1 = 1 + i // ((q - 1) * q)
    u2 = i // (q - 1)
    return (b * ((u1 + u2 * b) % q)) % q
