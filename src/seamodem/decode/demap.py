"""Soft demapping: PSK symbols → bit log-likelihood ratios (max-log)."""

from __future__ import annotations

import numpy as np

from ..config import MODULATIONS
from ..transmit.modulation import constellation

__all__ = ["soft_demap"]


def soft_demap(symbols: np.ndarray, noise_var: float | np.ndarray, modulation: str) -> np.ndarray:
    """Max-log LLRs, L = log P(b = 0 | y) / P(b = 1 | y), MSB first per symbol.

    Parameters
    ----------
    symbols : numpy.ndarray, shape (n,), complex
        Equalised symbols on the unit-energy constellation.
    noise_var : float or numpy.ndarray, shape (n,)
        Complex noise variance E|y − x|² per symbol.
    modulation : {"bpsk", "qpsk", "8psk"}

    Returns
    -------
    numpy.ndarray, shape (n · log2 M,)

    Notes
    -----
    L_i = (min_{x: b_i = 1} |y − x|² − min_{x: b_i = 0} |y − x|²) / σ²; exact (not max-log)
    for BPSK, and for Gray QPSK, where each bit sees one real dimension.
    """
    bps = MODULATIONS[modulation]
    y = np.asarray(symbols, dtype=complex)
    var = np.maximum(np.asarray(noise_var, dtype=float), 1e-12)  # a noiseless symbol gives a huge, finite LLR
    pts = constellation(modulation)
    d2 = np.abs(y[:, None] - pts[None, :]) ** 2
    labels = np.arange(pts.size)
    llr = np.empty((y.size, bps))
    for i in range(bps):
        one = ((labels >> (bps - 1 - i)) & 1).astype(bool)
        llr[:, i] = (d2[:, one].min(axis=1) - d2[:, ~one].min(axis=1)) / var
    return llr.ravel()
