"""Track a vehicle from the receiver's measurement records and IMU/AHRS samples (``seamodem nav track``).

The measurement CSV is read by column name (SPEC §4 record: ``frame_index,
t_emit_s, t_arrival_s, tof_s, range_m, v_r_mps, snr_db`` plus optional
``range_std_m, v_r_std_mps``, or ``sigma_range_m, sigma_v_r_mps`` as ``seamodem rx`` writes them); lines starting with ``#`` are header comments.
This module does not import the receiver: any program that writes those
columns can feed it.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputFileError
from ..io.files import atomic_outputs, check_writable
from .ekf import ExtendedKalmanFilter
from .geometry import geodetic_to_local, local_to_geodetic, slant_to_horizontal
from .logs import parse_pair as _pair, read_columns
from .models import Auv6Model
from .smoother import rts_smooth

__all__ = ["MEASUREMENT_COLUMNS", "IMU_COLUMNS", "read_columns", "run_track", "track_from_files"]

MEASUREMENT_COLUMNS = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db")
IMU_COLUMNS = ("t_s", "heading_rad", "omega_rad_s", "accel_mps2")
TRUTH_COLUMNS = ("t_s", "x_m", "y_m")

#: Paper 000 eq 25, by component.
EQ25_R = {"range": 12.0, "v_r": 0.2, "psi": 1.0, "omega": 0.005, "a": 0.005}


def run_track(meas: dict, imu: dict, *, beacon_xy, start_xy, start_speed_mps=0.0, filter="proposed",
              r_from_records=False, depths=None, smooth=False) -> dict:
    """6-state EKF (paper 000) over IMU samples and acoustic records, each fused at its own time.

    Parameters
    ----------
    meas : dict of ndarray
        Columns of :data:`MEASUREMENT_COLUMNS` (and optionally ``range_std_m``, ``v_r_std_mps``).
    imu : dict of ndarray
        Columns of :data:`IMU_COLUMNS`, strictly increasing ``t_s``.
    beacon_xy, start_xy : (float, float)
        Local positions [m].
    filter : {"proposed", "rosb"}
        With or without the v_r update.
    r_from_records : bool
        R of range and v_r from each record's standard deviations (SNR-dependent)
        instead of eq 25's fixed 12 m² and 0.2 m²/s².
    depths : (float, float), optional
        Vehicle and beacon depths [m]: slant ranges become horizontal (paper 004 eq 10).
    smooth : bool
        Replace the filtered states by the Rauch–Tung–Striebel smoothed ones
        (:func:`~seamodem.navigation.smoother.rts_smooth`): each state then uses
        the frames after it as well (post-processing, not real time).

    Returns
    -------
    dict with ``t_s`` (n,), ``state`` (n, 6), ``cov`` (n, 6, 6): the state after each event.
    """
    if filter not in ("proposed", "rosb"):
        raise ConfigError("filter", f"must be 'proposed' or 'rosb', got {filter!r}")
    if r_from_records and not {"range_std_m", "v_r_std_mps"} <= set(meas):
        raise ConfigError("r_from_records", "needs columns range_std_m and v_r_std_mps in the measurement file")
    ranges = meas["range_m"] if depths is None else slant_to_horizontal(meas["range_m"], *depths)
    model = Auv6Model(beacon_xy)
    x0 = [start_xy[0], start_xy[1], imu["heading_rad"][0], start_speed_mps, 0.0, 0.0]
    ekf = ExtendedKalmanFilter(model, x0, np.eye(6), lambda dt: dt**8 * np.eye(6), t0_s=float(imu["t_s"][0]))
    # Events in time order; at equal times the IMU sample comes first (kind 0 < 1).
    times = np.r_[imu["t_s"], meas["t_arrival_s"]]
    kinds = np.r_[np.zeros(imu["t_s"].size, int), np.ones(ranges.size, int)]
    rows = np.r_[np.arange(imu["t_s"].size), np.arange(ranges.size)]
    order = np.lexsort((kinds, times))
    order = order[times[order] >= ekf.t]
    R_ahrs = [EQ25_R["psi"], EQ25_R["omega"], EQ25_R["a"]]
    t_out, states, covs = [], [], []
    priors, prior_covs, jacobians = [], [], []
    for e in order:
        t, i = times[e], rows[e]
        ekf.predict(t)
        if smooth:
            priors.append(ekf.state)
            prior_covs.append(ekf.covariance)
            jacobians.append(ekf.F.copy())
        if kinds[e] == 0:
            ekf.update([imu["heading_rad"][i], imu["omega_rad_s"][i], imu["accel_mps2"][i]], "ahrs", R_ahrs)
        else:
            r_d = meas["range_std_m"][i] ** 2 if r_from_records else EQ25_R["range"]
            ekf.update([ranges[i]], "range", r_d)
            if filter == "proposed":
                r_v = meas["v_r_std_mps"][i] ** 2 if r_from_records else EQ25_R["v_r"]
                ekf.update([meas["v_r_mps"][i]], "v_r", r_v)
        t_out.append(t)
        states.append(ekf.state)
        covs.append(ekf.covariance)
    if smooth and states:
        state, cov = rts_smooth(np.array(states), np.array(covs), np.array(priors), np.array(prior_covs),
                                np.array(jacobians))
        return {"t_s": np.array(t_out), "state": state, "cov": cov}
    return {"t_s": np.array(t_out), "state": np.array(states), "cov": np.array(covs)}


def track_from_files(measurements, imu, *, beacon, start, start_speed_mps=0.0, geodetic=False, depths=None,
                     filter="proposed", r_from_records=False, smooth=False, truth=None, output) -> str:
    """Read, track, write OUT.csv, OUT.png (and OUT.json with --truth); return a one-paragraph summary."""
    out = check_writable(output)
    if out.suffix.lower() != ".csv":
        raise ConfigError("output", f"must be a .csv path, got {str(out)!r}")
    beacon_pair = _pair(beacon, "beacon")
    start_pair = _pair(start, "start")
    if geodetic:
        origin = beacon_pair
        beacon_xy = (0.0, 0.0)
        start_xy = tuple(float(v) for v in geodetic_to_local(*start_pair, *origin))
    else:
        beacon_xy, start_xy = beacon_pair, start_pair
    meas = read_columns(measurements, MEASUREMENT_COLUMNS,
                        optional=("range_std_m", "v_r_std_mps", "sigma_range_m", "sigma_v_r_mps"),
                        time_column="t_arrival_s", what="measurement file")
    # seamodem rx writes the per-frame standard deviations as sigma_range_m, sigma_v_r_mps
    for ours, theirs in (("range_std_m", "sigma_range_m"), ("v_r_std_mps", "sigma_v_r_mps")):
        if ours not in meas and theirs in meas:
            meas[ours] = meas[theirs]
    samples = read_columns(imu, IMU_COLUMNS, time_column="t_s", what="IMU file")
    truth_cols = read_columns(truth, TRUTH_COLUMNS, time_column="t_s", what="truth file") if truth else None
    result = run_track(meas, samples, beacon_xy=beacon_xy, start_xy=start_xy, start_speed_mps=start_speed_mps,
                       filter=filter, r_from_records=r_from_records, depths=depths, smooth=smooth)
    t, state, cov = result["t_s"], result["state"], result["cov"]
    columns = {"t_s": t, "x_m": state[:, 0], "y_m": state[:, 1], "heading_rad": state[:, 2],
               "speed_mps": state[:, 3], "var_x_m2": cov[:, 0, 0], "cov_xy_m2": cov[:, 0, 1], "var_y_m2": cov[:, 1, 1]}
    if geodetic:
        columns["lat_deg"], columns["lon_deg"] = local_to_geodetic(state[:, 0], state[:, 1], *origin)
    stats = None
    truth_xy = None
    if truth_cols is not None:
        truth_xy = np.c_[np.interp(t, truth_cols["t_s"], truth_cols["x_m"]), np.interp(t, truth_cols["t_s"], truth_cols["y_m"])]
        inside = (t >= truth_cols["t_s"][0]) & (t <= truth_cols["t_s"][-1])
        err = np.hypot(*(state[inside, :2] - truth_xy[inside]).T)
        if err.size == 0:
            raise InputFileError(f"truth file {truth}: its times do not overlap the track")
        stats = {"mean_error_m": float(err.mean()), "rms_error_m": float(np.sqrt(np.mean(err**2))),
                 "max_error_m": float(err.max()), "error_variance_m2": float(err.var()), "n_points": int(err.size)}
    from .figures import plot_track

    targets = [out, out.with_suffix(".png")] + ([out.with_suffix(".json")] if stats else [])
    with atomic_outputs(*targets) as temps:
        with open(temps[0], "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(columns)
            writer.writerows(zip(*(np.round(v, 9) for v in columns.values())))
        plot_track(t, state[:, :2], temps[1], beacon_xy=beacon_xy, sigma_xy=np.sqrt(np.c_[cov[:, 0, 0], cov[:, 1, 1]]),
                   truth_xy=truth_xy, title=f"{filter}{' (RTS-smoothed)' if smooth else ''}: {meas['range_m'].size} frames, {samples['t_s'].size} IMU samples")
        if stats:
            Path(temps[2]).write_text(json.dumps({"filter": filter, "smoothed": bool(smooth), **stats}, indent=1) + "\n", encoding="utf-8")
    text = f"wrote {out} ({t.size} states) and {out.with_suffix('.png')}"
    if stats:
        text += (f"; error vs truth: mean {stats['mean_error_m']:.2f} m, RMS {stats['rms_error_m']:.2f} m, "
                 f"max {stats['max_error_m']:.2f} m (in {out.with_suffix('.json')})")
    return text
