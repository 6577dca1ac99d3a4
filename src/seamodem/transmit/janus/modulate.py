"""JANUS chip synthesis: continuous-phase FH-BFSK chips, wake-up tones, up-conversion and S16 output.

A single phasor runs through every chip (continuous phase), advanced by the chip's tone before
each output sample. Each chip ramps up and down over ⌊lt/16⌋ samples along the halves of a
Hamming window of ⌊lt/8⌋ samples (lt = round(Tc·fs)). Chip i spans samples
round(i·Tc·fs) … round((i+1)·Tc·fs) − 1 of the chip stream. The passband is
Re{s_bb[n]·A·e^{j2π fc n/fs}}, n counted from the file's first sample.
"""

from __future__ import annotations

import numpy as np
from scipy.signal.windows import tukey

from .pset import JanusParameterSet

__all__ = ["chip_envelope", "chip_bounds", "synthesize_chips", "wake_up_tones", "upconvert", "to_s16", "WUT_GAP_S"]

#: Silence between the wake-up tones and the preamble [s].
WUT_GAP_S = 0.4


def chip_bounds(n_chips: int, chip_s: float, fs: float) -> np.ndarray:
    """Start sample of chips 0 … n_chips (the last entry is the end), shape (n_chips + 1,)."""
    return np.round(np.arange(n_chips + 1) * chip_s * fs).astype(np.int64)


def chip_envelope(n: int, lt: int) -> np.ndarray:
    """Amplitude of an ``n``-sample chip: half-Hamming ramps of ⌊lt/16⌋ samples at each end, 1 between.

    The rise is the window's first ⌊lt/16⌋ samples, the fall its samples ⌊lt/8⌋ − ⌊lt/16⌋ − 1 to
    ⌊lt/8⌋ − 2 (matched on the reference WAVs, where ⌊lt/8⌋ is odd; with an even window length,
    e.g. 44.1 kHz, that choice is unverified and may differ from the reference by one window sample).
    """
    ramp = lt // 16
    wlen = lt // 8
    w = 0.54 - 0.46 * np.cos(2 * np.pi * np.arange(wlen) / (wlen - 1)) if wlen > 1 else np.ones(wlen)
    env = np.ones(n)
    env[:ramp] = w[:ramp]
    env[n - ramp:] = w[wlen - ramp - 1 : wlen - 1]
    return env


def synthesize_chips(tones: np.ndarray, pset: JanusParameterSet, fs: float) -> np.ndarray:
    """Complex baseband of a chip stream.

    Parameters
    ----------
    tones : numpy.ndarray, shape (n_chips,)
        Tone index 2·slot + bit of each chip.
    pset : JanusParameterSet
        Parameter set (tone spacing, chip duration).
    fs : float
        Sample rate [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_samples,), complex128
    """
    offsets = np.asarray(pset.tone_offsets_hz(), dtype=np.float64)
    bounds = chip_bounds(len(tones), pset.chip_s, fs)
    lengths = np.diff(bounds)
    lt = int(round(pset.chip_s * fs))
    n = int(bounds[-1])
    freq = np.repeat(offsets[np.asarray(tones)], lengths)
    # sample m of a chip has advanced m + 1 increments from the chip's start phase
    inc = 2 * np.pi * freq / fs
    start_phase = np.concatenate([[0.0], np.cumsum(inc[bounds[1:-1] - 1] * lengths[:-1])])
    m = np.arange(n) - np.repeat(bounds[:-1], lengths) + 1
    phase = np.repeat(np.mod(start_phase, 2 * np.pi), lengths) + inc * m
    env = np.concatenate([chip_envelope(int(k), lt) for k in lengths]) if len(set(lengths.tolist())) > 1 \
        else np.tile(chip_envelope(int(lengths[0]), lt), len(lengths)) if len(lengths) else np.zeros(0)
    return env * np.exp(1j * phase)


def wake_up_tones(pset: JanusParameterSet, fs: float) -> np.ndarray:
    """Complex baseband of the three wake-up tones (−U/2, 0, +U/2), 4·(lt + 1) samples each, Tukey(0.05)."""
    lt = int(round(pset.chip_s * fs))
    n = 4 * (lt + 1)
    win = tukey(n, 0.05)
    u = pset.used_band_hz
    k = np.arange(n)
    # each tone starts at phase π/2 (measured on the reference WAV)
    return np.concatenate([1j * win * np.exp(2j * np.pi * f * k / fs) for f in (-u / 2, 0.0, u / 2)])


def upconvert(x_bb: np.ndarray, fc_hz: float, fs: float, *, amplitude: float = 0.95, start: int = 0) -> np.ndarray:
    """Re{x_bb[n]·A·e^{j2π fc (n + start)/fs}} (float64)."""
    n = np.arange(start, start + len(x_bb))
    return np.real(x_bb * amplitude * np.exp(2j * np.pi * fc_hz * n / fs))


def to_s16(x_pb: np.ndarray) -> np.ndarray:
    """S16 samples as the reference writes them: truncation of x·32768 toward zero."""
    return np.trunc(np.clip(x_pb, -1.0, 32767 / 32768) * 32768).astype(np.int16)
