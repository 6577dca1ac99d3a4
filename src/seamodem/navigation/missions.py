"""The simulated missions of paper 000 §4.1: one mission per filter.

Each mission is a whole boustrophedon path (:class:`~.mission_config.MissionConfig`):
the vehicle follows it with the feedback-linearization controller (eq 2), the
IMU/AHRS and the acoustic frames are emulated from the true geometry with the
noise of :class:`~.mission_config.NoiseModel`, and an estimator runs in the
loop: the paper's 6-state EKF (eq 5–7, 18–25; compiled kernel
:func:`simulate_mission`, pure-Python form :func:`simulate_mission_reference`)
or the inertial filter and its smoothers (:func:`simulate_inertial_mission`).
:mod:`.montecarlo` runs many of them and tabulates the errors.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError
from ._kernels import NOISE_COLUMNS, mission_kernel
from .ekf import ExtendedKalmanFilter
from .ekf_smoother import rts_smooth
from .imu import bias_step, imu_reading
from .mission_config import ALL_FILTERS, FILTERS, INERTIAL_FILTERS, MissionConfig
from .models import Auv6Model, closing_speed
from .paper import EQ25_ORDER
from .vehicle import feedback_command, vehicle_step

__all__ = [
    "mission_noise",
    "simulate_mission",
    "simulate_inertial_mission",
    "held_fix_index",
    "simulate_mission_reference",
]


def mission_noise(seed: int, run: int, n_steps: int) -> np.ndarray:
    """Standard normals of one run, from ``default_rng([seed, run])``.

    Parameters
    ----------
    seed : int
        The Monte Carlo seed.
    run : int
        The run's index.
    n_steps : int
        Simulation steps n of the mission.

    Returns
    -------
    numpy.ndarray, shape (n_steps + 1, 6)
        Standard normals in :data:`~seamodem.navigation._kernels.NOISE_COLUMNS` order.
    """
    return np.random.default_rng([seed, run]).standard_normal((n_steps + 1, len(NOISE_COLUMNS)))


def _start_state(reference: np.ndarray) -> np.ndarray:
    """True initial state: on the path, heading and speed along it."""
    vx, vy = reference[0, 2], reference[0, 3]
    return np.array([reference[0, 0], reference[0, 1], math.atan2(vy, vx), math.hypot(vx, vy)])


def simulate_mission(config: MissionConfig, noise: np.ndarray, *, filter: str = "proposed", reference=None):
    """One mission with the compiled kernel: (error (n+1,), estimate (n+1, 2), truth (n+1, 2)) [m].

    ``estimate`` is the position ``config.error_of`` names: the filter's, the
    smoothed one, or the last frame's held until the next.

    Parameters
    ----------
    config : MissionConfig
        The mission.
    noise : numpy.ndarray, shape (n + 1, 6)
        Its standard normals (:func:`mission_noise`).
    filter : str
        One of :data:`ALL_FILTERS`; the inertial ones go to :func:`simulate_inertial_mission`.
    reference : numpy.ndarray, optional
        The desired path (:meth:`MissionConfig.reference`), computed when not given.

    Returns
    -------
    error : numpy.ndarray, shape (n + 1,)
        Position error at each step [m].
    estimate, truth : numpy.ndarray, shape (n + 1, 2)
        Estimated and true positions [m].
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

    Parameters
    ----------
    config : MissionConfig
        The mission (``error_of`` must be "estimate").
    noise : numpy.ndarray, shape (n + 1, 6)
        Its standard normals (:func:`mission_noise`).
    filter : str
        One of :data:`INERTIAL_FILTERS`.
    reference : numpy.ndarray, optional
        The desired path (:meth:`MissionConfig.reference`), computed when not given.

    Returns
    -------
    error : numpy.ndarray, shape (n + 1,)
        Position error at each step [m].
    estimate, truth : numpy.ndarray, shape (n + 1, 2)
        Estimated and true positions [m].
    details : dict
        As above.
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
    """Index of the last frame step at or before each step 0…n (step 0: the start fix).

    Parameters
    ----------
    n_steps : int
        Simulation steps n.
    com_every : int
        Steps per acoustic frame.

    Returns
    -------
    numpy.ndarray, shape (n_steps + 1,)
        The step index of the fix held at each step.
    """
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

    Parameters
    ----------
    config : MissionConfig
        The mission (``error_of`` "estimate" or "last_fix").
    noise : numpy.ndarray, shape (n + 1, 6)
        Its standard normals (:func:`mission_noise`).
    filter : {"proposed", "rosb"}
        The paper's filter.
    reference : numpy.ndarray, optional
        The desired path (:meth:`MissionConfig.reference`), computed when not given.
    filter_factory : callable, optional
        As above; default :class:`~seamodem.navigation.ekf.ExtendedKalmanFilter`.

    Returns
    -------
    error : numpy.ndarray, shape (n + 1,)
        Position error at each step [m].
    estimate, truth : numpy.ndarray, shape (n + 1, 2)
        Estimated and true positions [m].
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
