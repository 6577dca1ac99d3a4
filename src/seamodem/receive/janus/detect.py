"""JANUS preamble detection: per-chip tone-energy shares of the 32 preamble chips, over a bank of time scales.

The statistic at a start sample n and time scale 1 + ε is 26 × the mean, over the preamble's chips,
of the share of the chip's energy (all 26 tones) that falls in the tone the chip should carry.
Noise gives 1 (± 0.18), a clean packet 26. Each chip weighs at most 1/32, so a click (energy in
every tone) or a wake-up tone (energy in one tone, which at most a chip or two of the preamble
use) cannot raise it: the receiver looks past wake-up tones without a special case.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.fft import fft

from ...transmit.janus import PREAMBLE_BITS, JanusParameterSet, hop_slots

__all__ = ["JanusCandidate", "tone_shares", "preamble_statistic", "find_preambles", "refine_candidate",
           "DETECTION_THRESHOLD"]

#: preamble statistic to declare a candidate: noise gives 1 ± 0.18 (8 σ above)
DETECTION_THRESHOLD = 2.5
#: time-scale hypotheses cover ±(v_max/c) in steps that move the preamble's last chip by ≤ 1/2 sample
_COARSE_STEP = 4


@dataclass(frozen=True)
class JanusCandidate:
    """A preamble found by the detector.

    Attributes
    ----------
    start : float
        Baseband sample of the first preamble chip's start.
    scale_eps : float
        Time-scale ε (received chips last Tc/(1 + ε)); v_r ≈ c·ε.
    statistic : float
        The preamble statistic (1 in noise, 26 clean).
    """

    start: float
    scale_eps: float
    statistic: float


def tone_shares(x_bb: np.ndarray, fs_bb: float, pset: JanusParameterSet, n_chip: int, step: int = 1) -> np.ndarray:
    """Share of each tone in the energy of the chip-long windows starting at samples 0, step, 2·step, …

    ``step`` must divide ``n_chip``. Each block of ``step`` samples is projected on the 26 tones once
    (one small matrix product); a window's tone sums are then running sums of n_chip/step blocks.

    Returns
    -------
    numpy.ndarray, shape (26, n_windows), float32
    """
    n_tones = 2 * pset.n_slots
    per_window = n_chip // step
    n_blocks = len(x_bb) // step
    if n_blocks < per_window or n_chip % step:
        if n_chip % step:
            raise ValueError(f"step must divide the chip's {n_chip} samples, got {step}")
        return np.zeros((n_tones, 0), dtype=np.float32)
    # tone k sits on bin b_k of an n_chip-point DFT; its oscillator at sample step·j + m
    bins = np.round(np.asarray(pset.tone_offsets_hz()) * n_chip / fs_bb).astype(np.int64)
    m = np.arange(step)
    inner = np.exp(-2j * np.pi * np.outer(bins, m) / n_chip).astype(np.complex64)
    # (26, n_blocks), C order: the running sums run along contiguous rows
    blocks = inner @ x_bb[: n_blocks * step].reshape(n_blocks, step).T.astype(np.complex64)
    j = np.arange(per_window)
    outer = np.exp(-2j * np.pi * np.outer(bins, j) * step / n_chip).astype(np.complex64)
    blocks *= np.tile(outer, (1, -(-n_blocks // per_window)))[:, :n_blocks]
    c = np.cumsum(blocks, axis=1, dtype=np.complex128)
    sums = c[:, per_window - 1 :].copy()
    sums[:, 1:] -= c[:, : n_blocks - per_window]
    e = sums.real**2 + sums.imag**2
    return (e / np.maximum(e.sum(axis=0), 1e-300)).astype(np.float32)


def preamble_statistic(shares: np.ndarray, pset: JanusParameterSet, n_chip: int, eps: np.ndarray, step: int = 1):
    """Preamble statistic at each window of ``shares`` (windows ``step`` samples apart) for each time scale in ``eps``.

    Returns
    -------
    stat : numpy.ndarray, shape (len(eps), n_starts)
    starts : numpy.ndarray, shape (n_starts,)
        Start sample of each, relative to the first window.
    """
    tones = 2 * hop_slots(32, pset) + PREAMBLE_BITS
    n_valid = shares.shape[1] - int(np.ceil(31 * n_chip / (1 + min(eps)) / step)) - 1
    n_starts = max(n_valid, 0)
    out = np.zeros((len(eps), n_starts), dtype=np.float32)
    for j, e in enumerate(eps):
        offs = np.round(np.arange(32) * n_chip / (1 + e) / step).astype(np.int64)
        for i in range(32):
            out[j] += shares[tones[i], offs[i] : offs[i] + n_starts]
    return out * (shares.shape[0] / 32), np.arange(n_starts) * step


def find_preambles(
    x_bb: np.ndarray,
    fs_bb: float,
    pset: JanusParameterSet,
    *,
    v_max_mps: float = 5.0,
    sound_speed_mps: float = 1500.0,
    threshold: float = DETECTION_THRESHOLD,
    refine: bool = True,
) -> list[JanusCandidate]:
    """Candidate preambles, the strongest within each preamble-length neighbourhood, in time order.

    Parameters
    ----------
    x_bb : numpy.ndarray
        Baseband (:func:`~seamodem.receive.janus.frontend.to_baseband`).
    fs_bb : float
        Its rate [Hz].
    pset : JanusParameterSet
        Parameter set.
    v_max_mps : float
        Largest |v_r| searched [m/s].
    sound_speed_mps : float
        c [m/s].
    threshold : float
        Statistic above which a start is a candidate.
    refine : bool
        Refine each to the sample (:func:`refine_candidate`); else starts are 4 samples apart and
        scales on the coarse bank.

    Returns
    -------
    list of JanusCandidate
    """
    n_chip = int(round(pset.chip_s * fs_bb))
    if len(x_bb) < 33 * n_chip:
        return []
    shares = tone_shares(x_bb, fs_bb, pset, n_chip, _COARSE_STEP)
    eps = _scale_bank(n_chip, v_max_mps / sound_speed_mps)
    stat, starts = preamble_statistic(shares, pset, n_chip, eps, step=_COARSE_STEP)
    if not starts.size:
        return []
    best = stat.max(axis=0)
    above = np.flatnonzero(best > threshold)
    found = []
    guard = 32 * n_chip // _COARSE_STEP
    while above.size:
        k = above[np.argmax(best[above])]
        found.append(k)
        above = above[np.abs(above - k) > guard]
    out = [JanusCandidate(start=float(starts[k]), scale_eps=float(eps[np.argmax(stat[:, k])]), statistic=float(best[k]))
           for k in sorted(found)]
    if refine:
        out = [refine_candidate(x_bb, fs_bb, pset, c, v_max_mps=v_max_mps, sound_speed_mps=sound_speed_mps)
               for c in out]
    return out


def _scale_bank(n_chip: int, eps_max: float) -> np.ndarray:
    """Time scales of the coarse bank: the preamble's last chip moves 31·n_chip·ε samples, one hypothesis per 2."""
    n_eps = 2 * int(np.ceil(31 * n_chip * eps_max / 2)) + 1
    return np.linspace(-eps_max, eps_max, n_eps)


