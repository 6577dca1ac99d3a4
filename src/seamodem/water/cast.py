"""Read a CTD or sound-velocity-profiler cast from a CSV file into a :class:`SoundSpeedProfile`.

Two layouts, told apart by the header:

- a sound-velocity cast: a depth column and a sound-speed column
  (``depth_m,c_mps``; also ``depth``, ``sound_speed_mps``, ``sound_speed``, ``c``);
- a CTD cast: depth *or* pressure, temperature and practical salinity
  (``depth_m`` or ``pressure_dbar``, ``temperature_c``, ``salinity_psu``; also
  ``pressure``, ``p``, ``temperature``, ``t``, ``salinity``, ``sp``), turned into c by
  TEOS-10 (``gsw``) or, if asked, by Mackenzie (1981).

Lines starting with ``#`` are comments. Every problem is one line naming the file.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputFileError
from .profile import SoundSpeedProfile
from .speed import DEFAULT_LATITUDE_DEG, depth_from_pressure, pressure_from_depth, sound_speed_mackenzie, sound_speed_teos10

__all__ = ["read_profile", "profile_from_ctd", "FORMULAS"]

#: how a CTD cast's c is computed
FORMULAS = ("teos10", "mackenzie")

_ALIASES = {
    "depth": ("depth_m", "depth"),
    "pressure": ("pressure_dbar", "pressure", "p", "pres"),
    "c": ("c_mps", "sound_speed_mps", "sound_speed", "c", "svel"),
    "temperature": ("temperature_c", "temperature", "t", "temp"),
    "salinity": ("salinity_psu", "salinity", "sp", "sal", "practical_salinity"),
}


def _columns(header: list[str], path: Path) -> dict[str, int]:
    names = [h.strip().lower() for h in header]
    found = {}
    for key, aliases in _ALIASES.items():
        for a in aliases:
            if a in names:
                found[key] = names.index(a)
                break
    if "c" in found and ("depth" in found or "pressure" in found):
        return found
    if "temperature" in found and "salinity" in found and ("depth" in found or "pressure" in found):
        return found
    raise InputFileError(f"{path}: header {','.join(header)!r} has neither depth_m,c_mps nor "
                         "depth_m|pressure_dbar,temperature_c,salinity_psu")


def _read_rows(path: Path) -> tuple[list[str], np.ndarray]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputFileError(f"{path}: no such sound-speed profile file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{path}: cannot read the profile ({exc.__class__.__name__}: {exc})") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputFileError(f"{path}: empty sound-speed profile (no header, no rows)")
    rows = list(csv.reader(lines))
    header, body = rows[0], rows[1:]
    if not body:
        raise InputFileError(f"{path}: the profile has a header but no rows")
    values = np.empty((len(body), len(header)))
    for i, row in enumerate(body):
        if len(row) != len(header):
            raise InputFileError(f"{path}: row {i + 1} has {len(row)} fields, the header {len(header)}")
        try:
            values[i] = [float(v) for v in row]
        except ValueError:
            raise InputFileError(f"{path}: row {i + 1} holds a value that is not a number ({','.join(row)!r})") from None
    return header, values


def profile_from_ctd(temperature_c, practical_salinity, *, depth_m=None, pressure_dbar=None, formula: str = "teos10",
                     latitude_deg: float = DEFAULT_LATITUDE_DEG, longitude_deg: float = 0.0,
                     source: str = "CTD cast") -> SoundSpeedProfile:
    """A profile from a CTD's temperature and salinity at depths or pressures.

    Parameters
    ----------
    temperature_c, practical_salinity : array_like
        In-situ temperature [°C] and practical salinity [PSS-78], shape ``(n,)``.
    depth_m, pressure_dbar : array_like, optional
        Where each sample was taken: depth [m, positive down] or sea pressure [dbar]; exactly one.
    formula : {"teos10", "mackenzie"}
        TEOS-10 through ``gsw`` (the standard) or Mackenzie (1981) (no extra package).
    latitude_deg, longitude_deg : float
        The cast's position [deg], for depth ↔ pressure and the salinity anomaly.
    source : str
        Named in the profile and in its errors.

    Returns
    -------
    SoundSpeedProfile

    Raises
    ------
    ConfigError
        Both or neither of depth and pressure, an unknown formula, or a profile that fails validation.
    """
    if (depth_m is None) == (pressure_dbar is None):
        raise ConfigError(source, "give depth_m or pressure_dbar, exactly one")
    if formula not in FORMULAS:
        raise ConfigError(source, f"formula must be one of {', '.join(FORMULAS)}, got {formula!r}")
    t = np.asarray(temperature_c, dtype=float)
    sp = np.asarray(practical_salinity, dtype=float)
    if depth_m is not None:
        z = np.asarray(depth_m, dtype=float)
        p = pressure_from_depth(z, latitude_deg=latitude_deg) if formula == "teos10" else None
    else:
        p = np.asarray(pressure_dbar, dtype=float)
        z = depth_from_pressure(p, latitude_deg=latitude_deg)
    if formula == "teos10":
        c = sound_speed_teos10(t, sp, p, latitude_deg=latitude_deg, longitude_deg=longitude_deg)
    else:
        c = sound_speed_mackenzie(t, sp, z)
    return SoundSpeedProfile(z, c, source=f"{source} ({formula})")


def read_profile(path: str | Path, *, formula: str = "teos10", latitude_deg: float = DEFAULT_LATITUDE_DEG,
                 longitude_deg: float = 0.0) -> SoundSpeedProfile:
    """Read a sound-speed or CTD cast from a CSV file (module docstring for the columns).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    formula, latitude_deg, longitude_deg
        For a CTD cast (temperature and salinity): see :func:`profile_from_ctd`.

    Returns
    -------
    SoundSpeedProfile
        With ``source`` = the file name.

    Raises
    ------
    InputFileError
        A missing or unreadable file, an unknown header, a row that is not numbers.
    ConfigError
        Values that fail the profile's checks (non-increasing depth, implausible c), the file named first.
    """
    path = Path(path)
    header, values = _read_rows(path)
    col = _columns(header, path)
    try:
        if "c" in col:
            if "depth" in col:
                z = values[:, col["depth"]]
            else:
                z = depth_from_pressure(values[:, col["pressure"]], latitude_deg=latitude_deg)
            return SoundSpeedProfile(z, values[:, col["c"]], source=str(path))
        where = {"depth_m": values[:, col["depth"]]} if "depth" in col else {"pressure_dbar": values[:, col["pressure"]]}
        return profile_from_ctd(values[:, col["temperature"]], values[:, col["salinity"]], formula=formula,
                                latitude_deg=latitude_deg, longitude_deg=longitude_deg, source=str(path), **where)
    except ConfigError as exc:  # its parameter is the profile's source, which starts with the file's name
        raise InputFileError(str(exc)) from None
