"""Settings of the simulated missions of paper 000 §4.1: the emulated sensors' noise and the mission.

:class:`NoiseModel` says how noisy the emulated IMU/AHRS, range and v_r are;
:class:`MissionConfig` the path, the filter's tuning, the controller's limits
and what the error is measured on. :mod:`.missions` simulates a mission from
them, :mod:`.montecarlo` runs many.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from .inertial import InertialConfig
from .imu import imu_sigmas
from .paper import EQ25_R, EQ25_R_DIAG, eq25_q
from .trajectories import boustrophedon

__all__ = [
    "FILTERS",
    "INERTIAL_FILTERS",
    "ALL_FILTERS",
    "BIAS_MODELS",
    "ERROR_OF",
    "NoiseModel",
    "MissionConfig",
]

#: Filters of the reproduction: the paper's proposal (range + v_r) and the ROSB baseline (range only).
FILTERS = ("proposed", "rosb")

#: The inertial filter (:mod:`.inertial`) with range and v_r, with range only, and its two smoothers
#: (:mod:`.inertial.smoothers`, post-processing of the "inertial" mission: the vehicle steers on the filter).
INERTIAL_FILTERS = ("inertial", "inertial_range", "fixed_lag", "batch")

#: Every estimator :func:`.montecarlo.run_monte_carlo` can run, in table order.
ALL_FILTERS = FILTERS + INERTIAL_FILTERS

#: How the heading-sensor bias evolves in the simulation (:attr:`NoiseModel.heading_bias_model`).
BIAS_MODELS = ("random_walk", "drift")

#: What the position error is measured on (:attr:`MissionConfig.error_of`).
ERROR_OF = ("estimate", "smoothed", "last_fix")


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
        """Per-step standard deviations in :data:`NOISE_COLUMNS` order (SI units).

        Parameters
        ----------
        dt_s : float
            Simulation step [s].

        Returns
        -------
        numpy.ndarray, shape (6,)
            The IMU's (:func:`.imu.imu_sigmas`), then range [m] and v_r [m/s].
        """
        imu = imu_sigmas(sigma_heading_deg=self.sigma_heading_deg, heading_drift_deg_per_h=self.heading_drift_deg_per_h,
                         sigma_omega_rad_s=self.sigma_omega_rad_s, sigma_accel_mps2=self.sigma_accel_mps2, dt_s=dt_s,
                         bias_random_walk=self.heading_bias_model == "random_walk")
        return np.r_[imu, self.sigma_range_m, self.sigma_vr_mps]

    def bias_rate(self, noise: np.ndarray) -> float:
        """The run's heading-bias drift rate [rad/s]: 0 for the random walk, else drawn from ``noise[0, 3]``.

        Row 0 of a mission's normals is not used by the paper's kernel, so the drift takes nothing from the
        other noise columns: the same runs see the same IMU, range and v_r noise under both bias models.

        Parameters
        ----------
        noise : numpy.ndarray, shape (n + 1, 6)
            The mission's standard normals (:func:`mission_noise`).

        Returns
        -------
        float
            The drift rate [rad/s].
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

        Parameters
        ----------
        dt_s : float
            Filter step [s].
        **overrides
            :class:`~seamodem.navigation.inertial.InertialConfig` fields that replace the derived ones.

        Returns
        -------
        InertialConfig
            The filter's settings.
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
        """Simulation steps per acoustic frame, T_com / dt."""
        return int(round(self.tcom_s / self.dt_s))

    def reference(self):
        """The desired path sampled at every step.

        Returns
        -------
        reference : numpy.ndarray, shape (n + 1, 6)
            Position, velocity and acceleration (x, y each) at steps 0 … n.
        path : Trajectory
            The :func:`~seamodem.navigation.trajectories.boustrophedon` path object.
        """
        path = boustrophedon(**self.path)
        n = int(round(path.duration_s / self.dt_s))
        sample = path.sample(np.arange(n + 1) * self.dt_s)
        return np.hstack([sample.position, sample.velocity, sample.acceleration]), path
