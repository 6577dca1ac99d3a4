"""Cramér–Rao bounds of SPEC §6, used as the per-frame standard deviations of a record.

Every function takes the in-band SNR of SPEC §1 (data-band signal power over the
noise power in B = (1 + α)/T) or a C/N0, and returns a standard deviation.
"""

from __future__ import annotations

import numpy as np

from ..config import FrameConfig

__all__ = [
    "gabor_bandwidth_hz",
    "delay_crlb_s",
    "tone_frequency_crlb_hz",
    "tone_c_n0_hz",
    "tone_velocity_crlb_mps",
    "pilot_velocity_crlb_mps",
]


def gabor_bandwidth_hz(symbol_rate_hz: float, rolloff: float) -> float:
    """RMS (Gabor) bandwidth β of the SRRC pulse [Hz].

    Parameters
    ----------
    symbol_rate_hz : float
        Symbol rate R = 1/T [Bd].
    rolloff : float
        SRRC roll-off α, in [0, 1].

    Returns
    -------
    float
        β [Hz].

    Notes
    -----
    β² = (R²/12)(1 + α²(3 − 24/π²)) (SPEC §6): 1930 Hz at 6.4 kBd, α = 0.4.
    """
    return float(np.sqrt(symbol_rate_hz**2 / 12 * (1 + rolloff**2 * (3 - 24 / np.pi**2))))


def _pilot_energy_ratio(config: FrameConfig, snr_db):
    """2E/N0 of the pilot: 2·Np·Es/N0 with Es/N0 = SNR·(1 + α)."""
    es_n0 = 10 ** (np.asarray(snr_db, dtype=float) / 10) * (1 + config.rolloff)
    return 2 * config.n_pilot * es_n0


def delay_crlb_s(config: FrameConfig, snr_db) -> np.ndarray:
    """Lower bound on the std of the pilot's arrival time [s] at an in-band SNR [dB].

    Parameters
    ----------
    config : FrameConfig
        The frame configuration (pilot length, symbol rate, roll-off, ...).
    snr_db : float or array_like
        In-band SNR [dB] (SPEC §1).

    Returns
    -------
    numpy.ndarray
        σ_τ [s], the shape of ``snr_db``.

    Notes
    -----
    σ_τ ≥ 1 / (2π β √(2E/N0)), E the pilot energy (SPEC §6).
    """
    beta = gabor_bandwidth_hz(config.symbol_rate_hz, config.rolloff)
    return 1.0 / (2 * np.pi * beta * np.sqrt(_pilot_energy_ratio(config, snr_db)))


def tone_frequency_crlb_hz(c_n0_hz, duration_s: float) -> np.ndarray:
    """Rife & Boorstyn bound on a tone's frequency [Hz]: √(3 / (2π² (C/N0) T³)).

    Parameters
    ----------
    c_n0_hz : array_like
        Tone power over one-sided noise PSD [Hz].
    duration_s : float
        Observation time T [s].

    Returns
    -------
    numpy.ndarray
        σ_f [Hz], the shape of ``c_n0_hz``.
    """
    return np.sqrt(3.0 / (2 * np.pi**2 * np.asarray(c_n0_hz, dtype=float) * duration_s**3))


def tone_c_n0_hz(config: FrameConfig, snr_db) -> np.ndarray:
    """C/N0 of the tone implied by an in-band SNR and the configured power split [Hz].

    Parameters
    ----------
    config : FrameConfig
        The frame configuration (pilot length, symbol rate, roll-off, ...).
    snr_db : float or array_like
        In-band SNR [dB] (SPEC §1).

    Returns
    -------
    numpy.ndarray
        C/N0 = SNR · B · share / (1 − share) [Hz], the shape of ``snr_db``.
    """
    snr = 10 ** (np.asarray(snr_db, dtype=float) / 10)
    return snr * config.bandwidth_hz * config.tone_power_share / (1 - config.tone_power_share)


def tone_velocity_crlb_mps(config: FrameConfig, c_n0_hz, *, sound_speed_mps: float) -> np.ndarray:
    """Bound on v_r from the tone over the frame [m/s]: (c / f_pt)·σ_f (SPEC §6).

    Parameters
    ----------
    config : FrameConfig
        The frame configuration (pilot length, symbol rate, roll-off, ...).
    c_n0_hz : float or array_like
        Tone C/N0 [Hz] (e.g. from :func:`tone_c_n0_hz`).
    sound_speed_mps : float
        Sound speed c [m/s].

    Returns
    -------
    numpy.ndarray
        σ_v [m/s], the shape of ``c_n0_hz``.
    """
    sigma_f = tone_frequency_crlb_hz(c_n0_hz, config.frame_duration_s)
    return sound_speed_mps / config.tone_hz * sigma_f


def pilot_velocity_crlb_mps(config: FrameConfig, snr_db, *, sound_speed_mps: float) -> np.ndarray:
    """Bound on v_r from the pilot alone (the filter-bank method) [m/s].

    Parameters
    ----------
    config : FrameConfig
        The frame configuration (pilot length, symbol rate, roll-off, ...).
    snr_db : float or array_like
        In-band SNR [dB] (SPEC §1).
    sound_speed_mps : float
        Sound speed c [m/s].

    Returns
    -------
    numpy.ndarray
        σ_v [m/s], the shape of ``snr_db``.

    Notes
    -----
    The Doppler shows in the baseband as a carrier offset f0·v/c; a known
    signal of energy E and RMS duration T_rms gives σ_f ≥ 1/(2π T_rms √(2E/N0)),
    with T_rms = Np·T/√12 for a train of Np equal-energy symbols.
    """
    t_rms = config.n_pilot * config.symbol_period_s / np.sqrt(12)
    sigma_f = 1.0 / (2 * np.pi * t_rms * np.sqrt(_pilot_energy_ratio(config, snr_db)))
    return sound_speed_mps / config.carrier_hz * sigma_f
