"""The channel as functions of true time: each path's delay τ_p(t) and complex gain g_p(t).

r(t) = Σ_p g_p(t) · s(t − τ_p(t)) (SPEC §3, paper 003 eq 11–12), t the true
(beacon) time of reception. A path's closing speed is v_r,p = −c dτ_p/dt.
A real gain multiplies s; a complex one acts on the analytic signal (see
:mod:`seamodem.channel.resample`).

- :class:`GeometryModel`: τ_p(t) = |r(t) − b_p| / c for a still beacon image
  b_p and the vehicle at r(t); amplitude = spreading · Thorp absorption ·
  reflection coefficients · rough-surface loss, normalised so that the direct
  path has amplitude 1 at t = 0 (the loss removed is reported).
- :class:`RayTracedModel`: the same geometry in a [water] sound-speed profile:
  τ_p(t) = the travel time of the traced eigenray of path p (direct, surface,
  bottom, ...) from the beacon's depth to the vehicle's at their horizontal range.
- :class:`ProfileModel`: τ_0(t) = R₀/c − ∫₀ᵗ v_r/c (paper 003 eq 12) for the
  direct path, and echoes at fixed excess delays sharing its Doppler (eq 13).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .fluctuation import GaussianDopplerProcess
from .geometry import SampledTrack, StraightLine, Trajectory, WaypointTrack, image_sources, read_track_csv
from .profiles import DopplerProfile
from .propagation import absorption_gain, rough_surface_gain, spreading_gain, thorp_absorption_db_per_km
from .resample import HALF_TAPS
from .scenario import Scenario

__all__ = ["PathInfo", "ChannelModel", "GeometryModel", "RayTracedModel", "ProfileModel", "build_model"]

AMPLITUDE_STEP = 64


@dataclass(frozen=True)
class PathInfo:
    """What the sidecar says about one path.

    Attributes
    ----------
    index : int
        Position of the path in the model, 0 for the direct path.
    name : str
        ``"direct"``, a reflection sequence such as ``"SB"`` (geometry mode)
        or ``"echo1"``, ``"echo2"``, ... (profile mode).
    n_surface, n_bottom : int, optional
        Numbers of surface and bottom reflections; default 0.
    reflection : float, optional
        Product of the reflection coefficients (profile mode: the echo's
        gain) [linear]; default 1.
    image_m : tuple of float or None, optional
        The beacon image's position ``(x, y, z)`` [m] (geometry mode only).
    excess_delay_s : float or None, optional
        Delay relative to the direct path [s] (profile mode only).
    """

    index: int
    name: str
    n_surface: int = 0
    n_bottom: int = 0
    reflection: float = 1.0  # product of the reflection coefficients (profile mode: the echo's gain)
    image_m: tuple[float, float, float] | None = None
    excess_delay_s: float | None = None

    def to_dict(self) -> dict:
        """The sidecar entry: the fields, without those that are None."""
        out = {"index": self.index, "name": self.name, "n_surface": self.n_surface, "n_bottom": self.n_bottom,
               "reflection": self.reflection}
        if self.image_m is not None:
            out["image_m"] = list(self.image_m)
        if self.excess_delay_s is not None:
            out["excess_delay_s"] = self.excess_delay_s
        return out


class ChannelModel:
    """Paths of one scenario; subclasses give ``delays`` and ``amplitudes``.

    Parameters
    ----------
    scenario : Scenario
        The parsed scenario.
    paths : list of PathInfo
        The paths, direct first.

    Attributes
    ----------
    scenario : Scenario
        The scenario given.
    c : float
        Sound speed [m/s].
    clock : Clock
        The receiver clock of the scenario.
    paths : list of PathInfo
        The paths given.
    fluctuations : list
        Per path, its Rician gain process, or None for a steady gain (set by
        :meth:`add_fluctuations`).
    """

    def __init__(self, scenario: Scenario, paths: list[PathInfo]):
        self.scenario = scenario
        self.c = scenario.sound_speed_mps
        self.clock = scenario.clock
        self.paths = paths
        self.fluctuations: list[GaussianDopplerProcess | None] = [None] * len(paths)

    @property
    def n_paths(self) -> int:
        """Number of paths."""
        return len(self.paths)

    def delays(self, t_s) -> np.ndarray:
        """τ_p at true times ``t_s`` [s], shape (n_paths, n).

        Parameters
        ----------
        t_s : array_like
            True times of reception [s], shape ``(n,)``.

        Returns
        -------
        numpy.ndarray
            Delays [s], shape ``(n_paths, n)``.
        """
        raise NotImplementedError

    def amplitudes(self, t_s, delays: np.ndarray) -> np.ndarray:
        """Steady real path amplitudes, shape (n_paths, n).

        Parameters
        ----------
        t_s : array_like
            True times of reception [s], shape ``(n,)``.
        delays : numpy.ndarray
            :meth:`delays` at ``t_s`` [s], shape ``(n_paths, n)``.

        Returns
        -------
        numpy.ndarray
            Amplitudes [linear], shape ``(n_paths, n)``.
        """
        raise NotImplementedError

    def check_span(self, t0_s: float, t1_s: float) -> None:
        """Raise if the scenario is not valid over true times [t0, t1] (speeds, water).

        Parameters
        ----------
        t0_s, t1_s : float
            True-time span the simulation needs [s].

        Raises
        ------
        ConfigError
            A speed reaches the sound speed, the vehicle leaves the water,
            the range reaches zero, or a track does not cover the span.
        """

    def gains(self, t_s, delays: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Weights of s and of ŝ per path (Re g, −Im g); the second is None without fluctuations.

        The steady amplitudes change over metres of travel, not samples: they are
        evaluated every ``AMPLITUDE_STEP`` samples and interpolated linearly.

        Parameters
        ----------
        t_s : array_like
            True times of reception [s], shape ``(n,)``.
        delays : numpy.ndarray
            :meth:`delays` at ``t_s`` [s], shape ``(n_paths, n)``.

        Returns
        -------
        gi : numpy.ndarray
            Weights of s, Re g_p [linear], shape ``(n_paths, n)``.
        gq : numpy.ndarray or None
            Weights of the Hilbert transform ŝ, −Im g_p, shape
            ``(n_paths, n)``; None when no path fluctuates.
        """
        t_s = np.asarray(t_s, dtype=float)
        if t_s.size > 4 * AMPLITUDE_STEP:
            idx = np.r_[0 : t_s.size : AMPLITUDE_STEP, t_s.size - 1]
            coarse = self.amplitudes(t_s[idx], delays[:, idx])
            amp = np.vstack([np.interp(t_s, t_s[idx], a) for a in coarse])
        else:
            amp = self.amplitudes(t_s, delays)
        if not any(f is not None for f in self.fluctuations):
            return amp, None
        gi = amp.copy()
        gq = np.zeros_like(amp)
        for p, f in enumerate(self.fluctuations):
            if f is not None:
                xi = f(t_s)
                gi[p] = amp[p] * xi.real
                gq[p] = -amp[p] * xi.imag
        return gi, gq

    def end_time(self, input_duration_s: float, fs: float) -> float:
        """True time by which every path has delivered the input's last sample [s].

        Parameters
        ----------
        input_duration_s : float
            Duration of the transmitted input [s].
        fs : float
            Sample rate [Hz] (sets the interpolator's half-length margin).

        Returns
        -------
        float
            End time [s], the fixed point of t = duration + margin + max τ_p(t).
        """
        t_in = input_duration_s + (HALF_TAPS + 1) / fs
        t = t_in
        for _ in range(60):
            t_next = t_in + float(np.max(self.delays(np.array([t]))))
            if abs(t_next - t) < 1e-9:
                break
            t = t_next
        return t_next

    def add_fluctuations(self, t0_s: float, t1_s: float, rng: np.random.Generator) -> None:
        """Draw each path's Rician gain over [t0, t1] from [fluctuation].

        Nothing is drawn when the Doppler spread is 0 or for a path whose
        K-factor is infinite.

        Parameters
        ----------
        t0_s, t1_s : float
            True-time span to cover [s].
        rng : numpy.random.Generator
            Source of the random draws.
        """
        fl = self.scenario.fluctuation
        if fl.doppler_spread_hz <= 0:
            return
        for p in range(self.n_paths):
            k_db = fl.direct_k_db if p == 0 else fl.k_factor_db
            if not math.isinf(k_db):
                self.fluctuations[p] = GaussianDopplerProcess(fl.doppler_spread_hz, k_db, t0_s, t1_s, rng)

    def describe(self) -> dict:
        """Model constants for the sidecar (empty in the base class)."""
        return {}


