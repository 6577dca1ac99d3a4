"""Payload coding: bytes → CRC → convolutional code → interleaver → scrambler → bits.

Layout of the coded block (``FrameConfig.n_coded_bits`` bits, MSB first):

1. information block: a 2-byte big-endian payload length, the payload, zero
   bytes up to ``capacity_bytes``, then the CRC of all of these (CRC-16/CCITT-
   FALSE or CRC-32), then zero bits up to ``n_info_bits``;
2. with ``fec = "conv_k7_r12"``: the K = 7, rate 1/2 code with generators
   (133, 171) octal, terminated by 6 zero tail bits, output c0 c1 per input bit,
   zero-filled to ``n_coded_bits`` and permuted by a row-in/column-out block
   interleaver; with ``fec = "none"``: the information block itself;
3. XOR with the PN9 sequence (x⁹ + x⁵ + 1, all-ones seed), so that a short or
   zero payload does not put spectral lines in the data band.

The decoder (soft Viterbi) lives in ``seamodem.decode``; this module offers the
inverse permutation and descrambling that it needs (:func:`code_order_llr`).
"""

from __future__ import annotations

import zlib
from functools import lru_cache

import numpy as np

from ..config import CRC_SCHEMES, LENGTH_HEADER_BYTES, FrameConfig
from ..errors import PayloadError

__all__ = [
    "crc16_ccitt",
    "crc",
    "conv_encode",
    "CONV_GENERATORS",
    "interleaver_permutation",
    "pn9_sequence",
    "encode_payload",
    "encode_info",
    "info_block",
    "parse_info_block",
    "code_order_llr",
]

#: Generator polynomials of the K = 7 code, octal 133 and 171 (NASA/CCSDS).
CONV_GENERATORS = (0o133, 0o171)
CONSTRAINT_LENGTH = 7


def _crc16_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.uint32)
    for i in range(256):
        c = i << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) if c & 0x8000 else (c << 1)
        table[i] = c & 0xFFFF
    return table


_CRC16_TABLE = _crc16_table()