def refine_candidate(
    x_bb: np.ndarray, fs_bb: float, pset: JanusParameterSet, cand: JanusCandidate, *, v_max_mps: float = 5.0,
    sound_speed_mps: float = 1500.0,
) -> JanusCandidate:
    """Best start (to the sample) and scale (to a sixth of the bank's step) near a coarse candidate.

    Returns
    -------
    JanusCandidate
    """
    n_chip = int(round(pset.chip_s * fs_bb))
    bank = _scale_bank(n_chip, v_max_mps / sound_speed_mps)
    deps = bank[1] - bank[0] if bank.size > 1 else 0.0
    eps = cand.scale_eps + deps * np.linspace(-1, 1, 13)
    start = int(cand.start)
    lo = max(start - _COARSE_STEP, 0)
    hi = lo + 2 * _COARSE_STEP + int(np.ceil(32 * n_chip / (1 + eps.min()))) + 2
    shares = tone_shares(x_bb[lo:hi], fs_bb, pset, n_chip)
    stat, starts = preamble_statistic(shares, pset, n_chip, eps, step=1)
    stat = stat[:, : 2 * _COARSE_STEP + 1]
    j, k = np.unravel_index(np.argmax(stat), stat.shape)
    return JanusCandidate(start=float(lo + starts[k]), scale_eps=float(eps[j]), statistic=float(stat[j, k]))
