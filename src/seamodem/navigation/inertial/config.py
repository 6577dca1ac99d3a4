"""Configuration of the inertial filter: sensor noise densities, optional states, gating, window, charts.

:class:`InertialConfig` holds every choice of the filter and turns it into what
the kernels take: the state layout (:attr:`InertialConfig.layout`), the process
noise density, the χ² thresholds and the window re-linearization's settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...errors import ConfigError

__all__ = ["CHI2_GATE", "WINDOW_ITERATIONS", "InertialConfig", "state_names", "with_options"]

#: Gauss–Newton iterations at most of a window re-linearization
#: (:func:`~seamodem.navigation.inertial.kernels.relinearize_window`).
WINDOW_ITERATIONS = 10

#: χ² quantiles for the gate: probability → (1 dof, 2 dof). Computed with scipy.stats.chi2.ppf,
#: tabulated so that importing the filter does not import scipy.stats.
CHI2_GATE = {
    0.99: (6.634896601021214, 9.210340371976180),
    0.999: (10.827566170662733, 13.815510557964274),
    0.9999: (15.136705226623606, 18.420680743952364),
    0.99999: (19.511420964666268, 23.025850929940457),
}


@dataclass(frozen=True, kw_only=True)
class InertialConfig:
    """Sensor noise, optional states, gating and initial uncertainty of the inertial filter.

    Noise *densities* make the filter independent of the IMU rate: over a step
    Δt the heading gains variance ``gyro_arw² · Δt``, the speed
    ``accel_vrw² · Δt``. For white samples of standard deviation σ at a period
    T_s the density is σ·√T_s (e.g. the paper's gyro, σ = 0.0707 rad/s at
    0.25 s: 0.0354 rad/√s). :meth:`from_noise_model` does that conversion.

    Parameters
    ----------
    gyro_arw : float
        Gyro angle random walk [rad/√s].
    accel_vrw : float
        Accelerometer velocity random walk [m/s/√s].
    heading_sigma_rad : float
        White noise of the heading sensor [rad] (paper 000 §3.5.3: 0.1–2°).
    bias_rw : float
        Heading-bias random walk [rad/√s] (5°/h after one hour: 0.0873/60 = 1.45e-3).
    bias_drift_rw : float
        Random walk of the bias drift rate [rad/s/√s] (only with ``estimate_bias_drift``).
    position_rw : float
        Position random walk [m/√s]: what the unicycle model misses (side slip, discretization) and what
        the linearization misses. The simulator's motion model is exact, yet with 0 one mission in 40 at
        σ_d = 1 cm lost itself near a lane's closest approach (speed and along-track position traded
        against each other, 185 m off); 0.02 kept all 40 within 13 m at no cost in mean error
        (docs/navigation.md, "Consistency").
    estimate_bias_drift : bool
        Carry the bias drift rate ḃ as a state.
    estimate_current : bool
        Carry a water current (c_x, c_y) [m/s] as two states.
    current_rw : float
        Random walk of the current [m/s/√s].
    estimate_range_scale : bool
        Carry a range scale s (sound-speed error) as a state.
    p0_position_m, p0_heading_rad, p0_speed_mps, p0_bias_rad, p0_bias_drift_rad_s, p0_current_mps, p0_scale :
        Initial standard deviations. ``p0_heading_rad`` adds to the heading sensor's own noise and bias when the
        start heading comes from the sensor.
    gate_probability : float or None
        Probability of the χ² gate on an acoustic update (one of :data:`CHI2_GATE`); ``None`` disables gating.
    gate_reset_after : int
        After this many consecutive gated frames the next frame is accepted.
    iterations : int
        Gauss–Newton iterations of the acoustic update (1 = plain EKF).
    second_order : bool
        Cartesian chart only: the range's second-order term (its curvature across the line of sight).
    window_s, window_probability : after a frame whose NIS exceeds the χ² quantile ``window_probability``
        (the filter's own prior finds it improbable), the last ``window_s`` seconds are re-solved by
        Gauss–Newton (:func:`.kernels.relinearize_window`, the batch smoother's step on a window) and the filter
        continues from the result. Measured on paper 000's protocol (300 runs per T_com, T_com 3–20 s, steering on
        the estimate): at paper-grade noise means 0–1.1 % lower and diverged missions 5 → 3 of 1800 (the one
        mission where the filter left the truth by 50 m although the data up to then did not, the MAP being 19 m
        off, stays within 50 m; the others are MAP-limited, docs/navigation.md); at receiver-grade noise means
        0.3–3.6 % lower with a random-walk bias, −2.3 to +1.5 % with a drifting one. Cost 3–5 × the filter's
        (1800 missions: 3.7 → 13.5 s at receiver grade, 3.8 → 18.8 s at paper grade). ``None`` or 0 s: off.
    min_speed_mps : float or None
        The vehicle moves forward: after each node's updates an estimated speed below this is projected onto
        it (:func:`.updates.floor_speed`). Range and v_r are blind to the track reflected about a closest approach
        with the speed negated; ``None``: no floor (a vehicle that backs up, or one a head current pushes
        backwards over ground when the current is not estimated).
    coordinates : {"polar", "cartesian"}
        ``"polar"`` (default): the position is (ρ, β), horizontal distance and bearing from the beacon,
        while the position's spread is below ρ/5 (Cartesian near the beacon, :data:`.charts.POLAR_ENTER`). Range
        is then linear in the state and the rotation about the beacon (with the heading bias, what
        range, v_r and heading cannot see) is one fixed direction, so the Gaussian keeps the curved
        range-circle shape that a Cartesian ellipse cannot (position NEES at σ_d = 1 cm: 1.5 against
        1.1e4). ``"cartesian"``: (x, y) throughout (the filter of earlier releases).
    """

    gyro_arw: float = math.sqrt(0.005) * math.sqrt(0.25)
    accel_vrw: float = math.sqrt(0.005) * math.sqrt(0.25)
    heading_sigma_rad: float = math.radians(1.0)
    bias_rw: float = math.radians(5.0) / 60.0
    bias_drift_rw: float = 1e-7
    position_rw: float = 0.02
    estimate_bias_drift: bool = False
    estimate_current: bool = False
    current_rw: float = 1e-4
    estimate_range_scale: bool = False
    p0_position_m: float = 1.0
    p0_heading_rad: float = math.radians(2.0)
    p0_speed_mps: float = 0.2
    p0_bias_rad: float = math.radians(2.0)
    p0_bias_drift_rad_s: float = math.radians(5.0) / 3600.0
    p0_current_mps: float = 0.2
    p0_scale: float = 0.01
    gate_probability: float | None = 0.9999
    gate_reset_after: int = 3
    iterations: int = 1
    second_order: bool = True
    coordinates: str = "polar"
    window_s: float = 120.0
    window_probability: float | None = 0.99
    min_speed_mps: float | None = 0.0

    def __post_init__(self):
        if self.coordinates not in ("cartesian", "polar"):
            raise ConfigError("coordinates", f"must be 'cartesian' or 'polar', got {self.coordinates!r}")
        for name in ("gyro_arw", "accel_vrw", "heading_sigma_rad", "bias_rw", "bias_drift_rw", "position_rw",
                     "current_rw"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(name, f"must be finite and >= 0, got {value!r}")
        for name in ("p0_position_m", "p0_heading_rad", "p0_speed_mps", "p0_bias_rad", "p0_bias_drift_rad_s",
                     "p0_current_mps", "p0_scale"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(name, f"must be finite and > 0, got {value!r}")
        if self.heading_sigma_rad <= 0:
            raise ConfigError("heading_sigma_rad", f"must be > 0 rad, got {self.heading_sigma_rad!r}")
        if self.gate_probability is not None and self.gate_probability not in CHI2_GATE:
            raise ConfigError("gate_probability", f"must be one of {sorted(CHI2_GATE)} or None, "
                                                  f"got {self.gate_probability!r}")
        if not (isinstance(self.gate_reset_after, int) and self.gate_reset_after >= 1):
            raise ConfigError("gate_reset_after", f"must be an integer >= 1, got {self.gate_reset_after!r}")
        if not (isinstance(self.iterations, int) and 1 <= self.iterations <= 50):
            raise ConfigError("iterations", f"must be an integer in [1, 50], got {self.iterations!r}")
        if not (math.isfinite(self.window_s) and self.window_s >= 0):
            raise ConfigError("window_s", f"must be finite and >= 0 s, got {self.window_s!r}")
        if self.window_probability is not None and self.window_probability not in CHI2_GATE:
            raise ConfigError("window_probability", f"must be one of {sorted(CHI2_GATE)} or None, "
                                                    f"got {self.window_probability!r}")
        if self.min_speed_mps is not None and not math.isfinite(self.min_speed_mps):
            raise ConfigError("min_speed_mps", f"must be finite or None, got {self.min_speed_mps!r}")

    @classmethod
    def from_noise_model(cls, noise, dt_s: float, **overrides) -> "InertialConfig":
        """Densities from the per-sample standard deviations of a :class:`~seamodem.navigation.mission_config.NoiseModel`.

        Parameters
        ----------
        noise : NoiseModel
            Per-sample standard deviations of the heading [deg], gyro [rad/s], accelerometer [m/s²] and the
            heading drift [deg/h].
        dt_s : float
            IMU step [s].
        **overrides
            Other fields of :class:`InertialConfig`.

        Returns
        -------
        InertialConfig
        """
        root = math.sqrt(dt_s)
        values = dict(gyro_arw=noise.sigma_omega_rad_s * root, accel_vrw=noise.sigma_accel_mps2 * root,
                      heading_sigma_rad=max(math.radians(noise.sigma_heading_deg), 1e-9),
                      bias_rw=math.radians(noise.heading_drift_deg_per_h) / 60.0)
        values.update(overrides)
        return cls(**values)

    @property
    def polar(self) -> bool:
        """Position states are (ρ, β) about the beacon, not (x, y)."""
        return self.coordinates == "polar"

    # --- layout -----------------------------------------------------------------------------------------
    @property
    def layout(self) -> np.ndarray:
        """Indices of the optional states (ḃ, c_x, s), −1 when absent (c_y follows c_x); then 1 if the polar
        chart may be used, and the current chart (0 Cartesian, 1 polar; the kernels switch it per node)."""
        i = 5
        idx = [-1, -1, -1, int(self.polar), int(self.polar)]
        if self.estimate_bias_drift:
            idx[0], i = i, i + 1
        if self.estimate_current:
            idx[1], i = i, i + 2
        if self.estimate_range_scale:
            idx[2], i = i, i + 1
        return np.array(idx, dtype=np.int64)

    @property
    def n_states(self) -> int:
        return 5 + self.estimate_bias_drift + 2 * self.estimate_current + self.estimate_range_scale

    @property
    def process_density(self) -> np.ndarray:
        """Diagonal process noise density per second, in state order."""
        q = [self.position_rw**2, self.position_rw**2, self.gyro_arw**2, self.accel_vrw**2, self.bias_rw**2]
        if self.estimate_bias_drift:
            q.append(self.bias_drift_rw**2)
        if self.estimate_current:
            q += [self.current_rw**2] * 2
        if self.estimate_range_scale:
            q.append(0.0)
        return np.array(q)

    def initial(self, x_m, y_m, heading_rad, speed_mps, *, heading_from_sensor: bool = True):
        """Initial state and covariance at a start fix.

        Parameters
        ----------
        x_m, y_m : float
            Start position [m].
        heading_rad : float
            Start heading [rad]: the sensor's reading (ψ + b) when ``heading_from_sensor``, the start heading
            then also carrying the bias uncertainty, correlated with it.
        speed_mps : float
            Start speed [m/s].
        heading_from_sensor : bool
            Whether ``heading_rad`` is the heading sensor's reading.

        Returns
        -------
        z : ndarray, shape (n,)
            Cartesian initial state.
        P : ndarray, shape (n, n)
            Its covariance.
        """
        n = self.n_states
        z = np.zeros(n)
        z[:4] = x_m, y_m, heading_rad, speed_mps
        P = np.zeros((n, n))
        P[0, 0] = P[1, 1] = self.p0_position_m**2
        P[3, 3] = self.p0_speed_mps**2
        P[4, 4] = self.p0_bias_rad**2
        if heading_from_sensor:
            # ψ = reading − b − noise: var = p0_b² + σ_h², cov(ψ, b) = −p0_b²
            P[2, 2] = self.p0_bias_rad**2 + self.heading_sigma_rad**2
            P[2, 4] = P[4, 2] = -self.p0_bias_rad**2
        else:
            P[2, 2] = self.p0_heading_rad**2
        lay = self.layout
        if lay[0] >= 0:
            P[lay[0], lay[0]] = self.p0_bias_drift_rad_s**2
        if lay[1] >= 0:
            P[lay[1], lay[1]] = P[lay[1] + 1, lay[1] + 1] = self.p0_current_mps**2
        if lay[2] >= 0:
            P[lay[2], lay[2]] = self.p0_scale**2
        return z, P

    @property
    def speed_floor(self) -> float:
        """The kernels' speed floor [m/s]: :attr:`min_speed_mps`, or −∞ without one."""
        return -math.inf if self.min_speed_mps is None else float(self.min_speed_mps)

    def window(self, dof: int) -> tuple[float, float]:
        """The window re-linearization's length and threshold for a frame of ``dof`` rows.

        Parameters
        ----------
        dof : int
            Rows of the acoustic update (1 or 2).

        Returns
        -------
        window_s : float
            Window length [s]; 0 when the re-linearization is off.
        nis : float
            NIS threshold; inf when off.
        """
        if self.window_probability is None or self.window_s == 0:
            return 0.0, math.inf
        return self.window_s, CHI2_GATE[self.window_probability][dof - 1]

    @property
    def gate(self) -> tuple[float, float]:
        """χ² thresholds (1 dof, 2 dof); infinite without gating."""
        if self.gate_probability is None:
            return math.inf, math.inf
        return CHI2_GATE[self.gate_probability]


def state_names(config: InertialConfig) -> tuple[str, ...]:
    """Names of the state components in order.

    Parameters
    ----------
    config : InertialConfig
        The filter's configuration (which optional states it carries).

    Returns
    -------
    tuple of str
        ``x, y, psi, v, bias`` then ``bias_rate``, ``current_x, current_y``, ``range_scale`` when enabled.
    """
    names = ["x", "y", "psi", "v", "bias"]
    if config.estimate_bias_drift:
        names.append("bias_rate")
    if config.estimate_current:
        names += ["current_x", "current_y"]
    if config.estimate_range_scale:
        names.append("range_scale")
    return tuple(names)


def with_options(config: InertialConfig, **kwargs) -> InertialConfig:
    """``dataclasses.replace`` with validation (for CLI overrides).

    Parameters
    ----------
    config : InertialConfig
        The configuration to start from.
    **kwargs
        Fields of :class:`InertialConfig` to change.

    Returns
    -------
    InertialConfig
        A validated copy with those fields changed.
    """
    return replace(config, **kwargs)
