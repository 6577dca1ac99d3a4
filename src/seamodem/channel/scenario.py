"""Scenario files (TOML): what the channel simulator is asked to simulate.

One frozen dataclass per TOML table, validated on construction; every error
names the key as ``section.key``. ``docs/channel.md`` documents the schema and
``examples/scenarios/`` holds one file per mode. Axes: x east, y north, z up;
the surface is z = 0 and the bottom z = −water_depth_m.

Three modes:

- ``geometry``: a fixed [beacon] and a moving [vehicle] in a flat waveguide;
  the direct path plus surface/bottom images ([multipath]); spreading, Thorp
  absorption, reflection and rough-surface losses.
- ``profile``: a prescribed closing speed v_r(t) ([doppler], paper 003
  §III.C) applied to a direct path at ``initial_range_m``, plus echoes listed
  in [multipath].paths (delay and gain relative to the direct path).
- ``replay``: a measured channel file ([replay], the uwa-channels format).

[fluctuation], [noise] and [clock] apply to the first two modes; [noise] to all.
[two_way] (geometry and profile modes) turns the recording into two-way
ranging exchanges: the vehicle polls, the beacon's frames are its replies
(:mod:`seamodem.channel.two_way`). [water] (geometry mode) gives a sound-speed
profile: the paths are then rays traced through it (:mod:`seamodem.channel.raytraced`).

The tables' dataclasses are in :mod:`.scenario_sections` (every name importable from here too);
this module assembles them into a :class:`Scenario` and reads the files.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputFileError
from .scenario_sections import (
    NOISE_KINDS,
    SECTIONS,
    Beacon,
    Clock,
    Doppler,
    Environment,
    Fluctuation,
    Multipath,
    Noise,
    Replay,
    TwoWay,
    Vehicle,
)
from .water_section import Water

#: every table a scenario may hold: those of :mod:`.scenario_sections`, and [water]
TABLES = {**SECTIONS, Water.SECTION: Water}

__all__ = [
    "read_scenario_tables",
    "Environment",
    "Beacon",
    "Vehicle",
    "Doppler",
    "Multipath",
    "Fluctuation",
    "Noise",
    "Clock",
    "Replay",
    "TwoWay",
    "Water",
    "Scenario",
    "load_scenario",
    "parse_scenario",
    "MODES",
    "NOISE_KINDS",
]

MODES = ("geometry", "profile", "replay")

@dataclass(frozen=True, kw_only=True)
class Scenario:
    """A whole scenario: the mode, a seed, and one record per table.

    Attributes
    ----------
    mode : {"geometry", "profile", "replay"}
        How the paths are made: image sources over a moving vehicle, Doppler profiles, or a measured
        channel replayed.
    seed : int
        Seeds the fading and the noise (two independent streams).
    description : str
        Free text.
    environment, beacon, vehicle, doppler, multipath, fluctuation, noise, clock, replay, two_way, water
        One record per TOML table (:mod:`~seamodem.channel.scenario_sections`); None where the table is
        absent and the mode does not need it.
    base_dir : Path
        Resolves relative file names (track, replay file): the scenario file's folder when loaded from a
        file.

    Raises
    ------
    ConfigError
        An unknown mode, a negative or non-integer seed, or a table the mode needs missing.
    """

    mode: str
    seed: int = 0
    description: str = ""
    environment: Environment = field(default_factory=Environment)
    beacon: Beacon | None = None
    vehicle: Vehicle | None = None
    doppler: Doppler | None = None
    multipath: Multipath = field(default_factory=Multipath)
    fluctuation: Fluctuation = field(default_factory=Fluctuation)
    noise: Noise = field(default_factory=Noise)
    clock: Clock = field(default_factory=Clock)
    replay: Replay | None = None
    two_way: TwoWay | None = None
    water: Water | None = None
    base_dir: Path = field(default=Path("."), compare=False)

    def __post_init__(self):
        if self.mode not in MODES:
            raise ConfigError("mode", f"must be one of {', '.join(MODES)}, got {self.mode!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError("seed", f"must be an integer >= 0, got {self.seed!r}")
        needs = {"geometry": ("beacon", "vehicle"), "profile": ("doppler",), "replay": ("replay",)}[self.mode]
        for name in needs:
            if getattr(self, name) is None:
                raise ConfigError(name, f"the [{name}] table is required in {self.mode} mode")
        unused = {"geometry": ("doppler", "replay"), "profile": ("beacon", "vehicle", "replay", "water"),
                  "replay": ("beacon", "vehicle", "doppler", "water")}[self.mode]
        for name in unused:
            if getattr(self, name) is not None:
                raise ConfigError(name, f"the [{name}] table does not apply in {self.mode} mode")
        if self.mode == "geometry":
            self._check_geometry()
        if self.mode == "replay" and (self.clock != Clock() or self.fluctuation.doppler_spread_hz > 0):
            raise ConfigError("clock" if self.clock != Clock() else "fluctuation",
                              "does not apply in replay mode (the measured channel carries its own)")
        if self.mode == "replay" and self.two_way is not None:
            raise ConfigError("two_way", "does not apply in replay mode (a measured channel has no known delay)")

    def _check_geometry(self) -> None:
        env = self.environment
        depth = env.water_depth_m
        if depth is None:
            raise ConfigError("environment.water_depth_m", "is required in geometry mode")
        c = env.c
        _check_in_water("beacon.position_m", self.beacon.position_m[2], depth)
        v = self.vehicle
        if v.start_m is not None:
            _check_in_water("vehicle.start_m", v.start_m[2], depth)
            speed = float(np.linalg.norm(v.velocity_mps))
            if speed >= c:
                raise ConfigError("vehicle.velocity_mps", f"speed {speed:g} m/s must be below the sound speed {c:g} m/s")
        if v.waypoints_m is not None:
            for p in v.waypoints_m:
                _check_in_water("vehicle.waypoints_m", p[2], depth)
            if v.speed_mps >= c:
                raise ConfigError("vehicle.speed_mps", f"{v.speed_mps:g} m/s must be below the sound speed {c:g} m/s")

    @property
    def sound_speed_mps(self) -> float:
        return self.environment.c

    def to_dict(self) -> dict[str, Any]:
        """The scenario as used (defaults filled in), JSON-ready."""
        out: dict[str, Any] = {"mode": self.mode, "seed": self.seed, "description": self.description}
        for name in TABLES:
            section = getattr(self, name)
            if section is not None:
                out[name] = section.to_dict()
        out["environment"]["sound_speed_used_mps"] = self.sound_speed_mps
        return _json_ready(out)


def _json_ready(value):
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


def _check_in_water(name: str, z: float, depth: float) -> None:
    if z > 0:
        raise ConfigError(name, f"z = {z:g} m is above the surface (z is up, the surface is z = 0)")
    if z < -depth:
        raise ConfigError(name, f"z = {z:g} m is below the bottom (z = -water_depth_m = {-depth:g} m)")


def parse_scenario(data: dict[str, Any], *, base_dir: str | Path = ".") -> Scenario:
    """Build a :class:`Scenario` from a mapping (a parsed TOML file).

    Parameters
    ----------
    data : dict
        The scenario's tables (top-level ``mode``, ``seed``, ``description`` and one table per section).
    base_dir : str or Path
        Folder that relative file names in the tables are resolved against.

    Returns
    -------
    Scenario
        Validated.

    Raises
    ------
    ConfigError
        Naming the first unknown or invalid key, as ``section.key``.
    """
    if not isinstance(data, dict):
        raise ConfigError("scenario", "must be a table")
    top = {"mode", "seed", "description", *TABLES}
    for key in data:
        if key not in top:
            raise ConfigError(key, f"unknown scenario key (known top-level keys and tables: {', '.join(sorted(top))})")
    if "mode" not in data:
        raise ConfigError("mode", f"is required: one of {', '.join(MODES)}")
    kwargs: dict[str, Any] = {k: data[k] for k in ("mode", "seed", "description") if k in data}
    if not isinstance(kwargs.get("description", ""), str):
        raise ConfigError("description", "must be a string")
    for name, cls in TABLES.items():
        if name in data:
            kwargs[name] = cls.from_table(data[name])
    return Scenario(**kwargs, base_dir=Path(base_dir))


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Parameters
    ----------
    path : str or Path
        The scenario file.

    Returns
    -------
    Scenario
        Validated, relative file names resolved against the file's folder.

    Raises
    ------
    InputFileError
        Missing file or invalid TOML.
    ConfigError
        An unknown key or an invalid value (or one of the wrong type), named as ``section.key`` after
        the file.
    """
    path = Path(path)
    tables = read_scenario_tables(path)
    try:
        return parse_scenario(tables, base_dir=path.parent)
    except ConfigError as exc:
        raise exc.in_file(f"scenario {path}") from None
    except (TypeError, ValueError, OverflowError) as exc:  # a value of a type no check expected
        raise ConfigError("scenario", f"a value is of the wrong type ({exc})", file=f"scenario {path}") from None


def read_scenario_tables(path: str | Path) -> dict[str, Any]:
    """A scenario file's tables as parsed TOML, not yet validated (see :func:`parse_scenario`).

    Raises
    ------
    InputFileError
        Missing file or invalid TOML.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"scenario file not found: {path}")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputFileError(f"scenario {path} is not valid TOML: {exc}") from None

