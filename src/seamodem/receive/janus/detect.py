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

__all__ = ["JanusCandidate", "tone_shares", "preamble_statistic", "find_preambles", "DETECTION_THRESHOLD"]

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

    Returns
    -------
    numpy.ndarray, shape (26, n_windows), float32
    """
    if len(x_bb) < n_chip:
        return np.zeros((2 * pset.n_slots, 0), dtype=np.float32)
    windows = sliding_window_view(x_bb, n_chip)[::step]
    # tone k sits on bin (k − Q)·n_chip·cf/fs_bb of an n_chip-point DFT
    bins = np.round(np.asarray(pset.tone_offsets_hz()) * n_chip / fs_bb).astype(np.int64) % n_chip
    e = np.abs(fft(windows, axis=1)[:, bins].T) ** 2
    total = e.sum(axis=0)
    return (e / np.maximum(total, 1e-300)).astype(np.float32)


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
) -> list[JanusCandidate]:
    """Candidate preambles, strongest first within each packet-length neighbourhood, in time order.

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

    Returns
    -------
    list of JanusCandidate
    """
    n_chip = int(round(pset.chip_s * fs_bb))
    if len(x_bb) < 33 * n_chip:
        return []
    shares = tone_shares(x_bb, fs_bb, pset, n_chip, _COARSE_STEP)
    eps_max = v_max_mps / sound_speed_mps
    # the preamble's last chip moves 31·n_chip·ε samples: one hypothesis per 2 samples of it
    n_eps = 2 * int(np.ceil(31 * n_chip * eps_max / 2)) + 1
    eps = np.linspace(-eps_max, eps_max, n_eps)
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
    out = []
    for k in sorted(found):
        deps = eps[1] - eps[0] if n_eps > 1 else 0.0
        out.append(_refine(x_bb, fs_bb, pset, n_chip, int(starts[k]), float(eps[np.argmax(stat[:, k])]), deps))
    return out


def _refine(x_bb, fs_bb, pset, n_chip, start, eps0, deps) -> JanusCandidate:
    """Best start (to the sample) and scale (to a sixth of the bank's step) near a coarse candidate."""
    eps = eps0 + deps * np.linspace(-1, 1, 13)
    lo = max(start - _COARSE_STEP, 0)
    hi = lo + 2 * _COARSE_STEP + int(np.ceil(32 * n_chip / (1 + eps.min()))) + 2
    shares = tone_shares(x_bb[lo:hi], fs_bb, pset, n_chip)
    stat, starts = preamble_statistic(shares, pset, n_chip, eps, step=1)
    stat = stat[:, : 2 * _COARSE_STEP + 1]
    j, k = np.unravel_index(np.argmax(stat), stat.shape)
    return JanusCandidate(start=float(lo + starts[k]), scale_eps=float(eps[j]), statistic=float(stat[j, k]))
