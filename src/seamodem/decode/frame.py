"""Decode one received frame: fractionally spaced samples from the receiver's Doppler compensation, then DFE / turbo."""

from __future__ import annotations

import numpy as np

from ..config import FrameConfig
from .equalizer import DfeSettings
from .turbo import TurboResult, turbo_equalize

__all__ = ["fractional_samples", "decode_frame"]


def fractional_samples(bb: np.ndarray, fs: float, t0_s: float, compensated, config: FrameConfig, sps: int = 2) -> np.ndarray:
    """Matched filter at ``sps`` instants per symbol along the Doppler-warped grid, phase removed.

    Parameters
    ----------
    bb : numpy.ndarray, complex
        Data-band baseband, bb[n] at t0 + n/fs [s].
    compensated : seamodem.receive.compensate.CompensatedFrame
        The receiver's eq 10–11 output: instants t̂_k, phases φ̂_k and pilot gain.
    config : FrameConfig
    sps : int
        Samples per symbol for the fractionally spaced equaliser.

    Returns
    -------
    numpy.ndarray, complex, shape (sps·(n_pilot + n_data),)
        x[sps·k + i] at t̂ interpolated at k + i/sps, divided by the pilot gain.

    Notes
    -----
    Instants and phases between symbols are linearly interpolated (extrapolated
    past the last symbol), which is exact for a constant speed.
    """
    from ..receive.doppler import matched_filter

    k = np.arange(compensated.times_s.size)
    frac = np.arange(sps * k.size) / sps
    slope_t = compensated.times_s[-1] - compensated.times_s[-2]
    slope_p = compensated.phases_rad[-1] - compensated.phases_rad[-2]
    times = np.interp(frac, k, compensated.times_s) + np.maximum(frac - k[-1], 0) * slope_t
    phases = np.interp(frac, k, compensated.phases_rad) + np.maximum(frac - k[-1], 0) * slope_p
    y = matched_filter(bb, fs, t0_s, times, config=config) * np.exp(-1j * phases)
    return y / compensated.gain


def decode_frame(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    compensated,
    config: FrameConfig,
    pilot: np.ndarray,
    *,
    settings: DfeSettings = DfeSettings(),
    passes: int = 1,
) -> TurboResult:
    """Equalise and decode a Doppler-compensated frame (passes = 1: DFE only; more: turbo)."""
    x = fractional_samples(bb, fs, t0_s, compensated, config, settings.sps)
    return turbo_equalize(x, np.asarray(pilot, dtype=complex), config, settings=settings, passes=passes)