class GeometryModel(ChannelModel):
    """A still beacon, a moving vehicle, and their images in a flat waveguide (module docstring).

    Parameters
    ----------
    scenario : Scenario
        A ``geometry`` mode scenario.
    reference_frequency_hz : float
        Frequency of the absorption and rough-surface losses [Hz], unless the
        scenario sets ``environment.reference_frequency_hz``.

    Attributes
    ----------
    trajectory : Trajectory
        The vehicle's track.
    f_ref : float
        Frequency used for the losses [Hz].
    images : numpy.ndarray
        Beacon image positions [m], shape ``(n_paths, 3)``.
    alpha_db_per_km : float
        Thorp absorption at ``f_ref`` [dB/km], 0 when absorption is off.
    normalization : float
        Gain that makes the direct path's amplitude 1 at the recording's
        start [linear].

    Raises
    ------
    ConfigError
        The direct path has zero amplitude.
    """

    def __init__(self, scenario: Scenario, *, reference_frequency_hz: float):
        env = scenario.environment
        mp = scenario.multipath
        depth = env.water_depth_m
        images = image_sources(scenario.beacon.position_m, depth, mp.max_bounces)
        self.trajectory = _trajectory(scenario)
        self.f_ref = float(env.reference_frequency_hz or reference_frequency_hz)
        if mp.max_paths:
            r0 = self.trajectory.position(np.zeros(1))[:, 0]
            dist = [np.linalg.norm(r0 - np.array(im.position_m)) for im in images]
            keep = sorted(np.argsort(dist, kind="stable")[: mp.max_paths])
            images = [images[i] for i in keep]
        paths = [
            PathInfo(i, im.name, im.n_surface, im.n_bottom,
                     mp.surface_reflection**im.n_surface * mp.bottom_reflection**im.n_bottom, im.position_m)
            for i, im in enumerate(images)
        ]
        super().__init__(scenario, paths)
        self.images = np.array([im.position_m for im in images])  # (P, 3)
        self.alpha_db_per_km = float(thorp_absorption_db_per_km(self.f_ref)) if env.absorption else 0.0
        self.reflection = np.array([p.reflection for p in paths])
        self.n_surface = np.array([p.n_surface for p in paths])
        self.normalization = 1.0
        t_start = float(self.clock.to_true(0.0))
        direct0 = self.amplitudes(np.array([t_start]), self.delays(np.array([t_start])))[0, 0]
        if direct0 == 0:
            raise ConfigError("multipath", "the direct path has zero amplitude")
        self.normalization = 1.0 / direct0

    def delays(self, t_s):
        r = self.trajectory.position(t_s)  # (3, n)
        d = r[None, :, :] - self.images[:, :, None]  # (P, 3, n)
        return np.sqrt(np.einsum("pin,pin->pn", d, d)) / self.c

    def amplitudes(self, t_s, delays):
        rng_m = delays * self.c
        amp = self.normalization * self.reflection[:, None] * spreading_gain(rng_m, self.scenario.environment.spreading_exponent)
        if self.alpha_db_per_km:
            amp *= absorption_gain(rng_m, self.alpha_db_per_km)
        rms = self.scenario.multipath.surface_rms_height_m
        if rms > 0 and np.any(self.n_surface):
            z_r = self.trajectory.position(t_s)[2]
            sin_grazing = np.abs(z_r[None, :] - self.images[:, 2, None]) / rng_m
            rough = rough_surface_gain(self.f_ref, rms, sin_grazing, self.c) ** self.n_surface[:, None]
            amp *= rough
        return amp

    def check_span(self, t0_s, t1_s):
        traj = self.trajectory
        if isinstance(traj, SampledTrack):
            traj.check_covers(t0_s, t1_s)
        depth = self.scenario.environment.water_depth_m
        zmin, zmax = traj.z_range(max(t0_s, 0.0), t1_s)
        if zmax > 0:
            raise ConfigError(traj.parameter, f"the vehicle rises above the surface (z = {zmax:g} m > 0) within the recording's {t1_s:g} s")
        if zmin < -depth:
            raise ConfigError(traj.parameter, f"the vehicle goes below the bottom (z = {zmin:g} m < {-depth:g} m) within the recording's {t1_s:g} s")
        speed = traj.max_speed(max(t0_s, 0.0), t1_s)
        if speed >= self.c:
            raise ConfigError(traj.parameter, f"speed {speed:g} m/s must be below the sound speed {self.c:g} m/s")

    def describe(self):
        return {
            "reference_frequency_hz": self.f_ref,
            "absorption_db_per_km": self.alpha_db_per_km,
            "normalization_db": 20.0 * math.log10(self.normalization),
        }


