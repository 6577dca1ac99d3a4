"""Propagation helpers: sound speed (Mackenzie, from :mod:`seamodem.water.speed`), absorption, spreading, rough-surface loss.

All in SI units except where the published formula fixes others (Thorp: f in
kHz, dB/km), which the function names say.
"""

from __future__ import annotations

import numpy as np

from ..water.speed import sound_speed_mackenzie

__all__ = [
    "sound_speed_mackenzie",
    "thorp_absorption_db_per_km",
    "spreading_gain",
    "absorption_gain",
    "rough_surface_gain",
]


def thorp_absorption_db_per_km(frequency_hz):
    """Thorp's absorption coefficient of sea water [dB/km].

    Parameters
    ----------
    frequency_hz : float or array_like
        Frequency [Hz].

    Returns
    -------
    float or numpy.ndarray
        α [dB/km].

    Notes
    -----
    With f in kHz (SPEC §6): α = 0.11 f²/(1 + f²) + 44 f²/(4100 + f²)
    + 2.75e-4 f² + 0.003. 7.39 dB/km at 28 kHz.

    Examples
    --------
    >>> round(float(thorp_absorption_db_per_km(28e3)), 2)
    7.39
    """
    f2 = (np.asarray(frequency_hz, dtype=float) / 1e3) ** 2
    a = 0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003
    return a[()] if a.ndim == 0 else a


def spreading_gain(range_m, exponent: float):
    """Amplitude factor of geometric spreading, (range / 1 m)^(−k/2).

    ``exponent`` k = 2 is spherical, 1 cylindrical, 1.5 the usual "practical"
    value of shallow-water models; power falls as range^−k.

    Parameters
    ----------
    range_m : float or array_like
        Path length [m], > 0.
    exponent : float
        Spreading exponent k.

    Returns
    -------
    numpy.ndarray
        Amplitude factor [linear], same shape as ``range_m``; 1 at 1 m.
    """
    return np.asarray(range_m, dtype=float) ** (-0.5 * exponent)


def absorption_gain(range_m, alpha_db_per_km: float):
    """Amplitude factor of absorption over ``range_m``: 10^(−α·range/20 000).

    Parameters
    ----------
    range_m : float or array_like
        Path length [m].
    alpha_db_per_km : float
        Absorption coefficient α [dB/km] (e.g. Thorp's at the carrier).

    Returns
    -------
    numpy.ndarray
        Amplitude factor [linear], same shape as ``range_m``.
    """
    return 10.0 ** (-alpha_db_per_km * np.asarray(range_m, dtype=float) / 20_000.0)


def rough_surface_gain(frequency_hz: float, rms_height_m: float, sin_grazing, sound_speed_mps: float):
    """Coherent reflection loss of a rough surface (Kirchhoff approximation).

    Returns the amplitude factor exp(−2 (k σ sin θ)²), k = 2π f / c, σ the RMS
    wave height, θ the grazing angle (the Rayleigh roughness parameter
    2 k σ sin θ squared, halved). 1 for a flat surface.

    Parameters
    ----------
    frequency_hz : float
        Acoustic frequency f [Hz].
    rms_height_m : float
        RMS wave height σ [m]; 0 is a flat surface.
    sin_grazing : float or array_like
        Sine of the grazing angle θ at the surface.
    sound_speed_mps : float
        Sound speed c [m/s].

    Returns
    -------
    numpy.ndarray
        Amplitude factor per reflection [linear], in (0, 1], same shape as
        ``sin_grazing``.
    """
    k = 2.0 * np.pi * frequency_hz / sound_speed_mps
    return np.exp(-2.0 * (k * rms_height_m * np.asarray(sin_grazing, dtype=float)) ** 2)
