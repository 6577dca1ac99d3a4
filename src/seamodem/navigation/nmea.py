"""NMEA 0183 position sentences (GGA, RMC), as autopilots such as ArduSub take them from acoustic positioning.

A sentence is ``$`` + comma-separated fields + ``*`` + two hexadecimal digits
(the XOR of every character between ``$`` and ``*``) + CR LF. Latitude is
``ddmm.mmmmmm`` with N/S, longitude ``dddmm.mmmmmm`` with E/W (WGS-84).

What an acoustic fix cannot say as a GNSS receiver would, and what is sent
instead (docs/live.md):

* fix quality 1 ("GPS fix"): autopilots ignore other values for position;
* satellites: 12 by default, a nominal count (ArduPilot's arming checks want
  at least 6);
* HDOP: the filter's horizontal 1-σ [m] (√(σx² + σy²)), kept in [0.1, 99.9];
* altitude: −depth [m] when a vehicle depth is known, else 0.

Examples
--------
>>> checksum("GPGGA")
'56'
>>> gga(time_s=45319.0, lat_deg=48.1173, lon_deg=11.516666667, sigma_m=0.9)[:43]
'$GPGGA,123519.00,4807.038000,N,01131.000000'
"""

from __future__ import annotations

import math
from datetime import datetime, timezone

__all__ = ["checksum", "sentence", "gga", "rmc", "format_lat", "format_lon"]

KNOTS_PER_MPS = 3600.0 / 1852.0


def checksum(body: str) -> str:
    """The two-hex-digit checksum of a sentence body (the text between ``$`` and ``*``).

    Parameters
    ----------
    body : str
        ASCII, without ``$`` and ``*``.

    Returns
    -------
    str
        XOR of the characters, as two upper-case hexadecimal digits.
    """
    value = 0
    for ch in body.encode("ascii"):
        value ^= ch
    return f"{value:02X}"


def sentence(body: str) -> str:
    """``$BODY*CS`` and CR LF.

    Parameters
    ----------
    body : str
        The fields, comma-separated, starting with the talker and type (``GPGGA``).

    Returns
    -------
    str
    """
    return f"${body}*{checksum(body)}\r\n"


def _angle(value_deg: float, limit: float, degree_digits: int, hemispheres: str, name: str) -> tuple[str, str]:
    if not (math.isfinite(value_deg) and -limit <= value_deg <= limit):
        raise ValueError(f"{name} must be in [{-limit:g}, {limit:g}] deg, got {value_deg!r}")
    a = abs(value_deg)
    degrees = int(a)
    minutes = (a - degrees) * 60.0
    if round(minutes, 6) >= 60.0:  # 59.9999999' rounds up into the next degree
        degrees, minutes = degrees + 1, 0.0
    return f"{degrees:0{degree_digits}d}{minutes:09.6f}", hemispheres[0] if value_deg >= 0 else hemispheres[1]


def format_lat(lat_deg: float) -> tuple[str, str]:
    """Latitude as NMEA ``ddmm.mmmmmm`` and ``N``/``S``.

    Parameters
    ----------
    lat_deg : float
        [deg], in [−90, 90].

    Returns
    -------
    (str, str)
    """
    return _angle(lat_deg, 90.0, 2, "NS", "latitude")


def format_lon(lon_deg: float) -> tuple[str, str]:
    """Longitude as NMEA ``dddmm.mmmmmm`` and ``E``/``W``.

    Parameters
    ----------
    lon_deg : float
        [deg], in [−180, 180].

    Returns
    -------
    (str, str)
    """
    return _angle(lon_deg, 180.0, 3, "EW", "longitude")


def _clock(time_s: float) -> str:
    """UTC time of day ``hhmmss.ss`` of a time [s since midnight, or a POSIX time]."""
    t = time_s % 86400.0
    centi = int(round(t * 100.0)) % 8_640_000
    h, rest = divmod(centi, 360_000)
    m, rest = divmod(rest, 6000)
    return f"{h:02d}{m:02d}{rest // 100:02d}.{rest % 100:02d}"


def gga(*, time_s: float, lat_deg: float, lon_deg: float, sigma_m: float, altitude_m: float = 0.0,
        satellites: int = 12, talker: str = "GP") -> str:
    """A GGA sentence (position fix).

    Parameters
    ----------
    time_s : float
        UTC [s]: a POSIX time, or seconds since midnight (only the time of day is sent).
    lat_deg, lon_deg : float
        WGS-84 [deg].
    sigma_m : float
        Horizontal 1-σ [m], sent as HDOP (module notes).
    altitude_m : float
        Above mean sea level [m] (−depth).
    satellites : int
        Nominal satellite count.
    talker : str
        Talker id.

    Returns
    -------
    str
        The sentence with CR LF.
    """
    lat, ns = format_lat(lat_deg)
    lon, ew = format_lon(lon_deg)
    hdop = min(max(sigma_m, 0.1), 99.9) if math.isfinite(sigma_m) else 99.9
    body = (f"{talker}GGA,{_clock(time_s)},{lat},{ns},{lon},{ew},1,{int(satellites):02d},{hdop:.1f},"
            f"{altitude_m:.2f},M,0.0,M,,")
    return sentence(body)


def rmc(*, time_s: float, lat_deg: float, lon_deg: float, speed_mps: float, course_deg: float,
        talker: str = "GP") -> str:
    """An RMC sentence (position, speed over ground, course, date), NMEA 2.3 with mode A.

    Parameters
    ----------
    time_s : float
        UTC as a POSIX time [s] (the date is sent too).
    lat_deg, lon_deg : float
        WGS-84 [deg].
    speed_mps : float
        Speed over ground [m/s] (sent in knots).
    course_deg : float
        Course over ground, clockwise from true north [deg].
    talker : str
        Talker id.

    Returns
    -------
    str
        The sentence with CR LF.
    """
    lat, ns = format_lat(lat_deg)
    lon, ew = format_lon(lon_deg)
    date = datetime.fromtimestamp(time_s, tz=timezone.utc).strftime("%d%m%y")
    speed = abs(speed_mps) * KNOTS_PER_MPS if math.isfinite(speed_mps) else 0.0
    course = course_deg % 360.0 if math.isfinite(course_deg) else 0.0
    body = f"{talker}RMC,{_clock(time_s)},A,{lat},{ns},{lon},{ew},{speed:.2f},{course:.1f},{date},,,A"
    return sentence(body)