class RayTracedModel(GeometryModel):
    """A geometry scenario whose paths are rays traced through its [water] profile (module docstring).

    Each path of :class:`GeometryModel` (direct, ``S``, ``B``, ``SB``, ...) becomes the eigenray with
    the same reflections, its delay read from a :class:`~seamodem.water.TravelTimeTable` over the
    depths and horizontal ranges the vehicle covers (built when :meth:`check_span` learns the span,
    rebuilt if a query leaves it). Amplitudes are :class:`GeometryModel`'s with the path length
    c·τ. Where a path has no eigenray (a shadow) its amplitude is 0.

    Attributes
    ----------
    profile : SoundSpeedProfile
        The water's c(z).
    tracer : RayTracer
    """

    #: table grid [m]: horizontal range step, depth step, and the margin around the span
    RANGE_STEP_M, DEPTH_STEP_M, MARGIN_M = 1.0, 0.5, 2.0

    def __init__(self, scenario: Scenario, *, reference_frequency_hz: float):
        from ..water import RayTracer

        self.profile = scenario.water.sound_speed_profile(scenario.base_dir)
        self.tracer = RayTracer(self.profile, water_depth_m=scenario.environment.water_depth_m)
        self._tables, self._cover = None, None
        super().__init__(scenario, reference_frequency_hz=reference_frequency_hz)

    def _ensure(self, depth_m: np.ndarray, range_m: np.ndarray) -> None:
        from ..water import TravelTimeTable
        from ..water.rays import path_name

        lo_z, hi_z, lo_r, hi_r = depth_m.min(), depth_m.max(), range_m.min(), range_m.max()
        if self._cover is not None:
            c = self._cover
            if c[0] <= lo_z and hi_z <= c[1] and c[2] <= lo_r and hi_r <= c[3]:
                return
            lo_z, hi_z, lo_r, hi_r = min(lo_z, c[0]), max(hi_z, c[1]), min(lo_r, c[2]), max(hi_r, c[3])
        bottom = self.scenario.environment.water_depth_m
        z0, z1 = max(0.0, lo_z - self.MARGIN_M), min(bottom, hi_z + self.MARGIN_M)
        depths = np.append(np.arange(z0, z1, self.DEPTH_STEP_M), z1) if z1 - z0 > 1e-9 else np.array([z0])
        ranges = np.arange(max(self.RANGE_STEP_M, lo_r - self.MARGIN_M), hi_r + self.MARGIN_M + self.RANGE_STEP_M,
                           self.RANGE_STEP_M)
        beacon_depth = -self.scenario.beacon.position_m[2]
        order = max(p.n_surface + p.n_bottom for p in self.paths)
        self._tables = [TravelTimeTable(self.tracer, beacon_depth, depths, ranges, max_vertices=max(order, 1),
                                        path=path_name(p.n_surface, p.n_bottom, p.name.startswith("S")))
                        for p in self.paths]
        self._cover = (depths[0], depths[-1], ranges[0], ranges[-1])

    def _depth_range(self, t_s):
        r = self.trajectory.position(np.asarray(t_s, dtype=float).reshape(-1))
        b = np.asarray(self.scenario.beacon.position_m, dtype=float)
        return -r[2], np.hypot(r[0] - b[0], r[1] - b[1])

    def delays(self, t_s):
        depth, rng = self._depth_range(t_s)
        self._ensure(depth, rng)
        tau = np.array([table.travel_time(depth, rng) for table in self._tables])
        straight = super().delays(t_s)
        return np.where(np.isfinite(tau), tau, straight)  # a shadowed path keeps a finite delay; amplitude 0

    def amplitudes(self, t_s, delays):
        amp = super().amplitudes(t_s, delays)
        depth, rng = self._depth_range(t_s)
        traced = np.array([np.isfinite(table.travel_time(depth, rng)) for table in self._tables])
        return np.where(traced, amp, 0.0)

    def check_span(self, t0_s, t1_s):
        super().check_span(t0_s, t1_s)
        depth, rng = self._depth_range(np.linspace(max(t0_s, 0.0), t1_s, 2001))
        self._ensure(depth, rng)

    def describe(self):
        return {**super().describe(), "sound_speed_profile": self.profile.to_dict()}


