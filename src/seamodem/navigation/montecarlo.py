"""Monte Carlo reproduction of paper 000 §4.1 (Tables 3 and 4): proposed EKF versus ROSB.

Each run simulates a whole boustrophedon mission: the vehicle follows the path
with the feedback-linearization controller (eq 2), the IMU/AHRS and the acoustic
frames are emulated from the true geometry with the noise of :class:`NoiseModel`,
and the 6-state EKF (eq 5–7, 18–25) estimates the position. Runs are
independent, seeded by (seed, run index) — the same noise for every T_com and
both filters (common random numbers), so differences between rows and filters
are not sampling noise — and spread over all local cores (the compiled kernel
releases the GIL, so threads suffice).
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import ConfigError
from ._kernels import NOISE_COLUMNS, mission_kernel
from .ekf import ExtendedKalmanFilter
from .imu import bias_step, imu_reading, imu_sigmas
from .inertial import InertialConfig
from .models import Auv6Model, closing_speed
from .paper import EQ25_ORDER, EQ25_R, EQ25_R_DIAG, eq25_q
from .ekf_smoother import rts_smooth
from .trajectories import boustrophedon
from .vehicle import feedback_command, vehicle_step

__all__ = [
    "NoiseModel",
    "MissionConfig",
    "MonteCarloResult",
    "PAPER_TABLE",
    "FILTERS",
    "mission_noise",
    "simulate_mission",
    "simulate_mission_reference",
    "simulate_inertial_mission",
    "INERTIAL_FILTERS",
    "ALL_FILTERS",
    "BIAS_MODELS",
    "run_monte_carlo",
    "summarize_runs",
    "outlier_mask",
    "format_table",
]

#: Filters of the reproduction: the paper's proposal (range + v_r) and the ROSB baseline (range only).
FILTERS = ("proposed", "rosb")

#: The inertial filter (:mod:`.inertial`) with range and v_r, with range only, and its two smoothers
#: (:mod:`.inertial.smoothers`, post-processing of the "inertial" mission: the vehicle steers on the filter).
INERTIAL_FILTERS = ("inertial", "inertial_range", "fixed_lag", "batch")

#: Every estimator :func:`run_monte_carlo` can run, in table order.
ALL_FILTERS = FILTERS + INERTIAL_FILTERS

#: How the heading-sensor bias evolves in the simulation (:attr:`NoiseModel.heading_bias_model`).
BIAS_MODELS = ("random_walk", "drift")

#: What the position error is measured on (:attr:`MissionConfig.error_of`).
ERROR_OF = ("estimate", "smoothed", "last_fix")

#: Paper 000 Tables 3 and 4: T_com → (mean error [m], outliers, variance [m²], %etd max, %etd mean,
#: ROSB mean error [m], ROSB outliers).
PAPER_TABLE = {
    3.0: (3.6054, 1, 1.7549, 0.5268, 0.2281, 4.5870, 4),
    6.0: (5.0440, 5, 3.2143, 0.5850, 0.3152, 6.2255, 6),
    9.0: (6.4518, 1, 6.2173, 0.7662, 0.4032, 7.7197, 5),
    12.0: (8.0853, 6, 12.7455, 1.0938, 0.5053, 9.2462, 15),
    15.0: (9.5457, 6, 18.3823, 1.3950, 0.5966, 10.6684, 10),
    20.0: (12.1322, 6, 33.9161, 1.7825, 0.7583, 12.9695, 29),
}


@dataclass(frozen=True, kw_only=True)
class NoiseModel:
    """Standard deviations of the emulated measurements.

    Defaults are the square roots of the filter's R (paper 000 eq 25, :data:`.paper.EQ25_R`), i.e. a
    filter that is told the truth about its sensors, and the AHRS figures of
    paper 000 §3.5.3 (1° white heading noise, 5°/h bias instability). The paper
    shows its noises only as box plots (Fig. 6); these are our stated choice.

    Parameters
    ----------
    sigma_range_m : float
        Range noise [m] (√12 = 3.46 m).
    sigma_vr_mps : float
        Closing-speed noise [m/s] (√0.2 = 0.447 m/s).
    sigma_heading_deg : float
        White heading noise [deg].
    heading_drift_deg_per_h : float
        Heading bias random walk: its standard deviation after one hour [deg].
    sigma_omega_rad_s : float
        Gyro white noise [rad/s] (√0.005 = 0.0707, inside the paper's ±0.1 s⁻¹).
    sigma_accel_mps2 : float
        Accelerometer white noise [m/s²] (√0.005, inside the paper's ±0.1 m/s²).
    sigma_bearing_deg : float
        The beacon's body-frame azimuth from a hydrophone array on the vehicle (issue 17), one per frame [deg];
        0 (default): no array. The inertial filters and smoothers then use it; the paper's filters do not.
    heading_bias_model : {"random_walk", "drift"}
        How ``heading_drift_deg_per_h`` is read. ``"random_walk"`` (the reproduction's choice so far): a
        random walk whose standard deviation is that value after one hour. ``"drift"``: a bias that drifts
        at a constant rate, drawn once per run from N(0, (that value per hour)²) — how a datasheet's
        "bias instability 5°/h" behaves over a mission. The random walk wanders ≈ 0.8° per 100 s, the drift
        0.14°: docs/navigation.md shows what that difference does to a single-beacon fix.
    """

    sigma_range_m: float = math.sqrt(EQ25_R["range"])
    sigma_vr_mps: float = math.sqrt(EQ25_R["v_r"])
    sigma_heading_deg: float = 1.0
    heading_drift_deg_per_h: float = 5.0
    sigma_omega_rad_s: float = math.sqrt(EQ25_R["omega"])
    sigma_accel_mps2: float = math.sqrt(EQ25_R["a"])
    sigma_bearing_deg: float = 0.0
    heading_bias_model: str = "random_walk"

    def __post_init__(self):
        if self.heading_bias_model not in BIAS_MODELS:
            raise ConfigError("heading_bias_model", f"must be one of {BIAS_MODELS}, got {self.heading_bias_model!r}")
        for name in self.__dataclass_fields__:
            if name == "heading_bias_model":
                continue
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(name, f"must be finite and >= 0, got {value!r}")

    def sigmas(self, dt_s: float) -> np.ndarray:
        """Per-step standard deviations in :data:`NOISE_COLUMNS` order (SI units): the IMU's
        (:func:`.imu.imu_sigmas`), then range and v_r."""
        imu = imu_sigmas(sigma_heading_deg=self.sigma_heading_deg, heading_drift_deg_per_h=self.heading_drift_deg_per_h,
                         sigma_omega_rad_s=self.sigma_omega_rad_s, sigma_accel_mps2=self.sigma_accel_mps2, dt_s=dt_s,
                         bias_random_walk=self.heading_bias_model == "random_walk")
        return np.r_[imu, self.sigma_range_m, self.sigma_vr_mps]

    def bias_rate(self, noise: np.ndarray) -> float:
        """The run's heading-bias drift rate [rad/s]: 0 for the random walk, else drawn from ``noise[0, 3]``.

        Row 0 of a mission's normals is not used by the paper's kernel, so the drift takes nothing from the
        other noise columns: the same runs see the same IMU, range and v_r noise under both bias models.
        """
        if self.heading_bias_model == "random_walk":
            return 0.0
        return math.radians(self.heading_drift_deg_per_h) / 3600.0 * float(noise[0, 3])

    def inertial_config(self, dt_s: float, **overrides) -> InertialConfig:
        """The inertial filter told the truth about these sensors (densities at the step ``dt_s``).

        The simulated range and v_r have Gaussian errors only, no outliers, so the filter told the truth has no
        χ² gate (``gate_probability=None``; pass it in ``overrides`` to study the gate). Measured: with the
        records' default gate (p = 0.9999) the filter gated 15–43 of 23 000 frames per 300 receiver-grade
        missions at T_com 12–20 s, every one a nonlinearity of the filter near a lane's closest approach and
        not a bad measurement, and 1 mission in 300 then left the truth by more than 50 m; without the gate
        the worst mission stayed within 22 m (seeds 0–2).

        Random-walk bias: the bias random walk is the stated one. Drifting bias: the drift rate is a state
        with that prior and the bias keeps a small random walk (0.5°/h after one hour) for what a constant
        rate does not describe.
        """
        if self.heading_bias_model == "drift":
            extra = dict(bias_rw=math.radians(0.5) / 60.0, estimate_bias_drift=True,
                         p0_bias_drift_rad_s=max(math.radians(self.heading_drift_deg_per_h), 1e-9) / 3600.0)
        else:
            extra = dict(bias_rw=math.radians(self.heading_drift_deg_per_h) / 60.0)
        extra["gate_probability"] = None
        return InertialConfig.from_noise_model(self, dt_s, **{**extra, **overrides})


@dataclass(frozen=True, kw_only=True)
class MissionConfig:
    """One simulated mission of paper 000 §4.1.

    Parameters
    ----------
    tcom_s : float
        Period of the acoustic frames [s]; must be a multiple of ``dt_s``.
    dt_s : float
        Filter and simulation step [s] (Table 2: 0.25 s).
    beacon_xy : tuple
        Beacon position [m] (Table 2: (50, 100)).
    r_diag : tuple
        Filter R for (d, v_r, ψ, Ω, a) — eq 25's diag(1, 0.005, 0.005, 12, 0.2)
        in eq 18's order (:data:`.paper.EQ25_R_DIAG`).
    q : float, tuple of 6 floats, or None
        Process noise variance per step: one value for every state, or one per
        state (x, y, ψ, v, Ω, a); ``None`` means Δt⁸ for all (eq 25).
    p0_diag : tuple
        Initial covariance diagonal (not printed in paper 000; I₆ as in papers 002–003).
    steer_on_estimate : bool
        The controller steers on the filter's estimate (a real vehicle) rather than on the truth.
    v_min_mps, v_max_mps : float
        Vehicle speed limits (Table 2: |v| ≤ 3 m/s; v ≥ 0.1 m/s keeps eq 2 regular).
    omega_max_rad_s, accel_max_mps2 : float
        Actuator limits of the controller (not in the paper; our choice for a
        micro-AUV: 0.5 rad/s, 0.5 m/s²). Without them, steering on the estimate
        turns each range correction into a step command the filter's
        near-constant-acceleration model (Q = Δt⁸) cannot follow.
    noise : NoiseModel
        Emulated measurement noise.
    error_of : {"estimate", "smoothed", "last_fix"}
        Which position the error is measured on: the filter's real-time estimate
        (paper 000), the Rauch–Tung–Striebel smoothed track (post-processing,
        :mod:`~seamodem.navigation.ekf_smoother`; the controller still steers on the
        filter), or the filter's position at the last frame held until the next
        one (a diagnostic: the error the paper's Table 3 is consistent with, see
        docs/navigation.md).
    path : dict
        Keyword arguments of :func:`~seamodem.navigation.trajectories.boustrophedon`.
    inertial : InertialConfig, optional
        The inertial filter's settings; ``None``: :meth:`NoiseModel.inertial_config` (told the truth).
    start_error : bool
        Start the inertial filter off the truth by a draw from its initial covariance (position, speed)
        and start the true heading bias from its prior: what a consistency check needs. ``False`` (the
        paper's protocol): the filter starts at the true position and speed, the bias at 0.
    lag_s : float
        Latency of the fixed-lag smoother [s].
    divergence_m : float
        A run whose position error ever exceeds this [m] (or is not finite) counts as diverged.
    current_mps : tuple
        True water current (east, north) [m/s]; only the inertial filters' missions simulate it.
    range_scale : float
        True scale error of range and v_r (a sound-speed error c_true/c_assumed − 1); inertial missions only.
    """

    tcom_s: float = 3.0
    dt_s: float = 0.25
    beacon_xy: tuple = (50.0, 100.0)
    r_diag: tuple = EQ25_R_DIAG
    q: float | None = None
    p0_diag: tuple = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    steer_on_estimate: bool = True
    v_min_mps: float = 0.1
    v_max_mps: float = 3.0
    omega_max_rad_s: float = 0.5
    accel_max_mps2: float = 0.5
    noise: NoiseModel = field(default_factory=NoiseModel)
    error_of: str = "estimate"
    path: dict = field(default_factory=dict)
    inertial: InertialConfig | None = None
    start_error: bool = False
    lag_s: float = 10.0
    divergence_m: float = 50.0
    current_mps: tuple = (0.0, 0.0)
    range_scale: float = 0.0

    def __post_init__(self):
        if not (math.isfinite(self.lag_s) and self.lag_s > 0):
            raise ConfigError("lag_s", f"must be > 0 s, got {self.lag_s!r}")
        if not self.divergence_m > 0:
            raise ConfigError("divergence_m", f"must be > 0 m, got {self.divergence_m!r}")
        if len(self.current_mps) != 2 or not all(math.isfinite(c) for c in self.current_mps):
            raise ConfigError("current_mps", f"must be two finite speeds [m/s], got {self.current_mps!r}")
        if not (math.isfinite(self.range_scale) and abs(self.range_scale) < 0.1):
            raise ConfigError("range_scale", f"must be finite and within ±0.1, got {self.range_scale!r}")
        if not self.dt_s > 0:
            raise ConfigError("dt_s", f"must be > 0 s, got {self.dt_s!r}")
        ratio = self.tcom_s / self.dt_s
        if not (self.tcom_s > 0 and abs(ratio - round(ratio)) < 1e-9):
            raise ConfigError("tcom_s", f"must be a positive multiple of dt_s = {self.dt_s} s, got {self.tcom_s!r}")
        if len(self.r_diag) != 5 or min(self.r_diag) <= 0:
            raise ConfigError("r_diag", f"must be 5 positive variances (d, v_r, ψ, Ω, a), got {self.r_diag!r}")
        if len(self.p0_diag) != 6 or min(self.p0_diag) <= 0:
            raise ConfigError("p0_diag", f"must be 6 positive variances, got {self.p0_diag!r}")
        if self.q is not None:
            q = np.atleast_1d(np.asarray(self.q, dtype=float))
            if q.size not in (1, 6) or q.ndim != 1 or not np.all(np.isfinite(q)) or np.any(q < 0):
                raise ConfigError("q", f"must be one or 6 finite variances >= 0, got {self.q!r}")
        if self.error_of not in ERROR_OF:
            raise ConfigError("error_of", f"must be one of {ERROR_OF}, got {self.error_of!r}")

    @property
    def process_variance(self) -> float:
        """Process noise variance of the position states per step (all states when ``q`` is a scalar)."""
        return float(self.process_diag[0])

    @property
    def process_diag(self) -> np.ndarray:
        """Diagonal of the filter's Q per step, (x, y, ψ, v, Ω, a)."""
        if self.q is None:
            return np.full(6, eq25_q(self.dt_s))
        return np.broadcast_to(np.asarray(self.q, dtype=float), (6,)).copy()

    @property
    def inertial_config(self) -> InertialConfig:
        """The inertial filter's settings (:attr:`inertial`, or told the truth about the sensors)."""
        return self.inertial if self.inertial is not None else self.noise.inertial_config(self.dt_s)

    @property
    def com_every(self) -> int:
        return int(round(self.tcom_s / self.dt_s))

    def reference(self):
        """Desired path sampled at every step: array (n + 1, 6) and the path object."""
        path = boustrophedon(**self.path)
        n = int(round(path.duration_s / self.dt_s))
        sample = path.sample(np.arange(n + 1) * self.dt_s)
        return np.hstack([sample.position, sample.velocity, sample.acceleration]), path


def mission_noise(seed: int, run: int, n_steps: int) -> np.ndarray:
    """Standard normals of run ``run``, shape (n_steps + 1, 6), from ``default_rng([seed, run])``."""
    return np.random.default_rng([seed, run]).standard_normal((n_steps + 1, len(NOISE_COLUMNS)))


def _start_state(reference: np.ndarray) -> np.ndarray:
    """True initial state: on the path, heading and speed along it."""
    vx, vy = reference[0, 2], reference[0, 3]
    return np.array([reference[0, 0], reference[0, 1], math.atan2(vy, vx), math.hypot(vx, vy)])


def simulate_mission(config: MissionConfig, noise: np.ndarray, *, filter: str = "proposed", reference=None):
    """One mission with the compiled kernel: (error (n+1,), estimate (n+1, 2), truth (n+1, 2)) [m].

    ``estimate`` is the position ``config.error_of`` names: the filter's, the
    smoothed one, or the last frame's held until the next.
    """
    if filter in INERTIAL_FILTERS:
        return simulate_inertial_mission(config, noise, filter=filter, reference=reference)[:3]
    if filter not in FILTERS:
        raise ConfigError("filter", f"must be one of {ALL_FILTERS}, got {filter!r}")
    if config.current_mps != (0.0, 0.0) or config.range_scale != 0.0:
        raise ConfigError("current_mps", "a current or a range scale is simulated for the inertial filters only")
    if reference is None:
        reference, _ = config.reference()
    n = reference.shape[0] - 1
    history = np.empty((n + 1 if config.error_of == "smoothed" else 0, 6, 20))
    error, estimate, truth = mission_kernel(
        reference,
        noise,
        _start_state(reference),
        config.noise.sigmas(config.dt_s),
        np.asarray(config.r_diag, dtype=float),
        np.asarray(config.p0_diag, dtype=float),
        np.asarray(config.beacon_xy, dtype=float),
        config.dt_s,
        config.process_diag,
        config.com_every,
        filter == "proposed",
        config.steer_on_estimate,
        config.v_min_mps,
        config.v_max_mps,
        config.omega_max_rad_s,
        config.accel_max_mps2,
        history,
        config.noise.bias_rate(noise),
    )
    if config.error_of == "estimate":
        return error, estimate, truth
    if config.error_of == "smoothed":
        smoothed, _ = rts_smooth(history[:, :, 1], history[:, :, 8:14], history[:, :, 0], history[:, :, 2:8],
                                 history[:, :, 14:20])
        estimate = np.ascontiguousarray(smoothed[:, :2])
    else:
        estimate = estimate[held_fix_index(n, config.com_every)]
    return np.hypot(*(estimate - truth).T), estimate, truth


def simulate_inertial_mission(config: MissionConfig, noise: np.ndarray, *, filter: str = "inertial",
                              reference=None):
    """One mission with the inertial filter in the loop: (error, estimate, truth, details) [m].

    ``filter``: ``"inertial"`` (range + v_r), ``"inertial_range"`` (range only), or a smoother of the
    ``"inertial"`` mission, ``"fixed_lag"`` (latency ``config.lag_s``) or ``"batch"``. The controller steers
    on the filter (or the truth); a smoother post-processes the sensors that mission recorded, through the
    same filter re-run over them (equal to the in-loop filter: tested). ``details`` has the filter's
    ``status`` and ``nis`` per step, the recorded ``sensors`` (n + 1, 6) and, for smoothers, the
    ``states`` and ``covariances`` of the output.
    """
    from ._inertial_mission import InertialMission, inertial_mission_kernel
    from .inertial.driver import filter_model, filter_settings

    if filter not in INERTIAL_FILTERS:
        raise ConfigError("filter", f"must be one of {INERTIAL_FILTERS}, got {filter!r}")
    if config.error_of != "estimate":
        raise ConfigError("error_of", "the inertial filters have their own smoothers (filter 'fixed_lag' or "
                                      f"'batch'); error_of must be 'estimate', got {config.error_of!r}")
    if reference is None:
        reference, _ = config.reference()
    n = reference.shape[0] - 1
    icfg = config.inertial_config
    start = _start_state(reference)
    use_vr = filter != "inertial_range"
    z0, P0 = icfg.initial(start[0], start[1], 0.0, start[3])
    offsets = np.zeros(4)
    if config.start_error:
        # row 0's columns 1, 2, 4, 5 are used by no kernel (0: the first heading reading, 3: the bias drift)
        offsets[:] = (icfg.p0_position_m * noise[0, 1], icfg.p0_position_m * noise[0, 2],
                      icfg.p0_speed_mps * noise[0, 4], icfg.p0_bias_rad * noise[0, 5])
    sig = config.noise.sigmas(config.dt_s)
    meas_var = np.array([max(config.noise.sigma_range_m, 1e-6) ** 2, max(config.noise.sigma_vr_mps, 1e-6) ** 2])
    sensors = np.empty((n + 1, 6))
    bearing_sigma = math.radians(config.noise.sigma_bearing_deg)
    if bearing_sigma > 0 and config.com_every < 2:
        raise ConfigError("sigma_bearing_deg", "a bearing needs T_com of at least two IMU steps (its noise is drawn "
                                               f"from the step before the frame), got T_com {config.tcom_s} s")
    mission = InertialMission(reference, noise, start, offsets, sig, config.dt_s, config.com_every,
                              config.steer_on_estimate, config.v_min_mps, config.v_max_mps, config.omega_max_rad_s,
                              config.accel_max_mps2, np.asarray(config.current_mps, dtype=float), config.range_scale,
                              config.noise.bias_rate(noise), bearing_sigma, icfg.heading_sigma_rad**2, meas_var)
    error, estimate, truth, status, nis = inertial_mission_kernel(
        mission, z0, P0, icfg.layout, filter_model(icfg, config.beacon_xy, use_range=True, use_vr=use_vr),
        filter_settings(icfg, use_range=True, use_vr=use_vr), sensors)
    details = {"status": status, "nis": nis, "sensors": sensors}
    if filter in ("inertial", "inertial_range"):
        return error, estimate, truth, details
    from .inertial import add_bearings, build_nodes, run_filter
    from .inertial.smoothers import batch_smooth, fixed_lag_smooth

    t = np.arange(n + 1) * config.dt_s
    frames = np.isfinite(sensors[:, 3])
    nodes = build_nodes(t, sensors[:, 0], sensors[:, 1], sensors[:, 2], t[frames], sensors[frames, 3],
                        sensors[frames, 4], meas_var[0], meas_var[1], heading_var=icfg.heading_sigma_rad**2)
    if bearing_sigma > 0:
        nodes = add_bearings(nodes, sensors[frames, 5], bearing_sigma)
    z_start = z0.copy()
    z_start[[0, 1, 3]] += offsets[:3]
    z_start[2] = sensors[0, 0] - z_start[4]
    run = run_filter(nodes, icfg, beacon_xy=config.beacon_xy, z0=z_start, P0=P0, use_vr=True)
    out = batch_smooth(run) if filter == "batch" else fixed_lag_smooth(run, lag_s=config.lag_s)
    estimate = np.ascontiguousarray(out.states[:, :2])
    details.update(states=out.states, covariances=out.covariances, filter_run=run)
    return np.hypot(*(estimate - truth).T), estimate, truth, details


def held_fix_index(n_steps: int, com_every: int) -> np.ndarray:
    """Index of the last frame step at or before each step 0…n (step 0: the start fix)."""
    k = np.arange(n_steps + 1)
    return (k // com_every) * com_every


def simulate_mission_reference(config: MissionConfig, noise: np.ndarray, *, filter: str = "proposed",
                               reference=None, filter_factory=None):
    """The same mission as :func:`simulate_mission`, written with the general EKF class.

    This is the pure-Python form the compiled kernel is tested against (and the
    timing reference of ``benchmarks/bench_navigation.py``); the IMU readings are
    :mod:`.imu`'s, the same functions the kernel calls. ``filter_factory``
    (x0, P0, Q, model) → object with ``predict(t_s)`` / ``update(z, kind, R)`` and
    ``x`` lets the benchmark plug in another EKF implementation.
    """
    if config.error_of == "smoothed":
        raise ConfigError("error_of", "'smoothed' is computed by simulate_mission only (the compiled kernel)")
    if reference is None:
        reference, _ = config.reference()
    n = reference.shape[0] - 1
    sig = config.noise.sigmas(config.dt_s)
    dt = config.dt_s
    model = Auv6Model(config.beacon_xy)
    x, y, psi, v = _start_state(reference)
    x0 = np.array([x, y, psi, v, 0.0, 0.0])
    P0 = np.diag(config.p0_diag)
    Q = np.diag(config.process_diag)
    factory = filter_factory or (lambda x0, P0, Q, model: ExtendedKalmanFilter(model, x0, P0, Q))
    ekf = factory(x0, P0, Q, model)
    r = dict(zip(EQ25_ORDER, config.r_diag))
    kind = "com" if filter == "proposed" else "rosb"
    R_com = np.diag([r[c] for c in model.kinds[kind]])
    R_ahrs = np.diag([r[c] for c in model.kinds["ahrs"]])
    error, estimate, truth = np.zeros(n + 1), np.zeros((n + 1, 2)), np.zeros((n + 1, 2))
    estimate[0], truth[0] = x0[:2], (x, y)
    bias = 0.0
    bias_rate = config.noise.bias_rate(noise)

    def command(k):
        s = ekf.x[:4] if config.steer_on_estimate else (x, y, psi, v)
        return feedback_command(*s, *reference[k], config.v_min_mps, config.omega_max_rad_s, config.accel_max_mps2)

    omega, accel = command(0)
    for k in range(1, n + 1):
        v_old = v
        x, y, psi, v = vehicle_step(x, y, psi, v, omega, accel, dt, config.v_min_mps, config.v_max_mps)
        ekf.predict(k * dt)
        bias = bias_step(bias, sig, noise, k, bias_rate, dt)
        ahrs = list(imu_reading(psi, bias, omega, (v - v_old) / dt, sig, noise, k))
        if k % config.com_every == 0:
            d = math.hypot(x - config.beacon_xy[0], y - config.beacon_xy[1]) + sig[4] * noise[k, 4]
            vr = float(closing_speed(x, y, psi, v, config.beacon_xy)) + sig[5] * noise[k, 5]
            ekf.update([d, vr, *ahrs] if kind == "com" else [d, *ahrs], kind, R_com)
        else:
            ekf.update(ahrs, "ahrs", R_ahrs)
        estimate[k], truth[k] = ekf.x[:2], (x, y)
        error[k] = math.hypot(*(estimate[k] - truth[k]))
        omega, accel = command(k)
    if config.error_of == "last_fix":
        estimate = estimate[held_fix_index(n, config.com_every)]
        error = np.hypot(*(estimate - truth).T)
    return error, estimate, truth


def outlier_mask(values: np.ndarray) -> np.ndarray:
    """True for values outside [q1 − 1.5·IQR, q3 + 1.5·IQR] (paper 000 §4.1.1, lower bound as corrected in SPEC §5)."""
    q1, q3 = np.percentile(values, [25, 75])
    iqr = q3 - q1
    return (values < q1 - 1.5 * iqr) | (values > q3 + 1.5 * iqr)


def summarize_runs(mean_error: np.ndarray, var_error: np.ndarray, max_error: np.ndarray,
                   travelled: np.ndarray, *, divergence_m: float = 50.0) -> dict:
    """One row of Table 3 from per-run statistics; outliers counted then excluded.

    ``mean_error``, ``var_error``, ``max_error`` are each run's mean, variance and
    maximum of the position error over time [m, m², m]; ``travelled`` each run's
    travelled distance [m]. %etd = error / travelled distance × 100. ``diverged``
    counts the runs whose error ever exceeded ``divergence_m`` (or was not finite);
    they are among the outliers when the IQR rule catches them, and a row with any
    is not a result (:func:`format_table` says so).
    """
    diverged = ~np.isfinite(max_error) | (max_error > divergence_m)
    finite = np.isfinite(mean_error)
    out = ~finite
    out[finite] = outlier_mask(mean_error[finite])
    keep = ~out
    if not keep.any():
        nan = float("nan")
        return {"mean_error_m": nan, "error_variance_m2": nan, "etd_max_pct": nan, "etd_mean_pct": nan,
                "outliers": int(out.sum()), "diverged": int(diverged.sum()), "median_error_m": nan}
    return {
        "mean_error_m": float(mean_error[keep].mean()),
        "error_variance_m2": float(var_error[keep].mean()),
        "etd_max_pct": float((100 * max_error[keep] / travelled[keep]).mean()),
        "etd_mean_pct": float((100 * mean_error[keep] / travelled[keep]).mean()),
        "outliers": int(out.sum()),
        "diverged": int(diverged.sum()),
        "median_error_m": float(np.median(mean_error[finite])) if finite.any() else float("nan"),
    }


@dataclass
class MonteCarloResult:
    """Table rows plus what the figures need.

    ``rows``: list of dicts with ``tcom_s, filter`` and the :func:`summarize_runs` keys.
    ``mean_error_curve[(tcom, filter)]``: error averaged over the non-outlier runs, (n + 1,) [m].
    ``mean_track[(tcom, filter)]``: estimated track averaged over the same runs, (n + 1, 2) [m].
    ``per_run_mean_error[(tcom, filter)]``: each run's mean error, (runs,) [m].
    """

    config: MissionConfig
    tcoms: tuple
    runs: int
    seed: int
    rows: list
    t_s: np.ndarray
    truth_track: np.ndarray
    mean_error_curve: dict
    mean_track: dict
    per_run_mean_error: dict
    wall_time_s: float = 0.0


def _run_chunk(config, reference, filter, seed, runs):
    n = reference.shape[0] - 1
    stats = np.empty((len(runs), 4))
    curves = np.empty((len(runs), n + 1))
    track_sum = np.zeros((len(runs), n + 1, 2), dtype=np.float32)
    truth = None
    for i, run in enumerate(runs):
        error, estimate, truth = simulate_mission(config, mission_noise(seed, run, n), filter=filter,
                                                  reference=reference)
        travelled = np.sum(np.hypot(*np.diff(truth, axis=0).T))
        stats[i] = error.mean(), error.var(), error.max(), travelled
        curves[i] = error
        track_sum[i] = estimate
    return stats, curves, track_sum, truth


def _chunk_results(tasks, configs, reference, seed, workers, progress, backend, scheduler):
    """(T_com, filter, chunk output) in task order: on local threads, or with seamodem.batch."""
    if backend is None:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = [(t, f, pool.submit(_run_chunk, configs[t], reference, f, seed, r)) for t, f, r in tasks]
            for t, f, fut in futures:
                out = fut.result()
                if progress is not None:
                    progress(len(out[0]))
                yield t, f, out
        return
    from ..batch.runner import map_tasks

    outputs = map_tasks(
        _run_chunk_task,
        [(configs[t], reference, f, seed, r) for t, f, r in tasks],
        backend=backend,
        workers=workers,
        scheduler=scheduler,
        on_result=None if progress is None else (lambda res: progress(len(res.value[0])) if res.ok else None),
    )
    for (t, f, _), out in zip(tasks, outputs):
        yield t, f, out


def _run_chunk_task(args):
    return _run_chunk(*args)


def run_monte_carlo(config: MissionConfig, *, tcoms=(3, 6, 9, 12, 15, 20), runs: int = 300, seed: int = 0,
                    filters=FILTERS, workers: int | None = None, progress=None, backend: str | None = None,
                    scheduler=None) -> MonteCarloResult:
    """Reproduce paper 000 Tables 3–4: every (T_com, filter) pair over ``runs`` seeded missions.

    Parameters
    ----------
    config : MissionConfig
        Everything but ``tcom_s``, which takes each value of ``tcoms`` [s].
    runs : int
        Missions per row (paper: 300).
    seed : int
        Run ``r`` draws its noise from ``default_rng([seed, r])``.
    workers : int, optional
        Threads, or processes with ``backend`` (default: all local cores).
    progress : callable, optional
        Called with the number of runs finished, after each chunk.
    backend : {"serial", "processes", "dask"}, optional
        Run the chunks with :func:`seamodem.batch.run_tasks` instead of local
        threads: this process, local processes, or a Dask cluster
        (``scheduler``: address or client); the same numbers on every backend.
    scheduler : str or distributed.Client, optional
        Dask scheduler, with ``backend="dask"``.
    """
    import time

    if runs < 4:
        raise ConfigError("runs", f"must be >= 4 (quartiles for the outlier rule), got {runs!r}")
    for f in filters:
        if f not in ALL_FILTERS:
            raise ConfigError("filter", f"must be one of {ALL_FILTERS}, got {f!r}")
    configs = {float(t): replace(config, tcom_s=float(t)) for t in tcoms}
    reference, _ = config.reference()
    workers = workers or os.cpu_count() or 1
    chunk = max(1, min(25, runs // workers))
    tasks = [(t, f, range(a, min(a + chunk, runs))) for t in configs for f in filters for a in range(0, runs, chunk)]
    start = time.perf_counter()
    parts: dict = {}
    truth = None
    for t, f, (stats, curves, tracks, truth) in _chunk_results(tasks, configs, reference, seed, workers, progress,
                                                               backend, scheduler):
        parts.setdefault((t, f), []).append((stats, curves, tracks))
    wall = time.perf_counter() - start
    rows, curves_out, tracks_out, per_run = [], {}, {}, {}
    for (t, f), pieces in parts.items():
        stats = np.vstack([p[0] for p in pieces])
        finite = np.isfinite(stats[:, 0]) & np.isfinite(stats[:, 2])
        keep = finite & (stats[:, 2] <= config.divergence_m)
        keep[finite] &= ~outlier_mask(stats[finite, 0])
        curves, tracks = np.vstack([p[1] for p in pieces]), np.concatenate([p[2] for p in pieces])
        # every run diverged or strayed: no mean to draw (NaN, and the table says UNSTABLE)
        curves_out[(t, f)] = curves[keep].mean(axis=0) if keep.any() else np.full(curves.shape[1], np.nan)
        tracks_out[(t, f)] = tracks[keep].mean(axis=0) if keep.any() else np.full(tracks.shape[1:], np.nan)
        per_run[(t, f)] = stats[:, 0]
        rows.append({"tcom_s": t, "filter": f, **summarize_runs(*stats.T, divergence_m=config.divergence_m)})
    rows.sort(key=lambda r: (r["tcom_s"], ALL_FILTERS.index(r["filter"])))
    n = reference.shape[0] - 1
    return MonteCarloResult(config, tuple(configs), runs, seed, rows, np.arange(n + 1) * config.dt_s, truth,
                            curves_out, tracks_out, per_run, wall)


def _q_text(config: MissionConfig) -> str:
    q = config.process_diag
    if np.all(q == q[0]):
        return f"{q[0]:.3g} I6"
    return "diag(" + ", ".join(f"{v:.3g}" for v in q) + ")"


def format_table(result: MonteCarloResult, *, paper: bool = True) -> str:
    """The result as text: paper 000's Tables 3 and 4 (with the paper's values when ``paper``) for its
    filters, and one table of every estimator that ran, with outlier and divergence counts.

    A row with diverged runs is not a result: its figure is replaced by ``UNSTABLE`` and the count.
    """
    by = {(r["tcom_s"], r["filter"]): r for r in result.rows}
    ran = [f for f in ALL_FILTERS if any((t, f) in by for t in result.tcoms)]
    noise = result.config.noise
    lines = [
        f"Monte Carlo, {result.runs} runs per row, seed {result.seed}, dt = {result.config.dt_s} s, "
        f"controller steers on the {'estimate' if result.config.steer_on_estimate else 'truth'}",
        f"noise: range {noise.sigma_range_m:.3g} m, v_r {noise.sigma_vr_mps:.3g} m/s, heading "
        f"{noise.sigma_heading_deg:.3g} deg + bias {noise.heading_drift_deg_per_h:.3g} deg/h "
        f"({noise.heading_bias_model.replace('_', ' ')}), gyro {noise.sigma_omega_rad_s:.3g} rad/s, accel "
        f"{noise.sigma_accel_mps2:.3g} m/s^2"
        + (f", array bearing {noise.sigma_bearing_deg:.3g} deg" if noise.sigma_bearing_deg > 0 else ""),
    ]
    if any(f in FILTERS for f in ran):
        lines.append(f"paper filters: R = {result.config.r_diag} (d, v_r, psi, omega, a), "
                     f"Q = {_q_text(result.config)}; error of the {result.config.error_of.replace('_', ' ')}")
    if any(f in INERTIAL_FILTERS for f in ran):
        ic = result.config.inertial_config
        lines.append(f"inertial filter: sensor densities told the truth, bias drift state "
                     f"{'on' if ic.estimate_bias_drift else 'off'}, gate {ic.gate_probability}; fixed lag "
                     f"{result.config.lag_s:g} s")
    lines.append(f"diverged = runs whose error exceeded {result.config.divergence_m:g} m; outliers (IQR rule) "
                 "are counted, then excluded from the mean")

    def cell(r):
        if r is None:
            return f"{'':>22}"
        if r["diverged"]:
            return f"{'UNSTABLE':>10} {r['diverged']:>3}/{result.runs:<3} div"
        return f"{r['mean_error_m']:>10.3f} ({r['outliers']:>3}, {r['diverged']:>2})"

    if "proposed" in ran and paper:
        lines += ["", "Table 3 (paper 000's proposed filter)",
                  f"{'T_com':>6} | {'mean error m (outliers, diverged)':>33} | {'variance m2':>11} | {'%etd max':>8} | "
                  f"{'%etd mean':>9} || {'paper mean (out)':>17} | {'paper var':>9} | {'ratio':>5}"]
        for t in result.tcoms:
            r = by.get((t, "proposed"))
            if r is None:
                continue
            line = (f"{t:>5g}s | {cell(r):>33} | {r['error_variance_m2']:>11.4f} | "
                    f"{r['etd_max_pct']:>8.4f} | {r['etd_mean_pct']:>9.4f}")
            if t in PAPER_TABLE:
                p = PAPER_TABLE[t]
                ratio = "  -  " if r["diverged"] else f"{r['mean_error_m'] / p[0]:>5.2f}"
                line += f" || {p[0]:>11.4f} ({p[1]:>3}) | {p[2]:>9.4f} | {ratio}"
            lines.append(line)
    lines += ["", "Mean position error [m] (outliers, diverged) per estimator"
              + (" | paper proposed / ROSB" if paper else ""),
              f"{'T_com':>6} | " + " | ".join(f"{f:>22}" for f in ran) + (" | paper" if paper else "")]
    for t in result.tcoms:
        line = f"{t:>5g}s | " + " | ".join(cell(by.get((t, f))) for f in ran)
        if paper and t in PAPER_TABLE:
            line += f" | {PAPER_TABLE[t][0]:.2f} / {PAPER_TABLE[t][5]:.2f}"
        lines.append(line)
    if paper and (abs(noise.sigma_range_m - math.sqrt(EQ25_R["range"])) > 1e-9
                  or abs(noise.sigma_vr_mps - math.sqrt(EQ25_R["v_r"])) > 1e-9):
        lines.append(f"(the paper's values are at its own noise, range {math.sqrt(EQ25_R['range']):.3g} m and v_r "
                     f"{math.sqrt(EQ25_R['v_r']):.3g} m/s; this table is at the noise above)")
    unstable = sum(r["diverged"] for r in result.rows)
    if unstable:
        lines += ["", f"{unstable} run(s) diverged in the rows marked UNSTABLE: those rows are not results "
                      "(docs/navigation.md, 'Stable defaults')."]
    lines.append(f"wall time {result.wall_time_s:.1f} s")
    return "\n".join(lines)
