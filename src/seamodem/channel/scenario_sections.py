"""The tables of a scenario file, one frozen dataclass each, validated on construction.

Every error names the key as ``section.key``. :mod:`.scenario` assembles the
tables into a :class:`~.scenario.Scenario` and reads the TOML files;
``docs/channel.md`` documents the schema.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from ..errors import ConfigError
from .profiles import DopplerProfile, SumProfile, profile_from_table
from .propagation import sound_speed_mackenzie

__all__ = [
    "NOISE_KINDS",
    "SECTIONS",
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
]

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
        """The section from its TOML table.

        Parameters
        ----------
        table : dict
            The table's keys and values.

        Returns
        -------
        The section (an instance of the class it is called on).

        Raises
        ------
        ConfigError
            Not a table, an unknown key, or an invalid value, named as ``section.key``.
        """
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
        """The section's fields as a TOML/JSON-ready table (tuples as lists).

        Returns
        -------
        dict
            Field name → value.
        """
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

    Parameters
    ----------
    sound_speed_mps : float, optional
        c [m/s]; when omitted, Mackenzie (1981) at the given temperature,
        salinity and ``sound_speed_depth_m``.
    temperature_c, salinity_ppt, sound_speed_depth_m : float
        Mackenzie's inputs [°C, ppt, m].
    water_depth_m : float, optional
        Flat bottom depth [m] (geometry mode; required there).
    spreading_exponent : float
        k, amplitude ∝ range^(−k/2) (2 spherical, 1 cylindrical).
    absorption : bool
        Thorp absorption at ``reference_frequency_hz`` on every path.
    reference_frequency_hz : float, optional
        Frequency of the losses [Hz] (default: the frame's data carrier).
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
    """[beacon]: the fixed transmitter.

    Parameters
    ----------
    position_m : (float, float, float)
        [x, y, z] [m], z ≤ 0.
    """

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

    Parameters
    ----------
    start_m, velocity_mps : (float, float, float), optional
        Straight line: start [m] and velocity [m/s].
    waypoints_m : sequence of (float, float, float), optional
        Waypoints [m], at least two.
    speed_mps : float, optional
        Speed along the waypoints [m/s].
    start_s : float
        When the vehicle leaves the first waypoint [s].
    track_file : str, optional
        Sampled track CSV.
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


@dataclass(frozen=True, kw_only=True)
class Doppler(_Section):
    """[doppler] (profile mode): v_r(t) = Σ components, direct path at ``initial_range_m``.

    Parameters
    ----------
    initial_range_m : float
        Range of the direct path at t = 0 [m].
    components : list of dict or of DopplerProfile
        Tables with ``kind`` = constant (v_mps), ramp (v0_mps, v1_mps, t0_s,
        t1_s), sinusoid (amplitude_mps, frequency_hz, phase_rad) or sampled
        (t_s, v_mps lists), and an optional ``label`` (e.g. "vehicle",
        "drift", "surface").
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
            profiles = [profile_from_table(i, c) for i, c in enumerate(comps)]
        object.__setattr__(self, "components", tuple(profiles))
        object.__setattr__(self, "_profile", SumProfile(profiles))

    @property
    def profile(self) -> DopplerProfile:
        """v_r(t), the sum of the components."""
        return self._profile

    def to_dict(self):
        """The table as used, each component as its profile's ``to_dict``.

        Returns
        -------
        dict
            ``initial_range_m`` and ``components``.
        """
        return {"initial_range_m": self.initial_range_m, "components": [p.to_dict() for p in self.components]}


@dataclass(frozen=True, kw_only=True)
class Multipath(_Section):
    """[multipath].

    Parameters
    ----------
    max_bounces : int
        Geometry mode: image order (1 → direct, surface, bottom).
    max_paths : int
        Geometry mode: keep the earliest N at the start (0 keeps all).
    surface_reflection, bottom_reflection : float
        Geometry mode: real reflection coefficients in [−1, 1].
    surface_rms_height_m : float
        Geometry mode: rough-surface loss (Kirchhoff) [m].
    paths : list of dict
        Profile mode: {delay_s, gain} echoes after the direct path (excess
        delay ≥ 0 [s], real amplitude relative to the direct path).
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

    Parameters
    ----------
    doppler_spread_hz : float
        RMS Doppler spread σ_D [Hz]; 0 disables fluctuations.
    k_factor_db : float
        Rician K (steady / random power) of every path but the direct one [dB].
    direct_k_db : float
        The same for the direct path; ``inf`` (default) keeps it steady.
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
    """[noise]: the noise added at an in-band SNR (SPEC §1; see docs/channel.md).

    Parameters
    ----------
    kind : str
        One of :data:`NOISE_KINDS`.
    snr_db : float
        In-band SNR [dB]; required unless ``kind`` is "none".
    shipping, wind_mps : float
        ambient: shipping activity (0–1) and wind speed [m/s].
    impulse_probability, impulse_power_ratio : float
        gaussian_mixture: impulse probability and power ratio (≥ 1).
    alpha : float
        alpha_stable: characteristic exponent in (0, 2].
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

    Parameters
    ----------
    offset_s : float
        Receiver clock offset [s].
    sample_rate_offset_ppm : float
        Receiver clock rate error [ppm], within ±10 000.
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
        """True time → receiver clock time [s].

        Parameters
        ----------
        t_s : array_like
            True times [s].

        Returns
        -------
        numpy.ndarray
            Receiver clock times [s].
        """
        return self.rate * np.asarray(t_s, dtype=float) + self.offset_s

    def to_true(self, t_rx_s):
        """Receiver clock time → true time [s].

        Parameters
        ----------
        t_rx_s : array_like
            Receiver clock times [s].

        Returns
        -------
        numpy.ndarray
            True times [s].
        """
        return (np.asarray(t_rx_s, dtype=float) - self.offset_s) / self.rate


@dataclass(frozen=True, kw_only=True)
class Replay(_Section):
    """[replay] (replay mode): a measured channel.

    Parameters
    ----------
    file : str
        The channel (.mat, uwa-channels format; relative to the scenario file).
    receiver : int
        Array element index.
    start_s : float
        Where in the measured channel to start [s].
    """

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

    Parameters
    ----------
    turnaround_s : float
        The beacon's delay from hearing a poll to its reply [s] (required).
    poll_period_s : float, optional
        Poll period [s] (or ``poll_times_s``).
    first_poll_s : float
        First poll [s], with ``poll_period_s``.
    poll_times_s : sequence of float, optional
        Increasing poll times [s] (or ``poll_period_s``).
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
        """Emission times of the ``count`` polls on the vehicle's clock [s].

        Parameters
        ----------
        count : int
            Polls (the input's frames).

        Returns
        -------
        numpy.ndarray, shape (count,)
            Poll times [s].
        """
        if self.poll_times_s is not None:
            if len(self.poll_times_s) != count:
                raise ConfigError(self._name("poll_times_s"),
                                  f"lists {len(self.poll_times_s)} polls but the input recording has {count} frames (one reply each)")
            return np.array(self.poll_times_s, dtype=float)
        return self.first_poll_s + self.poll_period_s * np.arange(count)


#: table name → its section class, in the order of a scenario's ``to_dict``
SECTIONS = {cls.SECTION: cls for cls in (Environment, Beacon, Vehicle, Doppler, Multipath, Fluctuation, Noise, Clock, Replay, TwoWay)}
#: the tables' base class, for a table defined in its own module (:mod:`.water_section`)
Section = _Section
