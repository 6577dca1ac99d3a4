"""The demo mission's configuration (:class:`DemoConfig`, the filters it compares, its receiver's settings)
and its vehicle record (:class:`VehicleRun`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig, get_preset
from ..errors import ConfigError

__all__ = ["FILTERS", "FILTER_LABELS", "FILTER_COLOURS", "WAVEFORMS", "JANUS_SAMPLE_RATE_HZ", "DemoConfig",
           "VehicleRun", "receiver_settings"]

#: What the demo's beacon emits: the preset's frames, or JANUS packets (parameter set 1; :mod:`.janus`).
WAVEFORMS = ("frame", "janus")
#: The JANUS beacon's sample rate [Hz] (docs/janus.md's beacon rate).
JANUS_SAMPLE_RATE_HZ = 96000
#: Time a JANUS packet's echoes and the travel over the survey need after the packet [s] (the T_com check).
JANUS_ECHO_MARGIN_S = 0.1

#: Positioning filters compared by the demo: the inertial filter and its batch smoother (docs/navigation.md),
#: and paper 000's EKF (proposed = range + v_r) and ROSB (range only).
FILTERS = ("inertial", "batch", "proposed", "rosb")

#: Their names in the summary and the figures, and their line colours.
FILTER_LABELS = {"inertial": "inertial filter", "batch": "batch smoother", "proposed": "paper 000 EKF",
                 "rosb": "paper 000 ROSB"}
FILTER_COLOURS = {"inertial": "C0", "batch": "C2", "proposed": "C3", "rosb": "C1"}


@dataclass(frozen=True, kw_only=True)
class DemoConfig:
    """Everything the demo mission depends on (written to ``demo_config.json``).

    Parameters
    ----------
    preset : str
        Frame preset (paper 000 Table 5: jmse2024).
    tcom_s : float
        Time between two frames [s] (paper 000 at sea: 3 s).
    n_lanes, lane_length_m, width_m : int, float, float
        The survey: ``n_lanes`` lanes along y, ``lane_length_m`` long, spread
        over ``width_m`` in x and joined by half circles.
    speed_mps : float
        Survey speed [m/s].
    duration_s : float or None
        Mission length [s]; None: the time to run the whole survey.
    beacon_xy_m : (float, float)
        Beacon position, east and north [m].
    depth_m : float
        Depth of both beacon and vehicle [m] (equal depths: the slant range of
        the direct path is the horizontal range the EKF models).
    water_depth_m : float
        Flat bottom [m].
    sound_speed_mps : float
        c [m/s].
    surface_reflection, bottom_reflection : float
        Reflection coefficients of the two echoes.
    snr_db : float
        In-band SNR (SPEC §1) of the white noise, mean over frames [dB].
    dt_s : float
        Vehicle, IMU and filter step [s] (paper 000 Table 2: 0.25 s).
    sigma_heading_deg, heading_drift_deg_per_h, sigma_omega_rad_s, sigma_accel_mps2 : float
        AHRS/IMU noise (as :class:`seamodem.navigation.NoiseModel`).
    seed : int
        Seeds the IMU noise, the channel's noise and the emulated measurements.
    array : str or None
        A hydrophone array (a preset such as ``tetra:0.08`` or a TOML/JSON file,
        as ``seamodem channel --array``): also run the mission's recording
        through it (step 7). None: one hydrophone only.
    waveform : str
        ``"frame"`` (the preset's frames) or ``"janus"`` (a JANUS base packet every T_com,
        parameter set 1, received by the JANUS receiver; no array).
    """

    preset: str = "jmse2024"
    tcom_s: float = 3.0
    n_lanes: int = 3
    lane_length_m: float = 40.0
    width_m: float = 20.0
    speed_mps: float = 1.0
    duration_s: float | None = None
    beacon_xy_m: tuple[float, float] = (45.0, -25.0)
    depth_m: float = 5.0
    water_depth_m: float = 20.0
    sound_speed_mps: float = 1500.0
    surface_reflection: float = -0.9
    bottom_reflection: float = 0.5
    snr_db: float = 12.0
    dt_s: float = 0.25
    sigma_heading_deg: float = 1.0
    heading_drift_deg_per_h: float = 5.0
    sigma_omega_rad_s: float = math.sqrt(0.005)
    sigma_accel_mps2: float = math.sqrt(0.005)
    seed: int = 1
    array: str | None = None
    waveform: str = "frame"

    def __post_init__(self):
        get_preset(self.preset)  # raises ConfigError naming the preset
        if self.waveform not in WAVEFORMS:
            raise ConfigError("waveform", f"must be one of {', '.join(WAVEFORMS)}, got {self.waveform!r}")
        if self.waveform == "janus" and self.array is not None:
            raise ConfigError("array", "the array mission takes frames only (waveform frame)")
        if self.array is not None:
            from ..channel.array import load_array
            from ..receive.array import array_geometry

            a = load_array(self.array)  # raises naming the array
            array_geometry(a.element_positions_m, a.assume)
        for name in ("tcom_s", "lane_length_m", "width_m", "speed_mps", "depth_m", "water_depth_m",
                     "sound_speed_mps", "dt_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(name, f"must be a positive number, got {value!r}")
        if self.waveform == "janus" and not self.tcom_s > self.emission_s + JANUS_ECHO_MARGIN_S:
            raise ConfigError("tcom_s", f"must exceed a JANUS packet ({self.emission_s:.3f} s) plus "
                              f"{JANUS_ECHO_MARGIN_S:g} s for its echoes and travel, got {self.tcom_s:g}")
        if self.duration_s is not None and not (math.isfinite(self.duration_s) and self.duration_s >= self.tcom_s):
            raise ConfigError("duration_s", f"must be at least tcom_s = {self.tcom_s:g} s, got {self.duration_s!r}")
        if isinstance(self.n_lanes, bool) or not isinstance(self.n_lanes, int) or self.n_lanes < 2:
            raise ConfigError("n_lanes", f"must be an integer >= 2, got {self.n_lanes!r}")
        if self.depth_m >= self.water_depth_m:
            raise ConfigError("depth_m", f"must be above the bottom (water_depth_m = {self.water_depth_m:g}), got {self.depth_m!r}")
        if len(self.beacon_xy_m) != 2:
            raise ConfigError("beacon_xy_m", f"must be two numbers (east, north), got {self.beacon_xy_m!r}")
        object.__setattr__(self, "beacon_xy_m", tuple(float(v) for v in self.beacon_xy_m))
        for name in ("sigma_heading_deg", "heading_drift_deg_per_h", "sigma_omega_rad_s", "sigma_accel_mps2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(name, f"must be finite and >= 0, got {value!r}")

    @property
    def frame_config(self) -> FrameConfig:
        return get_preset(self.preset)

    @property
    def janus_pset(self):
        """The JANUS beacon's parameter set (set 1).

        Returns
        -------
        JanusParameterSet
        """
        from ..transmit.janus import get_parameter_set

        return get_parameter_set(1)

    @property
    def emission_s(self) -> float:
        """One emission's length [s]: the preset's frame, or the JANUS packet with its padding."""
        if self.waveform == "frame":
            return self.frame_config.frame_duration_s
        from ..transmit.janus import janus_waveform

        wave = janus_waveform(self.janus_packet(), self.janus_pset, JANUS_SAMPLE_RATE_HZ)
        return wave.x_pb.size / JANUS_SAMPLE_RATE_HZ

    def janus_packet(self):
        """The JANUS beacon's packet: class 16 / type 0, station 1, parameter set 1, no cargo.

        Returns
        -------
        JanusPacket
        """
        from ..transmit.janus import JanusPacket

        return JanusPacket.class16_app0(station_id=1, pset_id=self.janus_pset.pset_id, cargo=b"")

    def path(self):
        """The desired survey path.

        Returns
        -------
        SegmentPath
            The boustrophedon (:func:`seamodem.navigation.trajectories.boustrophedon`), positions in [m].
        """
        from ..navigation.trajectories import boustrophedon

        return boustrophedon(width_m=self.width_m, lane_length_m=self.lane_length_m, n_lanes=self.n_lanes,
                             y0_m=0.0, speed_mps=self.speed_mps)

    def mission_s(self) -> float:
        """The mission's length [s]: ``duration_s``, or the whole survey's duration."""
        return self.path().duration_s if self.duration_s is None else float(self.duration_s)

    def frame_count(self) -> int:
        """Frames emitted at 0, T_com, … strictly before the mission's end.

        Returns
        -------
        int
            At least 1.
        """
        return max(1, math.ceil(self.mission_s() / self.tcom_s - 1e-9))


def receiver_settings(sidecar: dict):
    """How the demo's receiver works: the channel's sound speed, payloads decoded.

    Parameters
    ----------
    sidecar : dict
        The received recording's sidecar (its ``channel.sound_speed_mps`` [m/s]).

    Returns
    -------
    ReceiverSettings
    """
    from ..receive import ReceiverSettings

    return ReceiverSettings(sound_speed_mps=float(sidecar["channel"]["sound_speed_mps"]), decode=True)


@dataclass(frozen=True, eq=False)
class VehicleRun:
    """The true vehicle and its IMU/AHRS, sampled every Δt.

    Parameters
    ----------
    t_s : numpy.ndarray, shape (n,)
        Sample times [s].
    xy_m : numpy.ndarray, shape (n, 2)
        True position [m].
    heading_rad, speed_mps : numpy.ndarray, shape (n,)
        True heading (counter-clockwise from east) and speed.
    imu : dict of numpy.ndarray
        ``t_s, heading_rad, omega_rad_s, accel_mps2``: the measured AHRS/IMU
        (the columns of ``seamodem nav track --imu``).
    """

    t_s: np.ndarray
    xy_m: np.ndarray
    heading_rad: np.ndarray
    speed_mps: np.ndarray
    imu: dict
