"""Sound speed of sea water from temperature, salinity and depth or pressure.

Two formulas: Mackenzie (1981), the quick nine-term fit in depth, and TEOS-10
(the Thermodynamic Equation Of Seawater 2010, through the ``gsw`` package), the
field standard a CTD's processing software uses. ``gsw`` is imported only
when TEOS-10 is asked for.
"""

from __future__ import annotations

import numpy as np

__all__ = ["sound_speed_mackenzie", "sound_speed_teos10", "pressure_from_depth", "depth_from_pressure"]

#: latitude assumed when a cast does not give one [deg]: gravity, hence depth ↔ pressure, changes by 0.5 % pole to equator
DEFAULT_LATITUDE_DEG = 45.0


def sound_speed_mackenzie(temperature_c, salinity_ppt, depth_m):
    """Sound speed in sea water, Mackenzie (1981) nine-term equation.

    Parameters
    ----------
    temperature_c : float or array_like
        Temperature T [°C], valid 2–30 °C.
    salinity_ppt : float or array_like
        Salinity S [‰ = g/kg], valid 25–40 ‰.
    depth_m : float or array_like
        Depth D [m] (positive down), valid 0–8000 m.

    Returns
    -------
    float or numpy.ndarray
        c [m/s].

    Notes
    -----
    c = 1448.96 + 4.591 T − 5.304e-2 T² + 2.374e-4 T³ + 1.340 (S − 35)
    + 1.630e-2 D + 1.675e-7 D² − 1.025e-2 T (S − 35) − 7.139e-13 T D³
    (K. V. Mackenzie, J. Acoust. Soc. Am. 70(3), 807–812, 1981; standard error
    0.070 m/s). Check values: c(25 °C, 35 ‰, 1000 m) = 1550.744 m/s (the
    paper's), c(27 °C, 35 ‰, 10 m) = 1539.09 m/s (SPEC §6).

    Examples
    --------
    >>> round(float(sound_speed_mackenzie(25.0, 35.0, 1000.0)), 3)
    1550.744
    """
    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(salinity_ppt, dtype=float) - 35.0
    d = np.asarray(depth_m, dtype=float)
    c = (
        1448.96
        + 4.591 * t
        - 5.304e-2 * t**2
        + 2.374e-4 * t**3
        + 1.340 * s
        + 1.630e-2 * d
        + 1.675e-7 * d**2
        - 1.025e-2 * t * s
        - 7.139e-13 * t * d**3
    )
    return c[()] if c.ndim == 0 else c


def pressure_from_depth(depth_m, *, latitude_deg: float = DEFAULT_LATITUDE_DEG):
    """Sea pressure [dbar] at a depth [m, positive down] (TEOS-10 ``gsw.p_from_z``)."""
    import gsw

    return np.asarray(gsw.p_from_z(-np.asarray(depth_m, dtype=float), latitude_deg), dtype=float)


def depth_from_pressure(pressure_dbar, *, latitude_deg: float = DEFAULT_LATITUDE_DEG):
    """Depth [m, positive down] at a sea pressure [dbar] (TEOS-10 ``gsw.z_from_p``)."""
    import gsw

    return -np.asarray(gsw.z_from_p(np.asarray(pressure_dbar, dtype=float), latitude_deg), dtype=float)


def sound_speed_teos10(temperature_c, practical_salinity, pressure_dbar, *,
                       latitude_deg: float = DEFAULT_LATITUDE_DEG, longitude_deg: float = 0.0):
    """Sound speed in sea water by TEOS-10, from what a CTD records.

    Parameters
    ----------
    temperature_c : float or array_like
        In-situ temperature t [°C, ITS-90].
    practical_salinity : float or array_like
        Practical salinity SP [PSS-78, unitless ≈ ‰].
    pressure_dbar : float or array_like
        Sea pressure p [dbar] (0 at the surface).
    latitude_deg, longitude_deg : float
        Where the cast was taken [deg]; they set the absolute-salinity anomaly
        (``gsw.SA_from_SP``'s atlas). Defaults: 45° N, 0° E.

    Returns
    -------
    numpy.ndarray
        c [m/s], the shape of the broadcast inputs.

    Notes
    -----
    SA = ``gsw.SA_from_SP(SP, p, lon, lat)``, CT = ``gsw.CT_from_t(SA, t, p)``,
    c = ``gsw.sound_speed(SA, CT, p)`` (IOC, SCOR and IAPSO 2010, TEOS-10
    manual eq 2.17.1). Mackenzie (1981) agrees with it to a few 0.1 m/s in the
    upper ocean.
    """
    import gsw

    p = np.asarray(pressure_dbar, dtype=float)
    sa = gsw.SA_from_SP(np.asarray(practical_salinity, dtype=float), p, longitude_deg, latitude_deg)
    ct = gsw.CT_from_t(sa, np.asarray(temperature_c, dtype=float), p)
    return np.asarray(gsw.sound_speed(sa, ct, p), dtype=float)
