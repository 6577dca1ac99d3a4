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
(:mod:`seamodem.channel.two_way`).
"""

from __future__ import annotations

import itertools
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputFileError
from .profiles import ConstantProfile, DopplerProfile, RampProfile, SampledProfile, SinusoidalProfile, SumProfile
from .propagation import sound_speed_mackenzie

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
    "Scenario",
    "load_scenario",
    "parse_scenario",
    "MODES",
    "NOISE_KINDS",
]

MODES = ("geometry", "profile", "replay")
NOISE_KINDS = ("none", "white", "ambient", "gaussian_mixture", "alpha_stable")


def _number(name: str, value, *, allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(name, f"must be a number, got {value!r}")
    value = float(value)
    if math.isnan(value) or (math.isinf(value) and not allow_inf):
        raise ConfigError(name, f"must be finite, got {value!r}")
    return value


def _vector3(name: str, value) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ConfigError(name, f"must be [x, y, z] in metres, got {value!r}")
    return tuple(_number(name, v) for v in value)


def _positive(name: str, value: float) -> None:
    if not value > 0:
        raise ConfigError(name, f"must be > 0, got {value!r}")


class _Section:
    """Shared construction from a TOML table: unknown keys and types are errors naming the key."""

    SECTION = ""

    @classmethod
    def from_table(cls, table: Any):
        if not isinstance(table, dict):
            raise ConfigError(cls.SECTION, f"must be a table, got {table!r}")
        known = [f.name for f in fields(cls) if f.init and not f.name.startswith("_")]
        for key in table:
            if key not in known:
                raise ConfigError(f"{cls.SECTION}.{key}", f"unknown scenario key (known in [{cls.SECTION}]: {', '.join(known)})")
        return cls(**table)

    def _name(self, key: str) -> str:
        return f"{self.SECTION}.{key}"

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for f in fields(self):
            if f.name.startswith("_") or not f.init:
                continue
            value = getattr(self, f.name)
            if isinstance(value, tuple):
                value = [list(v) if isinstance(v, tuple) else v for v in value]
            out[f.name] = value
        return out


@dataclass(frozen=True, kw_only=True)
class Environment(_Section):
    """[environment]: the water.

    sound_speed_mps : c [m/s]; when omitted, Mackenzie (1981) at the given
        temperature, salinity and ``sound_speed_depth_m``.
    water_depth_m : flat bottom depth [m] (geometry mode; required there).
    spreading_exponent : k, amplitude ∝ range^(−k/2) (2 spherical, 1 cylindrical).
    absorption : Thorp absorption at ``reference_frequency_hz`` (default: the
        frame's data carrier) on every path.
    """

    SECTION = "environment"
    sound_speed_mps: float | None = None
    temperature_c: float = 15.0
    salinity_ppt: float = 35.0
    sound_speed_depth_m: float = 10.0
    water_depth_m: float | None = None
    spreading_exponent: float = 1.5
    absorption: bool = True
    reference_frequency_hz: float | None = None

    def __post_init__(self):
        for key in ("temperature_c", "salinity_ppt", "sound_speed_depth_m", "spreading_exponent"):
            object.__setattr__(self, key, _number(self._name(key), getattr(self, key)))
        for key in ("sound_speed_mps", "water_depth_m", "reference_frequency_hz"):
            value = getattr(self, key)
            if value is not None:
                value = _number(self._name(key), value)
                _positive(self._name(key), value)
                object.__setattr__(self, key, value)
        if not isinstance(self.absorption, bool):
            raise ConfigError(self._name("absorption"), f"must be true or false, got {self.absorption!r}")
        if self.spreading_exponent < 0:
            raise ConfigError(self._name("spreading_exponent"), f"must be >= 0, got {self.spreading_exponent!r}")

    @property
    def c(self) -> float:
        """The sound speed used [m/s]."""
        if self.sound_speed_mps is not None:
            return self.sound_speed_mps
        return float(sound_speed_mackenzie(self.temperature_c, self.salinity_ppt, self.sound_speed_depth_m))


@dataclass(frozen=True, kw_only=True)
class Beacon(_Section):
    """[beacon]: the fixed transmitter, ``position_m`` = [x, y, z] (z ≤ 0)."""

    SECTION = "beacon"
    position_m: tuple[float, float, float] = (0.0, 0.0, -5.0)

    def __post_init__(self):
        object.__setattr__(self, "position_m", _vector3(self._name("position_m"), self.position_m))


@dataclass(frozen=True, kw_only=True)
class Vehicle(_Section):
    """[vehicle]: the receiver's trajectory, exactly one of three kinds.

    - straight line: ``start_m`` and ``velocity_mps`` ([vx, vy, vz]);
    - waypoints: ``waypoints_m`` (list of [x, y, z]) at ``speed_mps`` from ``start_s``;
    - sampled track: ``track_file`` (CSV t_s,x_m,y_m,z_m; relative to the scenario file).
    """

    SECTION = "vehicle"
    start_m: tuple[float, float, float] | None = None
    velocity_mps: tuple[float, float, float] | None = None
    waypoints_m: tuple[tuple[float, float, float], ...] | None = None
    speed_mps: float | None = None
    start_s: float = 0.0
    track_file: str | None = None

    def __post_init__(self):
        kinds = [k for k, on in (("velocity_mps", self.velocity_mps is not None),
                                 ("waypoints_m", self.waypoints_m is not None),
                                 ("track_file", self.track_file is not None)) if on]
        if len(kinds) != 1:
            raise ConfigError("vehicle", f"give exactly one of velocity_mps (with start_m), waypoints_m (with speed_mps) or track_file; got {kinds or 'none'}")
        object.__setattr__(self, "start_s", _number(self._name("start_s"), self.start_s))
        if self.velocity_mps is not None:
            if self.start_m is None:
                raise ConfigError(self._name("start_m"), "is required with velocity_mps")
            object.__setattr__(self, "start_m", _vector3(self._name("start_m"), self.start_m))
            object.__setattr__(self, "velocity_mps", _vector3(self._name("velocity_mps"), self.velocity_mps))
        elif self.start_m is not None:
            raise ConfigError(self._name("start_m"), "only goes with velocity_mps")
        if self.waypoints_m is not None:
            pts = self.waypoints_m
            if not isinstance(pts, (list, tuple)) or len(pts) < 2:
                raise ConfigError(self._name("waypoints_m"), f"must list at least two [x, y, z] points, got {pts!r}")
            object.__setattr__(self, "waypoints_m", tuple(_vector3(self._name("waypoints_m"), p) for p in pts))
            if self.speed_mps is None:
                raise ConfigError(self._name("speed_mps"), "is required with waypoints_m")
            speed = _number(self._name("speed_mps"), self.speed_mps)
            _positive(self._name("speed_mps"), speed)
            object.__setattr__(self, "speed_mps", speed)
        elif self.speed_mps is not None:
            raise ConfigError(self._name("speed_mps"), "only goes with waypoints_m")
        if self.track_file is not None and not isinstance(self.track_file, str):
            raise ConfigError(self._name("track_file"), f"must be a file path, got {self.track_file!r}")


_PROFILE_KINDS = {
    "constant": (ConstantProfile, ("v_mps",)),
    "ramp": (RampProfile, ("v0_mps", "v1_mps", "t0_s", "t1_s")),
    "sinusoid": (SinusoidalProfile, ("amplitude_mps", "frequency_hz", "phase_rad")),
    "sampled": (SampledProfile, ("t_s", "v_mps")),
}


def _profile_from_table(i: int, table: Any) -> DopplerProfile:
    where = f"doppler.components[{i}]"
    if not isinstance(table, dict):
        raise ConfigError(where, f"must be a table, got {table!r}")
    kind = table.get("kind")
    if kind not in _PROFILE_KINDS:
        raise ConfigError(f"{where}.kind", f"must be one of {', '.join(_PROFILE_KINDS)}, got {kind!r}")
    cls, keys = _PROFILE_KINDS[kind]
    for key in table:
        if key not in ("kind", "label", *keys):
            raise ConfigError(f"{where}.{key}", f"unknown scenario key for kind {kind!r} (known: kind, label, {', '.join(keys)})")
    args = {k: v for k, v in table.items() if k != "kind"}
    try:
        return cls(**args)
    except ConfigError as exc:
        raise ConfigError(f"{where}.{exc.parameter}", str(exc).split(": ", 1)[1]) from None
    except TypeError as exc:
        raise ConfigError(where, f"missing a key for kind {kind!r} (needs {', '.join(keys)}): {exc}") from None


@dataclass(frozen=True, kw_only=True)
class Doppler(_Section):
    """[doppler] (profile mode): v_r(t) = Σ components, direct path at ``initial_range_m``.

    components : list of tables with ``kind`` = constant (v_mps), ramp (v0_mps,
        v1_mps, t0_s, t1_s), sinusoid (amplitude_mps, frequency_hz, phase_rad)
        or sampled (t_s, v_mps lists), and an optional ``label`` (e.g.
        "vehicle", "drift", "surface").
    """

    SECTION = "doppler"
    initial_range_m: float = 100.0
    components: tuple = ()
    _profile: DopplerProfile = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        r = _number(self._name("initial_range_m"), self.initial_range_m)
        _positive(self._name("initial_range_m"), r)
        object.__setattr__(self, "initial_range_m", r)
        comps = self.components
        if isinstance(comps, (list, tuple)) and comps and all(isinstance(c, DopplerProfile) for c in comps):
            profiles = list(comps)
        else:
            if not isinstance(comps, (list, tuple)) or not comps:
                raise ConfigError(self._name("components"), "must list at least one profile table")
            profiles = [_profile_from_table(i, c) for i, c in enumerate(comps)]
        object.__setattr__(self, "components", tuple(profiles))
        object.__setattr__(self, "_profile", SumProfile(profiles))

    @property
    def profile(self) -> DopplerProfile:
        return self._profile

    def to_dict(self):
        return {"initial_range_m": self.initial_range_m, "components": [p.to_dict() for p in self.components]}


@dataclass(frozen=True, kw_only=True)
class Multipath(_Section):
    """[multipath].

    Geometry mode: ``max_bounces`` (image order; 1 → direct, surface, bottom),
    ``max_paths`` (keep the earliest N at the start; 0 keeps all),
    ``surface_reflection``, ``bottom_reflection`` (real coefficients in
    [−1, 1]), ``surface_rms_height_m`` (rough-surface loss, Kirchhoff).
    Profile mode: ``paths``, a list of {delay_s, gain}: echoes after the
    direct path (excess delay ≥ 0 [s], real amplitude relative to the direct path).
    """

    SECTION = "multipath"
    max_bounces: int = 1
    max_paths: int = 0
    surface_reflection: float = -1.0
    bottom_reflection: float = 0.5
    surface_rms_height_m: float = 0.0
    paths: tuple = ()

    def __post_init__(self):
        for key in ("max_bounces", "max_paths"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ConfigError(self._name(key), f"must be an integer >= 0, got {value!r}")
        for key in ("surface_reflection", "bottom_reflection"):
            value = _number(self._name(key), getattr(self, key))
            if not -1.0 <= value <= 1.0:
                raise ConfigError(self._name(key), f"must be in [-1, 1], got {value!r}")
            object.__setattr__(self, key, value)
        rms = _number(self._name("surface_rms_height_m"), self.surface_rms_height_m)
        if rms < 0:
            raise ConfigError(self._name("surface_rms_height_m"), f"must be >= 0, got {rms!r}")
        object.__setattr__(self, "surface_rms_height_m", rms)
        if not isinstance(self.paths, (list, tuple)):
            raise ConfigError(self._name("paths"), f"must be a list of {{delay_s, gain}} tables, got {self.paths!r}")
        echoes = []
        for i, p in enumerate(self.paths):
            where = f"multipath.paths[{i}]"
            if not isinstance(p, dict) or set(p) - {"delay_s", "gain"} or "delay_s" not in p:
                raise ConfigError(where, f"must be a table {{delay_s, gain}}, got {p!r}")
            delay = _number(f"{where}.delay_s", p["delay_s"])
            if delay < 0:
                raise ConfigError(f"{where}.delay_s", f"must be >= 0 (echoes come after the direct path), got {delay!r}")
            echoes.append({"delay_s": delay, "gain": _number(f"{where}.gain", p.get("gain", 1.0))})
        object.__setattr__(self, "paths", tuple(echoes))


@dataclass(frozen=True, kw_only=True)
class Fluctuation(_Section):
    """[fluctuation]: Rician path gains with a Gaussian Doppler spectrum.

    doppler_spread_hz : RMS Doppler spread σ_D [Hz]; 0 disables fluctuations.
    k_factor_db : Rician K (steady / random power) of every path but the direct one [dB].
    direct_k_db : the same for the direct path; ``inf`` (default) keeps it steady.
    """

    SECTION = "fluctuation"
    doppler_spread_hz: float = 0.0
    k_factor_db: float = 0.0
    direct_k_db: float = math.inf

    def __post_init__(self):
        spread = _number(self._name("doppler_spread_hz"), self.doppler_spread_hz)
        if spread < 0:
            raise ConfigError(self._name("doppler_spread_hz"), f"must be >= 0, got {spread!r}")
        object.__setattr__(self, "doppler_spread_hz", spread)
        for key in ("k_factor_db", "direct_k_db"):
            value = _number(self._name(key), getattr(self, key), allow_inf=True)
            if value == -math.inf:
                raise ConfigError(self._name(key), "must be > -inf")
            object.__setattr__(self, key, value)


@dataclass(frozen=True, kw_only=True)
class Noise(_Section):
    """[noise]: ``kind`` and the in-band SNR ``snr_db`` (SPEC §1; see docs/channel.md).

    ambient: ``shipping`` (0–1), ``wind_mps``; gaussian_mixture:
    ``impulse_probability``, ``impulse_power_ratio``; alpha_stable: ``alpha`` in (0, 2].
    """

    SECTION = "noise"
    kind: str = "none"
    snr_db: float | None = None
    shipping: float = 0.5
    wind_mps: float = 5.0
    impulse_probability: float = 0.01
    impulse_power_ratio: float = 100.0
    alpha: float = 1.8

    def __post_init__(self):
        if self.kind not in NOISE_KINDS:
            raise ConfigError(self._name("kind"), f"must be one of {', '.join(NOISE_KINDS)}, got {self.kind!r}")
        if self.kind != "none":
            if self.snr_db is None:
                raise ConfigError(self._name("snr_db"), f"is required with kind = {self.kind!r}")
            object.__setattr__(self, "snr_db", _number(self._name("snr_db"), self.snr_db))
        for key in ("shipping", "wind_mps", "impulse_probability", "impulse_power_ratio", "alpha"):
            object.__setattr__(self, key, _number(self._name(key), getattr(self, key)))
        if not 0 <= self.shipping <= 1:
            raise ConfigError(self._name("shipping"), f"must be in [0, 1], got {self.shipping!r}")
        if self.wind_mps < 0:
            raise ConfigError(self._name("wind_mps"), f"must be >= 0, got {self.wind_mps!r}")
        if not 0 <= self.impulse_probability <= 1:
            raise ConfigError(self._name("impulse_probability"), f"must be in [0, 1], got {self.impulse_probability!r}")
        if self.impulse_power_ratio < 1:
            raise ConfigError(self._name("impulse_power_ratio"), f"must be >= 1, got {self.impulse_power_ratio!r}")
        if not 0 < self.alpha <= 2:
            raise ConfigError(self._name("alpha"), f"must be in (0, 2], got {self.alpha!r}")


@dataclass(frozen=True, kw_only=True)
class Clock(_Section):
    """[clock]: the receiver's clock against the beacon's (true) clock.

    A receiver clock reads t_rx = (1 + ppm·1e-6)·t + offset_s at true time t,
    and its sample n is taken when t_rx = n/fs. ``offset_s`` > 0: the receiver
    clock is ahead (arrivals look later); ``sample_rate_offset_ppm`` > 0: its
    clock runs fast (a tone at f is recorded at f/(1 + ppm·1e-6)).
    """

    SECTION = "clock"
    offset_s: float = 0.0
    sample_rate_offset_ppm: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "offset_s", _number(self._name("offset_s"), self.offset_s))
        ppm = _number(self._name("sample_rate_offset_ppm"), self.sample_rate_offset_ppm)
        if abs(ppm) >= 1e4:
            raise ConfigError(self._name("sample_rate_offset_ppm"), f"must be within ±10 000 ppm, got {ppm!r}")
        object.__setattr__(self, "sample_rate_offset_ppm", ppm)

    @property
    def rate(self) -> float:
        """Receiver seconds per true second, 1 + ppm·1e-6."""
        return 1.0 + 1e-6 * self.sample_rate_offset_ppm

    def to_receiver(self, t_s):
        """True time → receiver clock time [s]."""
        return self.rate * np.asarray(t_s, dtype=float) + self.offset_s

    def to_true(self, t_rx_s):
        """Receiver clock time → true time [s]."""
        return (np.asarray(t_rx_s, dtype=float) - self.offset_s) / self.rate


@dataclass(frozen=True, kw_only=True)
class Replay(_Section):
    """[replay] (replay mode): ``file`` (.mat, uwa-channels format; relative to the
    scenario file), ``receiver`` (array element index), ``start_s`` (where in
    the measured channel to start)."""

    SECTION = "replay"
    file: str = ""
    receiver: int = 0
    start_s: float = 0.0

    def __post_init__(self):
        if not isinstance(self.file, str) or not self.file:
            raise ConfigError(self._name("file"), "must name a channel file (.mat)")
        if isinstance(self.receiver, bool) or not isinstance(self.receiver, int) or self.receiver < 0:
            raise ConfigError(self._name("receiver"), f"must be an integer >= 0, got {self.receiver!r}")
        value = _number(self._name("start_s"), self.start_s)
        if value < 0:
            raise ConfigError(self._name("start_s"), f"must be >= 0, got {value!r}")
        object.__setattr__(self, "start_s", value)


@dataclass(frozen=True, kw_only=True)
class TwoWay(_Section):
    """[two_way]: two-way travel-time ranging exchanges (paper 004 §III.B).

    The vehicle emits poll k at ``poll_times_s[k]`` — or at ``first_poll_s`` +
    k·``poll_period_s`` — on its own clock (the [clock] of the scenario); the
    beacon hears it and, ``turnaround_s`` later on its clock, emits frame k of
    the input recording as its reply. One poll per input frame.
    """

    SECTION = "two_way"
    turnaround_s: float | None = None
    poll_period_s: float | None = None
    first_poll_s: float = 0.0
    poll_times_s: tuple | None = None

    def __post_init__(self):
        if self.turnaround_s is None:
            raise ConfigError(self._name("turnaround_s"), "is required: the beacon's delay from hearing a poll to its reply [s]")
        turnaround = _number(self._name("turnaround_s"), self.turnaround_s)
        if turnaround < 0:
            raise ConfigError(self._name("turnaround_s"), f"must be >= 0, got {turnaround!r}")
        object.__setattr__(self, "turnaround_s", turnaround)
        object.__setattr__(self, "first_poll_s", _number(self._name("first_poll_s"), self.first_poll_s))
        if (self.poll_period_s is None) == (self.poll_times_s is None):
            raise ConfigError(self._name("poll_period_s"), "give exactly one of poll_period_s and poll_times_s")
        if self.poll_period_s is not None:
            period = _number(self._name("poll_period_s"), self.poll_period_s)
            _positive(self._name("poll_period_s"), period)
            object.__setattr__(self, "poll_period_s", period)
        else:
            if not isinstance(self.poll_times_s, (list, tuple)) or not self.poll_times_s:
                raise ConfigError(self._name("poll_times_s"), f"must be a non-empty list of times [s], got {self.poll_times_s!r}")
            times = tuple(_number(self._name("poll_times_s"), t) for t in self.poll_times_s)
            if any(b <= a for a, b in itertools.pairwise(times)):
                raise ConfigError(self._name("poll_times_s"), "must be increasing")
            object.__setattr__(self, "poll_times_s", times)

    def poll_times(self, count: int) -> np.ndarray:
        """Emission times of the ``count`` polls on the vehicle's clock [s]."""
        if self.poll_times_s is not None:
            if len(self.poll_times_s) != count:
                raise ConfigError(self._name("poll_times_s"),
                                  f"lists {len(self.poll_times_s)} polls but the input recording has {count} frames (one reply each)")
            return np.array(self.poll_times_s, dtype=float)
        return self.first_poll_s + self.poll_period_s * np.arange(count)


_SECTIONS = {cls.SECTION: cls for cls in (Environment, Beacon, Vehicle, Doppler, Multipath, Fluctuation, Noise, Clock, Replay, TwoWay)}


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """A whole scenario: the mode, a seed, and one record per table.

    ``base_dir`` resolves relative file names (track, replay file); it is the
    scenario file's folder when loaded from a file.
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
        unused = {"geometry": ("doppler", "replay"), "profile": ("beacon", "vehicle", "replay"),
                  "replay": ("beacon", "vehicle", "doppler")}[self.mode]
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
        for name in _SECTIONS:
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

    Raises
    ------
    ConfigError
        Naming the first unknown or invalid key, as ``section.key``.
    """
    if not isinstance(data, dict):
        raise ConfigError("scenario", "must be a table")
    top = {"mode", "seed", "description", *_SECTIONS}
    for key in data:
        if key not in top:
            raise ConfigError(key, f"unknown scenario key (known top-level keys and tables: {', '.join(sorted(top))})")
    if "mode" not in data:
        raise ConfigError("mode", f"is required: one of {', '.join(MODES)}")
    kwargs: dict[str, Any] = {k: data[k] for k in ("mode", "seed", "description") if k in data}
    if not isinstance(kwargs.get("description", ""), str):
        raise ConfigError("description", "must be a string")
    for name, cls in _SECTIONS.items():
        if name in data:
            kwargs[name] = cls.from_table(data[name])
    return Scenario(**kwargs, base_dir=Path(base_dir))


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Raises
    ------
    InputFileError
        Missing file or invalid TOML.
    ConfigError
        An unknown key or an invalid value, named as ``section.key``.
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

