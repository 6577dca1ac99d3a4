"""What the receiver is told: its settings (one frozen object) and when frames were emitted."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from ..errors import ConfigError

__all__ = ["ReceiverSettings", "ReferenceSettings", "Emissions", "MIN_RHO", "MAX_ACCEL_MPS2", "REFERENCE_V_MAX_LIMIT_MPS"]

#: smallest normalised correlation of a reference detection: ≈ S/(S + N) in the baseband's band, so detection
#: reaches in-band SNRs near −10 dB, while an impulse of k samples in a ping of N gives ρ ≈ k/N (≈ 0.02 for a
#: 1 ms snap in a 50 ms ping); unlike the frame detector, a ping has no data of its own to reject
MIN_RHO = 0.05
#: largest radial acceleration assumed over a pre/postamble packet [m/s²]
#: (:func:`~seamodem.receive.reference.pair_up`)
MAX_ACCEL_MPS2 = 0.3
#: the reference receiver searches |v_r| below this [m/s] (its scale bank and band plan)
REFERENCE_V_MAX_LIMIT_MPS = 100.0


def _positive(name: str, value) -> None:
    if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ConfigError(name, f"must be a positive number, got {value!r}")


def _non_negative(name: str, value, what: str) -> None:
    if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ConfigError(name, f"must be {what}, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class ReceiverSettings:
    """How a recording is received: built once (CLI, batch, sweeps, demo) and passed down.

    Parameters
    ----------
    sound_speed_mps : float
        c [m/s].
    clock_offset_s : float
        Receiver clock minus beacon clock [s], removed from the one-way tof.
    turnaround_s : float, optional
        Beacon's reply delay [s]: two-way ranging (paper 004 §III.B); the
        emissions are then the vehicle's polls and the clock offset is not used.
    v_max_mps : float
        Largest |v_r| searched [m/s].
    false_alarms_per_hour : float
        Detector design rate in white noise (sets the threshold).
    decode : bool
        Also equalise and decode each complete frame's payload: compensation
        (eq 10–11), fractionally spaced DFE with PLL, turbo passes while the
        CRC fails. Fills the record's payload columns.
    turbo_passes : int
        Most equaliser passes per frame (1: DFE only).
    follow_track : bool
        Compensation follows the eq 9 speed track smoothed to its
        least-squares line through the ML mean speed (the frame's
        acceleration); False: the constant mean speed.
    equalizer : DfeSettings, optional
        A fixed equaliser; default: sized per frame to the delay spread
        measured on the pilots (:func:`~seamodem.receive.demodulate.dfe_for_span`).
    blank_impulses : bool
        Zero the passband samples of impulses (clicks) before anything else
        (:mod:`~seamodem.receive.impulse`); the record's ``blanked_fraction``
        says how much of each frame was blanked. Costs < 0.1 dB in white noise
        (benchmarks/bench_doppler_paths.py), so on by default.
    impulse_threshold : float
        Impulse level in robust (median/MAD) standard deviations of the input.
    whole_frame_doppler : bool
        When decoding, fit each resolved path's Doppler over the whole frame
        with the decoded symbols as the reference
        (:mod:`~seamodem.receive.wholeframe`): ``v_r_mps`` is then the direct
        path's.
    front_end_block : int, optional
        Input samples per front-end FFT block, roughly (default 2¹⁶, the cheapest per sample; a live
        receiver uses 2¹³ for latency: :func:`~seamodem.receive.frontend.plan_front_end`). Changes the
        results by float rounding only.
    beacon_depth_m, vehicle_depth_m : float, optional
        Depths of the beacon and of the vehicle [m], when known (a surveyed
        beacon, the vehicle's pressure sensor). With both, the surface image's
        extra delay at the measured range, 2·z_b·z_v/(R·c) for R ≫ z, is
        known: below the signal's resolution 1/B it is an echo merged with the
        direct path, which biases the arrival by a fraction of that delay with
        no signature one frame shows. With the delay the image's carrier phase
        is known too, and so is the bias (0.4–0.47 of the delay for most
        phases): it is taken out of the arrival, whose σ then covers the
        phase and reflection not known (waves, the depths' error:
        :func:`~seamodem.receive.frame.merged_image_bias_s`), and the
        channel bend it makes is not counted again. Where another
        fitted path couples to the direct one, the delay is the arrival's σ
        (:func:`~seamodem.receive.frame.merged_image_delay_s`). Without the
        depths the σ cannot cover that bias (docs/receiver.md), unless the
        echoes give them (``echo_geometry``).
    vehicle_depth_log : tuple of two sequences, optional
        The vehicle's depth over the recording, in place of ``vehicle_depth_m``
        for a vehicle that changes depth: (times [s] on the recording's clock,
        strictly increasing; depths [m]), each frame taking the depth at its
        arrival (linear between samples, the end samples held outside the log:
        :meth:`vehicle_depth_at`). A vehicle that dives while a constant depth
        is given has its surface image predicted at the wrong delay and phase:
        the bias taken out is another's, and the σ no longer covers it.
    wave_amplitude_m, wave_period_s : float
        The sea state the merged surface image rides, with the depths: waves
        of this amplitude [m] (half the height) and no shorter period [s]
        move the image's path, and with it its bias's spread and the Doppler
        it gives v_r where the amplitude cannot show it (default 0.5 m at
        3 s, a wind sea of 1 m; a calm sea's smaller values give smaller σ's).
    echo_geometry : bool
        Without the ends' depths (one-way): take them from the echoes the
        decoded frames' whole-frame fits resolve, where their lags form a
        flat waveguide's first images (the bottom and the two surface–bottom
        images, :mod:`~seamodem.receive.echo_geometry`); the surface image
        they then place below 1/B is taken out of the arrival as with the
        depths given. False: a merged image only counts through the channel
        bend it shows (as before session 28).
    lookahead_frames : int
        Frames measured after a record before it is given out: its range σ
        then also covers the channel bend that those later frames show
        (:class:`~seamodem.receive.frame.RecordLookahead`; the first frames of
        a recording have no earlier ones). 0 gives each record out as soon as
        it is measured (a live receiver: ``rx --live`` uses 0).

    Examples
    --------
    >>> ReceiverSettings(sound_speed_mps=1480.0).v_max_mps
    5.0
    >>> ReceiverSettings(v_max_mps=-1)
    Traceback (most recent call last):
    ...
    seamodem.errors.ConfigError: v_max: must be a positive number, got -1
    """

    sound_speed_mps: float = 1500.0
    clock_offset_s: float = 0.0
    turnaround_s: float | None = None
    v_max_mps: float = 5.0
    false_alarms_per_hour: float = 0.01
    decode: bool = False
    turbo_passes: int = 3
    follow_track: bool = True
    equalizer: Any = None
    blank_impulses: bool = True
    impulse_threshold: float = 5.0
    whole_frame_doppler: bool = True
    front_end_block: int | None = None
    beacon_depth_m: float | None = None
    vehicle_depth_m: float | None = None
    vehicle_depth_log: tuple | None = None
    wave_amplitude_m: float = 0.5
    wave_period_s: float = 3.0
    lookahead_frames: int = 5
    echo_geometry: bool = True

    def __post_init__(self):
        _positive("sound_speed", self.sound_speed_mps)
        _positive("impulse_threshold", self.impulse_threshold)
        _positive("v_max", self.v_max_mps)
        _positive("false_alarms_per_hour", self.false_alarms_per_hour)
        if not (isinstance(self.clock_offset_s, (int, float)) and math.isfinite(self.clock_offset_s)):
            raise ConfigError("clock_offset", f"must be finite, got {self.clock_offset_s!r}")
        t = self.turnaround_s
        if t is not None and not (isinstance(t, (int, float)) and math.isfinite(t) and t >= 0):
            raise ConfigError("turnaround", f"must be >= 0, got {t!r}")
        p = self.turbo_passes
        if isinstance(p, bool) or not isinstance(p, int) or p < 1:
            raise ConfigError("turbo_passes", f"must be an integer >= 1, got {p!r}")
        b = self.front_end_block
        if b is not None and (isinstance(b, bool) or not isinstance(b, int) or b < 1024):
            raise ConfigError("front_end_block", f"must be an integer >= 1024 samples, got {b!r}")
        for name in ("beacon_depth_m", "vehicle_depth_m"):
            if getattr(self, name) is not None:
                _non_negative(name.removesuffix("_m"), getattr(self, name), "a depth >= 0 m")
        if self.vehicle_depth_log is not None:
            object.__setattr__(self, "vehicle_depth_log", _depth_log(self.vehicle_depth_log))
            if self.vehicle_depth_m is not None:
                raise ConfigError("vehicle_depth_log", "give a vehicle depth or a depth log, not both")
        _non_negative("wave_amplitude", self.wave_amplitude_m, ">= 0 m")
        _positive("wave_period", self.wave_period_s)
        n = self.lookahead_frames
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise ConfigError("lookahead_frames", f"must be an integer >= 0, got {n!r}")
        for name in ("decode", "follow_track", "blank_impulses", "whole_frame_doppler"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(name, f"must be true or false, got {getattr(self, name)!r}")

    @property
    def two_way(self) -> bool:
        return self.turnaround_s is not None

    def vehicle_depth_at(self, t_s: float) -> float | None:
        """The vehicle's depth [m] at ``t_s`` [s]: ``vehicle_depth_m``, else the depth log's (linear between
        samples, its end samples held outside it), else None.

        >>> s = ReceiverSettings(vehicle_depth_log=((0.0, 10.0), (2.0, 4.0)))
        >>> s.vehicle_depth_at(2.5), s.vehicle_depth_at(-1.0), s.vehicle_depth_at(30.0)
        (2.5, 2.0, 4.0)
        """
        if self.vehicle_depth_m is not None:
            return float(self.vehicle_depth_m)
        if self.vehicle_depth_log is None:
            return None
        import numpy as np

        times, depths = self.vehicle_depth_log
        return float(np.interp(float(t_s), times, depths))

    def to_dict(self) -> dict[str, Any]:
        """Every field as plain values (for headers and the identity of batch parts).

        Returns
        -------
        dict
            Field name → value, in the order of the fields; ``equalizer`` is
            None or the fields of its :class:`~seamodem.decode.equalizer.DfeSettings`.
        """
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ReceiverSettings:
        """The settings a :meth:`to_dict` (or a measurement header holding one) describes.

        Parameters
        ----------
        data : mapping
            Field name → value; fields missing take their defaults, other keys
            (a header's ``config``, ``created_by``...) are left aside.

        Returns
        -------
        ReceiverSettings

        Raises
        ------
        ConfigError
            A value out of range.

        Examples
        --------
        >>> s = ReceiverSettings(sound_speed_mps=1480.0, turnaround_s=0.5)
        >>> ReceiverSettings.from_dict(s.to_dict()) == s
        True
        """
        values = {f.name: data[f.name] for f in fields(cls) if f.name in data}
        if isinstance(values.get("equalizer"), Mapping):
            from ..decode.equalizer import DfeSettings

            values["equalizer"] = DfeSettings(**values["equalizer"])
        return cls(**values)


def _depth_log(log) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """A vehicle depth log (times, depths) as two tuples of floats, checked: the same length, at least one
    sample, finite, times strictly increasing, depths >= 0."""
    try:
        times, depths = log
        times = tuple(float(t) for t in times)
        depths = tuple(float(d) for d in depths)
    except (TypeError, ValueError):
        raise ConfigError("vehicle_depth_log", "must be (times, depths), two sequences of numbers") from None
    if not times or len(times) != len(depths):
        raise ConfigError("vehicle_depth_log", f"needs as many depths as times, at least one: got {len(times)} "
                                               f"times and {len(depths)} depths")
    if not all(math.isfinite(v) for v in times + depths):
        raise ConfigError("vehicle_depth_log", "holds a value that is not a finite number")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise ConfigError("vehicle_depth_log", "its times must increase strictly")
    if min(depths) < 0:
        raise ConfigError("vehicle_depth_log", f"a depth >= 0 m, got {min(depths)!r}")
    return times, depths


@dataclass(frozen=True, kw_only=True)
class ReferenceSettings(ReceiverSettings):
    """:class:`ReceiverSettings` of the reference (known-waveform) receiver, with what it adds.

    The reference receiver (:class:`~seamodem.receive.reference.ReferenceReceiver`) uses
    ``sound_speed_mps``, ``clock_offset_s``, ``v_max_mps`` and ``false_alarms_per_hour`` (shared
    among the references and channels searched); the frame receiver's decoding and blanking fields
    are not used. Validated once, on construction, with the frame receiver's rules and these:
    |v_r| searched below :data:`REFERENCE_V_MAX_LIMIT_MPS`, no two-way ranging, no decoding.

    Parameters
    ----------
    min_rho : float
        Smallest normalised correlation of a detection, in [0, 1] (0: the ρ test off).
    max_accel_mps2 : float
        Largest radial acceleration over a pre/postamble packet [m/s²], in [0, 100);
        0 states a constant speed (:func:`~seamodem.receive.reference.pair_up`).

    Examples
    --------
    >>> s = ReferenceSettings(v_max_mps=6.0, sound_speed_mps=1500.0)
    >>> s.eps_max, s.min_rho
    (0.004, 0.05)
    >>> ReferenceSettings.from_settings(ReceiverSettings(v_max_mps=3.0)).v_max_mps
    3.0
    >>> ReferenceSettings(v_max_mps=150.0)
    Traceback (most recent call last):
    ...
    seamodem.errors.ConfigError: v_max: must be below 100 m/s with reference waveforms, got 150.0
    """

    min_rho: float = MIN_RHO
    max_accel_mps2: float = MAX_ACCEL_MPS2

    def __post_init__(self):
        super().__post_init__()
        if not self.v_max_mps < REFERENCE_V_MAX_LIMIT_MPS:
            raise ConfigError(
                "v_max", f"must be below {REFERENCE_V_MAX_LIMIT_MPS:g} m/s with reference waveforms, got {self.v_max_mps!r}"
            )
        if self.turnaround_s is not None:
            raise ConfigError("turnaround", "two-way ranging is not available with reference waveforms")
        if self.decode:
            raise ConfigError("decode", "reference waveforms carry no payload to decode")
        a = self.max_accel_mps2
        if isinstance(a, bool) or not (isinstance(a, (int, float)) and math.isfinite(a) and 0 <= a < 100):
            raise ConfigError("max_accel", f"must be in [0, 100) m/s², got {a!r}")
        r = self.min_rho
        if isinstance(r, bool) or not (isinstance(r, (int, float)) and 0 <= r <= 1):
            raise ConfigError("min_rho", f"must be in [0, 1], got {r!r}")

    @classmethod
    def from_settings(cls, settings: ReceiverSettings, **changes: Any) -> ReferenceSettings:
        """The reference settings holding every field of ``settings`` (validated again), with ``changes``.

        Parameters
        ----------
        settings : ReceiverSettings
            Receiver settings; a :class:`ReferenceSettings` keeps its own fields.
        **changes
            Fields to replace (``min_rho``, ``max_accel_mps2``, ``v_max_mps``, …).

        Returns
        -------
        ReferenceSettings
            ``settings`` itself when it already is one and nothing changes.
        """
        if isinstance(settings, cls) and not changes:
            return settings
        values = {f.name: getattr(settings, f.name) for f in fields(settings)}
        return cls(**{**values, **changes})

    @property
    def eps_max(self) -> float:
        """Largest |ε| = v_max/c searched (Doppler scale, dimensionless)."""
        return self.v_max_mps / self.sound_speed_mps


@dataclass(frozen=True)
class Emissions:
    """When frames were emitted: an explicit list, or a PPS-synchronised period.

    Parameters
    ----------
    times_s : numpy.ndarray, optional
        Emission time of each frame (sidecar) [s], increasing; frame_index is
        the position in this list.
    start_s, period_s : float, optional
        Frame k emitted at start + k·period (``--emit-start``, ``--emit-period``).

    Examples
    --------
    >>> e = Emissions(start_s=0.5, period_s=3.0)
    >>> e.frame_for(7.0)
    (2, 6.5)
    >>> e.shifted(6.0).frame_for(1.0)
    (2, 0.5)
    """

    times_s: np.ndarray | None = None
    start_s: float | None = None
    period_s: float | None = None

    def __post_init__(self):
        if self.times_s is None:
            if self.start_s is None or self.period_s is None:
                raise ConfigError("emissions", "give emission times, or both start and period")
            if not (math.isfinite(self.period_s) and self.period_s > 0):
                raise ConfigError("emit_period", f"must be > 0, got {self.period_s!r}")
            if not math.isfinite(self.start_s):
                raise ConfigError("emit_start", f"must be finite, got {self.start_s!r}")
        else:
            times = np.asarray(self.times_s, dtype=float)
            if times.ndim != 1 or times.size == 0 or np.any(np.diff(times) <= 0) or not np.all(np.isfinite(times)):
                raise ConfigError("emissions", "emission times must be a non-empty increasing list of finite numbers")
            object.__setattr__(self, "times_s", times)

    def frame_for(self, t_s: float) -> tuple[int, float]:
        """(frame_index, t_emit_s) of the latest emission at or before ``t_s``; (−1, nan) if none."""
        slack = 1e-6  # a frame heard at tof ≈ 0 may measure a hair early
        if self.times_s is None:
            k = math.floor((t_s - self.start_s + slack) / self.period_s)
        else:
            k = int(np.searchsorted(self.times_s, t_s + slack, side="right")) - 1
        return (k, self.time_of(k)) if k >= 0 else (-1, math.nan)

    def time_of(self, frame_index: int) -> float:
        """Emission time of frame ``frame_index`` [s] (nan for −1, no emission)."""
        if frame_index < 0:
            return math.nan
        if self.times_s is None:
            return self.start_s + frame_index * self.period_s
        return float(self.times_s[frame_index])

    def shifted(self, t0_s: float) -> Emissions:
        """The same emissions on a clock whose zero is at ``t0_s`` (a segment of a recording)."""
        if t0_s == 0:
            return self
        if self.times_s is None:
            return Emissions(start_s=self.start_s - t0_s, period_s=self.period_s)
        return Emissions(times_s=self.times_s - t0_s)

    def to_list(self) -> list:
        """Plain values (for the identity of batch parts)."""
        return [None if self.times_s is None else self.times_s.tolist(), self.start_s, self.period_s]


#: c outside this range is refused unless forced: seawater is 1440–1560 m/s, fresh water ≈ 1400–1500 m/s
PLAUSIBLE_SOUND_SPEED_MPS = (1400.0, 1600.0)
#: c when neither the user nor the recording's sidecar gives one [m/s]
DEFAULT_SOUND_SPEED_MPS = 1500.0


def resolve_sound_speed(given: float | None, sidecar: dict | None, *, force: bool = False) -> tuple[float, str]:
    """The sound speed a receiver uses, in every mode: the option, else the recording's sidecar, else 1500 m/s.

    Parameters
    ----------
    given : float or None
        The user's value (``--sound-speed``) [m/s].
    sidecar : dict or None
        The recording's sidecar: ``channel.sound_speed_mps`` (written by ``seamodem channel``), else a
        top-level ``sound_speed_mps``.
    force : bool
        Accept a value outside :data:`PLAUSIBLE_SOUND_SPEED_MPS` (``--force-sound-speed``).

    Returns
    -------
    sound_speed_mps : float
        c [m/s].
    origin : str
        Where it came from: "option", "sidecar" or "default" (say so to the user: ranges scale with it).

    Raises
    ------
    ConfigError
        Not a positive finite number, or outside 1400–1600 m/s without ``force``.

    Examples
    --------
    >>> resolve_sound_speed(None, {"channel": {"sound_speed_mps": 1496.99}})
    (1496.99, 'sidecar')
    >>> resolve_sound_speed(None, None)
    (1500.0, 'default')
    """
    if given is not None:
        value, origin = given, "option"
    else:
        side = sidecar if isinstance(sidecar, dict) else {}
        channel = side.get("channel") if isinstance(side.get("channel"), dict) else {}
        value = channel.get("sound_speed_mps", side.get("sound_speed_mps"))
        value, origin = (DEFAULT_SOUND_SPEED_MPS, "default") if value is None else (value, "sidecar")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ConfigError("sound_speed", f"must be a number of m/s, got {value!r} (from the {origin})") from None
    if not (math.isfinite(value) and value > 0):
        raise ConfigError("sound_speed", f"must be a positive number of m/s, got {value!r} (from the {origin})")
    lo, hi = PLAUSIBLE_SOUND_SPEED_MPS
    if not force and not lo <= value <= hi:
        raise ConfigError("sound_speed", f"{value:g} m/s (from the {origin}) is outside {lo:g}–{hi:g} m/s, "
                          "implausible in water; give --force-sound-speed to use it anyway")
    return value, origin