class ProfileModel(ChannelModel):
    """Prescribed v_r(t) on a direct path, plus echoes that share it (module docstring).

    Parameters
    ----------
    scenario : Scenario
        A ``profile`` mode scenario.

    Attributes
    ----------
    profile : DopplerProfile
        The closing speed v_r(t).
    tau0 : float
        Direct-path delay at t = 0 [s], initial range / c.
    excess : numpy.ndarray
        Excess delay of each path [s], shape ``(n_paths,)``, 0 for the direct path.
    gain : numpy.ndarray
        Constant amplitude of each path [linear], shape ``(n_paths,)``.
    """

    def __init__(self, scenario: Scenario):
        dop = scenario.doppler
        echoes = scenario.multipath.paths
        paths = [PathInfo(0, "direct", reflection=1.0, excess_delay_s=0.0)] + [
            PathInfo(i + 1, f"echo{i + 1}", reflection=e["gain"], excess_delay_s=e["delay_s"]) for i, e in enumerate(echoes)
        ]
        super().__init__(scenario, paths)
        self.profile: DopplerProfile = dop.profile
        self.tau0 = dop.initial_range_m / self.c
        self.excess = np.array([p.excess_delay_s for p in paths])
        self.gain = np.array([p.reflection for p in paths])

    def delays(self, t_s):
        t = np.asarray(t_s, dtype=float).reshape(-1)
        direct = self.tau0 - self.profile.displacement(t) / self.c
        return direct[None, :] + self.excess[:, None]

    def amplitudes(self, t_s, delays):
        return np.broadcast_to(self.gain[:, None], delays.shape).copy()

    def check_span(self, t0_s, t1_s):
        vmax = self.profile.max_abs_speed(t0_s, t1_s)
        if vmax >= self.c:
            raise ConfigError("doppler.components", f"|v_r| reaches {vmax:g} m/s, which must stay below the sound speed {self.c:g} m/s")
        tau = self.delays(np.linspace(t0_s, t1_s, 10_001))[0]
        if np.min(tau) <= 0:
            raise ConfigError("doppler.initial_range_m", f"the range reaches zero within the recording (v_r closes {self.tau0 * self.c:g} m)")