def crc16_ccitt(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF); check value 0x29B1 for b"123456789".

    Parameters
    ----------
    data : bytes
        The message.

    Returns
    -------
    int
        The CRC, in [0, 0xFFFF].
    """
    c = 0xFFFF
    for byte in data:
        c = ((c << 8) & 0xFFFF) ^ int(_CRC16_TABLE[((c >> 8) ^ byte) & 0xFF])
    return c


def crc(data: bytes, scheme: str) -> bytes:
    """Frame check sequence of ``data`` as big-endian bytes."""
    if scheme == "crc16":
        return crc16_ccitt(data).to_bytes(2, "big")
    if scheme == "crc32":
        return (zlib.crc32(data) & 0xFFFFFFFF).to_bytes(4, "big")
    raise ValueError(f"crc must be one of {sorted(CRC_SCHEMES)}, got {scheme!r}")


def conv_encode(
    bits: np.ndarray, *, generators: tuple[int, ...] = CONV_GENERATORS, constraint_length: int = CONSTRAINT_LENGTH
) -> np.ndarray:
    """Encode with the K = 7 (133, 171) code (or the given one), zero-terminated.

    Parameters
    ----------
    bits : numpy.ndarray, shape (n,)
        Information bits (0/1).
    generators : tuple of int
        Generator polynomials (octal by convention), MSB tapping the newest input bit.
    constraint_length : int
        K: the encoder appends K − 1 zero tail bits.

    Returns
    -------
    numpy.ndarray, shape (2·(n + K − 1),)
        Coded bits c0[0], c1[0], c0[1], c1[1], … The tail drives the encoder
        back to the all-zero state.
    """
    k = constraint_length
    u = np.concatenate([np.asarray(bits, dtype=np.int64), np.zeros(k - 1, dtype=np.int64)])
    out = np.empty((u.size, len(generators)), dtype=np.uint8)
    for j, g in enumerate(generators):
        # tap i of the generator (MSB = current input) multiplies u[n − i]
        taps = np.array([(g >> (k - 1 - i)) & 1 for i in range(k)])
        out[:, j] = np.convolve(u, taps)[: u.size] % 2
    return out.ravel()


@lru_cache(maxsize=32)
def interleaver_permutation(n: int) -> np.ndarray:
    """Row-in, column-out block interleaver over ``n`` bits.

    Bits are written in rows of ``ceil(√n)`` and read column by column (the
    last row may be short). ``interleaved = bits[perm]``;
    ``bits[perm] = interleaved`` undoes it.
    """
    cols = int(np.ceil(np.sqrt(n)))
    i = np.arange(n)
    perm = np.lexsort((i // cols, i % cols))
    perm.setflags(write=False)
    return perm


@lru_cache(maxsize=32)
def pn9_sequence(n: int) -> np.ndarray:
    """First ``n`` bits of the PN9 sequence x⁹ + x⁵ + 1 from the all-ones state."""
    state = 0x1FF
    out = np.empty(n, dtype=np.uint8)
    for i in range(n):
        bit = ((state >> 8) ^ (state >> 4)) & 1
        out[i] = state & 1
        state = ((state << 1) | bit) & 0x1FF
    out.setflags(write=False)
    return out


def _bytes_to_bits(data: bytes) -> np.ndarray:
    return np.unpackbits(np.frombuffer(data, dtype=np.uint8))


def info_block(payload: bytes, config: FrameConfig) -> np.ndarray:
    """Information bits (``config.n_info_bits``): length, payload, padding, CRC.

    Raises
    ------
    PayloadError
        If the payload is longer than ``config.capacity_bytes``.
    """
    payload = bytes(payload)
    if len(payload) > config.capacity_bytes:
        raise PayloadError(
            f"payload: {len(payload)} bytes exceed the frame capacity of {config.capacity_bytes} bytes"
        )
    body = len(payload).to_bytes(LENGTH_HEADER_BYTES, "big") + payload
    body += bytes(config.capacity_bytes - len(payload))
    bits = _bytes_to_bits(body + crc(body, config.crc))
    return np.concatenate([bits, np.zeros(config.n_info_bits - bits.size, dtype=np.uint8)])


def parse_info_block(bits: np.ndarray, config: FrameConfig) -> tuple[bytes, bool]:
    """Inverse of :func:`info_block`: (payload, crc_ok).

    The payload is returned even when the CRC fails (for inspection); its
    length field is clipped to the capacity.

    Parameters
    ----------
    bits : array_like of {0, 1}, shape (n_info_bits,)
        Decoded information bits (more are ignored).
    config : FrameConfig
        The frame configuration (capacity, CRC, FEC, data length).

    Returns
    -------
    payload : bytes
        The payload, at most ``config.capacity_bytes`` long.
    crc_ok : bool
        Whether the CRC matches.
    """
    n_body = LENGTH_HEADER_BYTES + config.capacity_bytes
    n_crc = CRC_SCHEMES[config.crc]
    data = np.packbits(np.asarray(bits[: 8 * (n_body + n_crc)], dtype=np.uint8)).tobytes()
    body, check = data[:n_body], data[n_body:]
    length = min(int.from_bytes(body[:LENGTH_HEADER_BYTES], "big"), config.capacity_bytes)
    ok = crc(body, config.crc) == check
    return body[LENGTH_HEADER_BYTES : LENGTH_HEADER_BYTES + length], ok


def encode_payload(payload: bytes, config: FrameConfig) -> np.ndarray:
    """The ``config.n_coded_bits`` bits that the data symbols carry.

    Parameters
    ----------
    payload : bytes
        At most ``config.capacity_bytes`` bytes.
    config : FrameConfig
        The frame configuration (capacity, CRC, FEC, data length).

    Returns
    -------
    numpy.ndarray, shape (n_coded_bits,), uint8
        Length, payload, padding and CRC, coded, interleaved and scrambled.

    Raises
    ------
    PayloadError
        The payload exceeds the capacity.
    """
    return encode_info(info_block(payload, config), config)


def encode_info(info: np.ndarray, config: FrameConfig) -> np.ndarray:
    """Code, interleave and scramble an information block (``config.n_info_bits``) into on-air bits."""
    n = config.n_coded_bits
    if config.fec == "none":
        return info ^ pn9_sequence(n)
    coded = conv_encode(info)
    coded = np.concatenate([coded, np.zeros(n - coded.size, dtype=np.uint8)])
    return coded[interleaver_permutation(n)] ^ pn9_sequence(n)


def code_order_llr(llr_air: np.ndarray, config: FrameConfig) -> np.ndarray:
    """Undo the scrambler (sign flips) and the interleaver on LLRs in on-air order.

    L = log P(b = 0)/P(b = 1); for hard bits pass 1 − 2·bits and read the sign.

    Parameters
    ----------
    llr_air : array_like, shape (n_coded_bits,)
        LLRs in the order the bits were sent (more are ignored).
    config : FrameConfig
        The frame configuration (capacity, CRC, FEC, data length).

    Returns
    -------
    numpy.ndarray, shape (n_coded_bits,)
        LLRs in the coder's output order, ready for the Viterbi decoder.
    """
    n = config.n_coded_bits
    llr = np.asarray(llr_air, dtype=float)[:n] * (1.0 - 2.0 * pn9_sequence(n))
    if config.fec == "none":
        return llr
    out = np.empty(n)
    out[interleaver_permutation(n)] = llr
    return out
