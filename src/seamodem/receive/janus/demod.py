"""JANUS demodulation: chip energies at the packet's time scale, soft bits, de-interleaving, Viterbi, CRC.

Chip i of a packet that starts at baseband sample t0 with time scale 1 + ε begins at
t0 + i·n_chip/(1 + ε); its tones arrive at f_k·(1 + ε) + fc·ε about fc. Each chip's 26 tone
energies come from one matrix product. The soft bit of a chip is the non-coherent BFSK
log-likelihood ratio, log I0(2√(Es·E0)/N) − log I0(2√(Es·E1)/N), with N the chip's noise (the
median of the 24 tones it does not use, never below the packet's) and Es the packet's mean chip
energy: a click inflates only its own chips' N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import i0e

from ...decode.viterbi import trellis, viterbi_decode
from ...transmit.janus import (
    JANUS_CONSTRAINT_LENGTH,
    JANUS_GENERATORS,
    JanusParameterSet,
    bits_to_bytes,
    conv_encode_janus,
    hop_slots,
    interleaver_permutation_janus,
)

__all__ = ["chip_energies", "chip_llrs", "decode_block", "BlockDecision"]

_OUTPUTS, _ = trellis(JANUS_GENERATORS, JANUS_CONSTRAINT_LENGTH)


def chip_energies(
    x_bb: np.ndarray, fs_bb: float, pset: JanusParameterSet, start: float, eps: float, first: int, count: int
) -> np.ndarray:
    """Energy of the 26 tones in chips ``first`` … ``first + count − 1`` (chip 0: the first preamble chip).

    Returns
    -------
    numpy.ndarray, shape (count, 26); NaN rows for chips beyond the recording
    """
    n_chip = int(round(pset.chip_s * fs_bb))
    idx = np.arange(first, first + count)
    starts = np.round(start + idx * n_chip / (1 + eps)).astype(np.int64)
    m = np.arange(n_chip)
    ok = (starts >= 0) & (starts + n_chip <= len(x_bb))
    seg = np.zeros((count, n_chip), dtype=complex)
    seg[ok] = x_bb[starts[ok, None] + m[None, :]]
    f = np.asarray(pset.tone_offsets_hz(), dtype=np.float64) * (1 + eps) + pset.fc_hz * eps
    dft = np.exp(-2j * np.pi * np.outer(m, f) / fs_bb)
    e = np.abs(seg @ dft) ** 2
    e[~ok] = np.nan
    return e


def chip_llrs(energies: np.ndarray, slots: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Soft chip bits L = log P(bit 0)/P(bit 1) from tone energies.

    Parameters
    ----------
    energies : numpy.ndarray, shape (n, 26)
    slots : numpy.ndarray, shape (n,)
        The frequency slot of each chip.

    Returns
    -------
    llr : numpy.ndarray, shape (n,)
    es : float
        Mean chip energy above the noise.
    n0 : float
        The block's noise energy per tone.
    """
    n = len(slots)
    rows = np.arange(n)
    e0 = energies[rows, 2 * slots]
    e1 = energies[rows, 2 * slots + 1]
    others = energies.copy()
    others[rows, 2 * slots] = np.nan
    others[rows, 2 * slots + 1] = np.nan
    # median of an exponential variable is ln 2 × its mean
    local = np.nanmedian(others, axis=1) / np.log(2)
    n0 = float(np.nanmedian(local))
    noise = np.maximum(np.maximum(local, n0), 1e-300)
    es = max(float(np.mean(np.maximum(e0, e1) - noise)), 1e-3 * n0)
    a0 = 2 * np.sqrt(es * e0) / noise
    a1 = 2 * np.sqrt(es * e1) / noise
    llr = (np.log(i0e(a0)) + a0) - (np.log(i0e(a1)) + a1)
    return np.nan_to_num(llr), es, n0


@dataclass(frozen=True)
class BlockDecision:
    """A decoded block (base packet or cargo).

    Attributes
    ----------
    data : bytes
        The decoded bytes.
    agreement : float
        Σ L·(1 − 2c) / Σ|L| over the block's chips, c the re-encoded decision: 1 when every chip
        agrees with the decoded codeword (about 0.85 on noise: the best of 2⁶⁴ codewords).
    margin : float
        Mean over the block's chips of (energy of the decoded codeword's tone − energy of the other
        tone of the pair) / N0: Es/N0 along the decoded path (a signal's), near 0 on noise.
    es_n0 : float
        Mean chip energy over noise per tone, linear.
    """

    data: bytes
    agreement: float
    margin: float
    es_n0: float


def decode_block(
    x_bb: np.ndarray, fs_bb: float, pset: JanusParameterSet, start: float, eps: float, first_chip: int, n_bytes: int
) -> BlockDecision:
    """Demodulate and decode one coded block of ``n_bytes`` starting at chip ``first_chip``.

    Returns
    -------
    BlockDecision
    """
    n_bits = 8 * n_bytes
    n = 2 * (n_bits + JANUS_CONSTRAINT_LENGTH - 1)
    slots = hop_slots(first_chip + n, pset)[first_chip:]
    energies = chip_energies(x_bb, fs_bb, pset, start, eps, first_chip, n)
    llr_sent, es, n0 = chip_llrs(np.nan_to_num(energies), slots)
    llr = np.empty(n)
    llr[interleaver_permutation_janus(n)] = llr_sent
    bits = viterbi_decode(llr, n_bits, outputs=_OUTPUTS)
    coded = conv_encode_janus(bits)
    agreement = float(np.sum(llr * (1 - 2.0 * coded)) / max(np.sum(np.abs(llr)), 1e-300))
    sent = coded[interleaver_permutation_janus(n)].astype(np.int64)
    rows = np.arange(n)
    e = np.nan_to_num(energies)
    margin = float(np.mean(e[rows, 2 * slots + sent] - e[rows, 2 * slots + 1 - sent]) / max(n0, 1e-300))
    return BlockDecision(data=bits_to_bytes(bits), agreement=agreement, margin=margin, es_n0=es / max(n0, 1e-300))