def _trajectory(scenario: Scenario) -> Trajectory:
    v = scenario.vehicle
    if v.velocity_mps is not None:
        return StraightLine(np.array(v.start_m), np.array(v.velocity_mps))
    if v.waypoints_m is not None:
        return WaypointTrack(np.array(v.waypoints_m), v.speed_mps, v.start_s)
    path = scenario.base_dir / v.track_file
    return read_track_csv(path)


def build_model(scenario: Scenario, *, reference_frequency_hz: float) -> ChannelModel:
    """The channel model of a geometry or profile scenario.

    ``reference_frequency_hz``: frequency of the absorption and rough-surface
    losses unless the scenario gives ``environment.reference_frequency_hz``
    (the simulator passes the frame's data carrier).

    Parameters
    ----------
    scenario : Scenario
        A ``geometry`` or ``profile`` mode scenario.
    reference_frequency_hz : float
        Default frequency of the losses [Hz] (geometry mode only).

    Returns
    -------
    ChannelModel
        A :class:`GeometryModel` or a :class:`ProfileModel`.

    Raises
    ------
    ConfigError
        Any other mode (``replay`` has no path model).
    """
    if scenario.mode == "geometry" and scenario.water is not None:
        return RayTracedModel(scenario, reference_frequency_hz=reference_frequency_hz)
    if scenario.mode == "geometry":
        return GeometryModel(scenario, reference_frequency_hz=reference_frequency_hz)
    if scenario.mode == "profile":
        return ProfileModel(scenario)
    raise ConfigError("mode", f"{scenario.mode!r} has no path model (use seamodem.channel.replay)")
