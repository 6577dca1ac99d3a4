"""Compiled mission loop with the inertial filter in the loop (the controller can steer on its estimate).

The vehicle, the controller and the sensors are paper 000's simulation exactly
as in :func:`seamodem.navigation._kernels.mission_kernel`, fed by the same
standard normals (common random numbers with the paper's filters), plus two
truths that kernel does not have: a water current and a range scale (a sound
speed error). The filter is :mod:`.inertial`'s, step for step the same kernels
as :func:`~seamodem.navigation.inertial.filter.filter_nodes`: the tests hold the
estimate equal to a filter pass over the recorded sensor streams.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .imu import bias_step, imu_reading
from .inertial.charts import cartesian, to_internal, wrap
from .inertial.filter import record_prior
from .inertial.kernels import relinearize_window, window_start
from .inertial.models import predict
from .inertial.records import NodeData, Track, workspace
from .inertial.updates import floor_speed, gated_acoustic, gated_bearing, update_heading
from .vehicle import feedback_command, vehicle_step

__all__ = ["InertialMission", "inertial_mission_kernel"]


class InertialMission(NamedTuple):
    """The simulated world of one mission: the vehicle, its controller, its sensors, the truths.

    Parameters
    ----------
    reference : ndarray, shape (n + 1, 6)
        Desired x, y, ẋ, ẏ, ẍ, ÿ at t = k·dt [m, m/s, m/s²].
    noise : ndarray, shape (n + 1, 6)
        Standard normals, columns as :data:`~seamodem.navigation._kernels.NOISE_COLUMNS`.
    start : ndarray, shape (4,)
        True initial (x, y, ψ, v) [m, m, rad, m/s].
    start_offsets : ndarray, shape (4,)
        Filter start minus true start in x, y [m] and speed [m/s], and the true initial heading bias [rad].
    sigmas : ndarray, shape (6,)
        Sensor noise standard deviations per step (:meth:`~seamodem.navigation.mission_config.NoiseModel.sigmas`).
    dt : float
        IMU step [s].
    com_every : int
        A frame every ``com_every`` steps.
    steer_on_estimate : bool
        The controller steers on the filter's estimate (else on the truth).
    v_min, v_max : float
        Speed limits of the vehicle [m/s].
    omega_max, accel_max : float
        Command limits [rad/s, m/s²].
    current : ndarray, shape (2,)
        True water current [m/s].
    range_scale : float
        True range and v_r scale − 1.
    bias_rate : float
        True heading-bias drift rate [rad/s] (added to the random walk of ``sigmas[3]``).
    bearing_sigma : float
        Standard deviation of the beacon's body-frame azimuth per frame [rad] (a hydrophone array, issue 17);
        0: no array. Its normal is ``noise[k − 1, 5]``, the v_r column of the step before the frame, which no
        kernel uses when ``com_every`` ≥ 2: the runs without an array see the same numbers.
    heading_var : float
        The filter's variance of a heading reading [rad²].
    meas_var : ndarray, shape (2,)
        The filter's variances of range and v_r [m², m²/s²].
    """

    reference: np.ndarray
    noise: np.ndarray
    start: np.ndarray
    start_offsets: np.ndarray
    sigmas: np.ndarray
    dt: float
    com_every: int
    steer_on_estimate: bool
    v_min: float
    v_max: float
    omega_max: float
    accel_max: float
    current: np.ndarray
    range_scale: float
    bias_rate: float
    bearing_sigma: float
    heading_var: float
    meas_var: np.ndarray


@njit(cache=True, nogil=True)
def inertial_mission_kernel(mission, z0, P0, lay, model, settings, sensors):
    """Run one mission with the inertial filter in the loop.

    Parameters
    ----------
    mission : InertialMission
        The vehicle, its controller, its sensors and the truths.
    z0, P0 : ndarray, shapes (m,), (m, m)
        Cartesian filter start (the position, speed and bias parts; the heading is set from the step-0
        reading); converted to the filter's chart (``lay[4]``) inside.
    lay : ndarray, shape (5,), int64
        State layout (:attr:`~seamodem.navigation.inertial.InertialConfig.layout`).
    model : FilterModel
        The filter's process noise density, the beacon, the acoustic rows (range always).
    settings : FilterSettings
        Gates, iterations, window re-linearization (``window_s`` 0: off), speed floor (−∞: none).
    sensors : ndarray, shape (n + 1, 6)
        Output: heading, gyro, accelerometer readings, range, v_r and body azimuth (NaN without a frame, or
        without an array).

    Returns
    -------
    error : ndarray, shape (n + 1,)
        Position error of the estimate [m].
    estimate, truth : ndarray, shape (n + 1, 2)
        Estimated and true positions [m].
    status : ndarray, shape (n + 1,), int8
        0 no frame, 1 accepted, 2 gated, 3 accepted after a run of gated frames.
    nis : ndarray, shape (n + 1,)
        NIS of each frame (NaN elsewhere).
    """
    reference, noise, start, start_offsets, sigmas = (mission.reference, mission.noise, mission.start,
                                                       mission.start_offsets, mission.sigmas)
    dt, com_every, current = mission.dt, mission.com_every, mission.current
    v_min, v_max, omega_max, accel_max = mission.v_min, mission.v_max, mission.omega_max, mission.accel_max
    bearing_sigma, heading_var, meas_var = mission.bearing_sigma, mission.heading_var, mission.meas_var
    steer_on_estimate, range_scale, bias_rate = mission.steer_on_estimate, mission.range_scale, mission.bias_rate
    beacon = model.beacon
    window_s, window_nis = settings.window_s, settings.window_nis
    n = reference.shape[0] - 1
    m = z0.shape[0]
    error = np.empty(n + 1)
    estimate = np.empty((n + 1, 2))
    truth = np.empty((n + 1, 2))
    status = np.zeros(n + 1, dtype=np.int8)
    nis_out = np.full(n + 1, np.nan)
    z = z0.copy()
    P = P0.copy()
    lay = lay.copy()  # lay[4], the current chart, changes along the mission
    ws = workspace(m)
    meas = np.empty(2)
    # the window re-linearization needs the filter's history and the sensors as nodes (filter_nodes' layout)
    window = window_s > 0
    N = n + 1 if window else 1
    track = Track(np.empty((N, m)), np.empty((N, m, 3 * m + 1)), np.zeros(N, dtype=np.int8))
    states, history = track.states, track.history
    dts = np.full(N, dt)
    has_heading = np.ones(N, dtype=np.bool_)
    has_heading[0] = False  # the start holds step 0's reading
    heading_var_n = np.full(N, heading_var)
    used_frame = np.zeros(N, dtype=np.bool_)
    used_bearing = np.zeros(N, dtype=np.bool_)
    meas_n = np.zeros((N, 2))
    meas_var_n = np.empty((N, 2))
    meas_var_n[:, 0], meas_var_n[:, 1] = meas_var[0], meas_var[1]
    no_fix = np.zeros(N, dtype=np.bool_)
    fix_n = np.zeros((N, 2))
    fix_var_n = np.ones(N)
    bearing_n = np.zeros(N)
    bearing_var_n = np.full(N, max(bearing_sigma, 1e-9) ** 2)
    # the nodes' own contiguous copies of the readings (not views of ``sensors``' columns): the kernels then see
    # the same array types as from filter_nodes, and numba compiles them once, not twice (~30 s cold)
    heading_n, omega_n, accel_n = np.zeros(N), np.zeros(N), np.zeros(N)
    nodes = NodeData(dts, omega_n, accel_n, has_heading, heading_n, heading_var_n, used_frame, meas_n,
                     meas_var_n, no_fix, fix_n, fix_var_n, used_bearing, bearing_n, bearing_var_n)
    x, y, psi, v = start[0], start[1], start[2], start[3]
    z[0] = x + start_offsets[0]
    z[1] = y + start_offsets[1]
    z[3] = v + start_offsets[2]
    bias = start_offsets[3]
    heading0 = psi + bias + sigmas[0] * noise[0, 0]
    z[2] = heading0 - z[4]  # P0 is the prior after this reading (InertialConfig.initial)
    to_internal(z, P, lay, beacon)  # z0, P0 come Cartesian
    sensors[0, 0] = heading_n[0] = heading0
    sensors[0, 1] = sensors[0, 2] = 0.0
    sensors[0, 3] = sensors[0, 4] = np.nan
    if window:
        record_prior(np.int64(0), z, P, None, lay, track)  # a typed 0: no literal-0 specialization
    ex, ey = cartesian(z, lay, beacon)
    estimate[0, 0], estimate[0, 1] = ex, ey
    truth[0, 0], truth[0, 1] = x, y
    error[0] = np.sqrt((ex - x) ** 2 + (ey - y) ** 2)
    gated_run = np.int64(0)  # typed, not literal 0: gated_acoustic/gated_bearing compile once
    bearing_gated = np.int64(0)
    sensors[0, 5] = np.nan
    scale = 1.0 + range_scale
    sx, sy, spsi, sv = (ex, ey, z[2], z[3]) if steer_on_estimate else (x, y, psi, v)
    omega, accel = feedback_command(sx, sy, spsi, sv, reference[0, 0], reference[0, 1], reference[0, 2],
                                    reference[0, 3], reference[0, 4], reference[0, 5], v_min, omega_max, accel_max)
    for k in range(1, n + 1):
        v_old = v
        x, y, psi, v = vehicle_step(x, y, psi, v, omega, accel, dt, v_min, v_max)
        x += current[0] * dt
        y += current[1] * dt
        accel_true = (v - v_old) / dt
        bias = bias_step(bias, sigmas, noise, k, bias_rate, dt)
        head_m, omega_m, accel_m = imu_reading(psi, bias, omega, accel_true, sigmas, noise, k)
        sensors[k, 0], sensors[k, 1], sensors[k, 2] = head_m, omega_m, accel_m
        if window:
            heading_n[k], omega_n[k], accel_n[k] = head_m, omega_m, accel_m
        sensors[k, 3] = sensors[k, 4] = sensors[k, 5] = np.nan
        predict(z, P, lay, model, omega_m, accel_m, dt, ws)
        if window:
            record_prior(k, z, P, ws.F, lay, track)
        if k % com_every == 0:
            dx, dy = x - beacon[0], y - beacon[1]
            d_true = np.sqrt(dx * dx + dy * dy)
            gx, gy = v * np.cos(psi) + current[0], v * np.sin(psi) + current[1]
            vr_true = -(dx * gx + dy * gy) / d_true
            meas[0] = scale * d_true + sigmas[4] * noise[k, 4]
            meas[1] = scale * vr_true + sigmas[5] * noise[k, 5]
            sensors[k, 3], sensors[k, 4] = meas[0], meas[1]
            nis_out[k], status[k], gated_run = gated_acoustic(z, P, lay, model, settings, meas, meas_var, gated_run,
                                                              ws)
        update_heading(z, P, head_m, heading_var, ws.ph)
        if bearing_sigma > 0 and k % com_every == 0:
            # after the heading update, as filter_nodes orders a node's measurements
            az = wrap(np.arctan2(beacon[1] - y, beacon[0] - x) - psi + bearing_sigma * noise[k - 1, 5])
            sensors[k, 5] = az
            _, b_status, bearing_gated = gated_bearing(z, P, lay, model, settings, az, bearing_sigma * bearing_sigma,
                                                       bearing_gated, ws)
            if window:
                bearing_n[k] = az
                used_bearing[k] = b_status != 2
        floor_speed(z, P, settings.v_floor)
        if window:
            states[k] = z
            history[k, :, m + 1:2 * m + 1] = P
            if k % com_every == 0 and status[k] != 2:
                used_frame[k] = True
                meas_n[k, 0], meas_n[k, 1] = sensors[k, 3], sensors[k, 4]
                i0 = window_start(k, dts, window_s) if nis_out[k] > window_nis else k
                if i0 < k:
                    relinearize_window(i0, k, track, lay, model, settings, nodes, z, P)
        ex, ey = cartesian(z, lay, beacon)
        estimate[k, 0], estimate[k, 1] = ex, ey
        truth[k, 0], truth[k, 1] = x, y
        error[k] = np.sqrt((ex - x) ** 2 + (ey - y) ** 2)
        sx, sy, spsi, sv = (ex, ey, z[2], z[3]) if steer_on_estimate else (x, y, psi, v)
        omega, accel = feedback_command(sx, sy, spsi, sv, reference[k, 0], reference[k, 1], reference[k, 2],
                                        reference[k, 3], reference[k, 4], reference[k, 5], v_min, omega_max,
                                        accel_max)
    return error, estimate, truth, status, nis_out
