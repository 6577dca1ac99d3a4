"""Gray-mapped PSK constellations: bits ↔ symbols."""

from __future__ import annotations

import numpy as np

from ..config import MODULATIONS

__all__ = ["constellation", "bits_to_symbols", "symbols_to_bits", "nearest_labels"]


def _gray(n: np.ndarray) -> np.ndarray:
    return n ^ (n >> 1)


def constellation(modulation: str) -> np.ndarray:
    """Unit-energy points indexed by their bit label (MSB first).

    BPSK: 0 → +1, 1 → −1. QPSK: first bit on the real axis, second on the
    imaginary, 0 → +, scaled by 1/√2 (Gray). 8PSK: point at angle 2π p/8
    carries label gray(p).

    Parameters
    ----------
    modulation : {"bpsk", "qpsk", "8psk"}
        The PSK alphabet, M = 2, 4 or 8.

    Returns
    -------
    numpy.ndarray, shape (M,), complex
        ``points[label]`` is the symbol that carries ``label``.
    """
    bps = MODULATIONS[modulation]
    m = 1 << bps
    if modulation == "bpsk":
        return np.array([1.0 + 0j, -1.0 + 0j])
    if modulation == "qpsk":
        labels = np.arange(m)
        return ((1 - 2 * (labels >> 1)) + 1j * (1 - 2 * (labels & 1))) / np.sqrt(2)
    points = np.empty(m, dtype=complex)
    p = np.arange(m)
    points[_gray(p)] = np.exp(2j * np.pi * p / m)
    return points


def bits_to_symbols(bits: np.ndarray, modulation: str) -> np.ndarray:
    """Map bits (length a multiple of log2 M, MSB first) to PSK symbols.

    Parameters
    ----------
    bits : array_like of {0, 1}, shape (n_bits,)
        Bits, ``n_bits`` a multiple of log2 M.
    modulation : {"bpsk", "qpsk", "8psk"}
        The PSK alphabet, M = 2, 4 or 8.

    Returns
    -------
    numpy.ndarray, shape (n_bits / log2 M,), complex
        Unit-energy symbols.

    Raises
    ------
    ValueError
        ``n_bits`` not a multiple of log2 M.
    """
    bps = MODULATIONS[modulation]
    bits = np.asarray(bits, dtype=np.int64)
    if bits.size % bps:
        raise ValueError(f"number of bits must be a multiple of {bps} for {modulation}, got {bits.size}")
    groups = bits.reshape(-1, bps)
    labels = groups @ (1 << np.arange(bps - 1, -1, -1))
    return constellation(modulation)[labels]


def nearest_labels(symbols: np.ndarray, modulation: str) -> np.ndarray:
    """The label of the constellation point nearest each symbol (hard decisions): ``constellation(modulation)[
    nearest_labels(y, modulation)]`` are the decided points.

    >>> nearest_labels(np.array([0.9, -1.2, 0.3j]), "bpsk").tolist()
    [0, 1, 0]
    """
    points = constellation(modulation)
    return np.argmin(np.abs(np.asarray(symbols)[:, None] - points[None, :]), axis=1)


def symbols_to_bits(symbols: np.ndarray, modulation: str) -> np.ndarray:
    """Hard decision: nearest constellation point's bit label (MSB first).

    Parameters
    ----------
    symbols : array_like, shape (n_symbols,), complex
        Received symbols, on the unit-energy scale.
    modulation : {"bpsk", "qpsk", "8psk"}
        The PSK alphabet, M = 2, 4 or 8.

    Returns
    -------
    numpy.ndarray, shape (n_symbols · log2 M,), uint8
        Bits.
    """
    bps = MODULATIONS[modulation]
    labels = nearest_labels(symbols, modulation)
    return ((labels[:, None] >> np.arange(bps - 1, -1, -1)) & 1).astype(np.uint8).ravel()
