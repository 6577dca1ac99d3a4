"""Track a vehicle from the receiver's measurement records and IMU/AHRS samples (``seamodem nav track``).

Four filters:

- ``"inertial"`` (default for tracks from real records): the inertial beacon filter of
  :mod:`.inertial` -- the IMU's gyro and accelerometer drive the motion model with process
  noise from their noise densities, the heading sensor measures heading + bias, the bias is
  a state, each acoustic frame (range and v_r) is an iterated update gated on its
  normalised innovation (a gated frame is reported in the frame table, not used).
  Optionally smoothed over the whole mission (:func:`~.inertial.smoothers.batch_smooth`) or over a
  fixed lag (:func:`~.inertial.smoothers.fixed_lag_smooth`).
- ``"inertial-range"``: the same with range only (no v_r update).
- ``"proposed"``, ``"rosb"``: paper 000's 6-state EKF with and without v_r, with its
  R (eq 25) and Q = Δt⁸: kept exactly as published so that Tables 3-4 stay
  reproducible (paper-faithful, not recommended for centimetre-grade records:
  told how good the measurements are it diverges, docs/navigation.md).

Measurement noise of the inertial filters (R). By default each record's own
``sigma_range_m`` / ``sigma_v_r_mps`` (what ``seamodem rx`` writes; ``range_std_m`` /
``v_r_std_mps`` are accepted too), raised to a floor:

- :data:`RANGE_FLOOR_M` = 1 cm. The receiver's σ is its Cramér-Rao bound at the
  measured SNR inflated by what the frame shows; it cannot see the errors that come
  from outside the waveform: 1 µs of clock synchronisation is 1.5 mm, a 0.1 % error of
  the sound speed is 10 cm at 100 m, the transducers' offsets from the navigation
  reference are millimetres to centimetres. Measured on ``seamodem demo``'s 51
  decoded frames (seed 1, exact sound speed and clocks, errors against the geometric
  truth): range error RMS 3.3 mm, max 8.4 mm, records' σ median 1.6 mm; |error| ≤ 3σ
  in 84 % of the frames with the records' σ alone (SPEC §4 asks ≈ 99 %), 92 % with a
  2 mm floor, 100 % with 5 mm and 1 cm. 1 cm keeps that margin when the sound speed
  or the clocks are less perfect than in the demo.
- :data:`V_R_FLOOR_MPS` = 5 cm/s. The receiver's v_r σ is a CRLB of the tone's
  frequency (median 1.2 mm/s on the demo), while the direct path's closing speed
  differs from the tone's by the multipath Doppler spread and the vehicle's motion
  during the frame (SPEC §1). On the same frames the v_r error is 4.6 cm/s RMS (max
  21 cm/s): |error| ≤ 3σ in 6 % of the frames with the records' σ, 71 % with a 1 cm/s
  floor, 86 % with 2 cm/s, 98 % with 5 cm/s. With a 1 cm/s floor the filter gates two
  good frames of the demo and its mean error is 0.40 m; with 5 cm/s none, 0.24 m.

Records without σ columns use ``sigma_range_m`` / ``sigma_v_r_mps`` (defaults
:data:`DEFAULT_SIGMA_RANGE_M` = 5 cm, :data:`DEFAULT_SIGMA_V_R_MPS` = 5 cm/s: a
receiver of this kind at moderate SNR with unknown sound speed to 0.05 %); given
explicitly they override the records' σ as well. Rows whose σ is NaN use them too.

The measurement CSV is read by column name (SPEC §4 record: ``frame_index,
t_emit_s, t_arrival_s, tof_s, range_m, v_r_mps, snr_db`` plus optional
``sigma_range_m, sigma_v_r_mps``); lines starting with ``#`` are header comments.
This module does not import the receiver: any program that writes those
columns can feed it.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputFileError
from ..io.files import atomic_outputs, check_writable
from .ekf import ExtendedKalmanFilter
from .geometry import local_to_geodetic, slant_to_horizontal
from .logs import (LogWarning, depth_at, parse_pair as _pair, parse_position, read_columns, read_depth,
                   read_fixes, read_imu, read_measurements)
from .models import Auv6Model
from .paper import EQ25_R, eq25_q, eq25_r_text
from .ekf_smoother import rts_smooth

__all__ = ["MEASUREMENT_COLUMNS", "IMU_COLUMNS", "FILTERS", "SMOOTHERS", "RANGE_FLOOR_M", "V_R_FLOOR_MPS",
           "DEFAULT_SIGMA_RANGE_M", "DEFAULT_SIGMA_V_R_MPS", "BEARING_FLOOR_RAD", "FRAME_STATUS", "read_columns", "run_track",
           "track_from_files"]

MEASUREMENT_COLUMNS = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db")
IMU_COLUMNS = ("t_s", "heading_rad", "omega_rad_s", "accel_mps2")
TRUTH_COLUMNS = ("t_s", "x_m", "y_m")
FILTERS = ("inertial", "inertial-range", "proposed", "rosb")
SMOOTHERS = (None, "batch", "fixed-lag")
#: Floors of the records' σ for the inertial filters (module notes).
RANGE_FLOOR_M = 0.01
V_R_FLOOR_MPS = 0.05
#: σ of records that carry none (module notes).
DEFAULT_SIGMA_RANGE_M = 0.05
DEFAULT_SIGMA_V_R_MPS = 0.05
#: Floor of a record's bearing σ: the receiver's σ is the CRLB at the frame's SNR (0.1–0.2° at 12 dB on an
#: 8 cm array), but the bearing also carries the array's mounting alignment to the heading sensor and the
#: elements' position errors (±2 mm: 1.2° RMS uncalibrated, docs/array.md); 0.5° for a calibrated array.
BEARING_FLOOR_RAD = math.radians(0.5)
#: Bearing σ for records that carry an azimuth without its σ.
DEFAULT_SIGMA_BEARING_RAD = math.radians(2.0)
#: Frame status in the frame table: the filter's codes, and frames outside the IMU's time span.
FRAME_STATUS = {0: "not_used", 1: "accepted", 2: "gated", 3: "accepted_after_gates", -1: "outside_imu"}
#: χ² with 2 degrees of freedom at 95 %: the error ellipse that should hold the truth 95 % of the time.
CHI2_2DOF_95 = 5.991464547107979



def _warn(message: str) -> None:
    import warnings

    warnings.warn(message, LogWarning, stacklevel=3)


def normalise_sigma_columns(meas: dict) -> dict:
    """Records' σ under the names ``seamodem rx`` writes (``range_std_m`` → ``sigma_range_m``...)."""
    meas = dict(meas)
    for theirs, ours in (("range_std_m", "sigma_range_m"), ("v_r_std_mps", "sigma_v_r_mps")):
        if ours not in meas and theirs in meas:
            meas[ours] = meas[theirs]
    return meas


def horizontal_ranges(meas: dict, depths, depth_log, beacon_depth_m, profile=None) -> np.ndarray:
    ranges = np.asarray(meas["range_m"], dtype=float)
    if depths is not None and depth_log is not None:
        raise ConfigError("depths", "give either fixed depths or a depth log, not both")
    if depths is None and depth_log is None:
        if profile is not None:
            raise ConfigError("sound_speed_profile", "needs the depths of both ends (--depth or --depth-log)")
        return ranges
    vehicle, beacon = depths if depths is not None else (depth_at(depth_log, meas["t_arrival_s"]), beacon_depth_m)
    if profile is None:
        return slant_to_horizontal(ranges, vehicle, beacon)
    from ..water.ranging import ProfileRanging  # travel time along the traced ray → horizontal range

    vehicle = np.broadcast_to(np.asarray(vehicle, dtype=float), ranges.shape)
    return ProfileRanging.for_records(profile, beacon, vehicle, meas["tof_s"]).horizontal_range(meas["tof_s"], vehicle)


def check_positive(name, value):
    if not (value is not None and math.isfinite(value) and value > 0):
        raise ConfigError(name, f"must be a finite number > 0, got {value!r}")


def run_track(meas: dict, imu: dict, *, beacon_xy, start_xy, start_speed_mps=0.0, filter="inertial",
              r_from_records=False, depths=None, depth_log=None, beacon_depth_m=0.0, sound_speed_profile=None,
              smooth=None, lag_s=None,
              config=None, range_floor_m=RANGE_FLOOR_M, v_r_floor_mps=V_R_FLOOR_MPS, sigma_range_m=None,
              sigma_v_r_mps=None, start_sigma_m=1.0, fixes=None, use_bearing=True,
              bearing_floor_rad=BEARING_FLOOR_RAD) -> dict:
    """Track from IMU samples and acoustic records, each fused at its own time.

    Parameters
    ----------
    meas : dict of ndarray
        Columns of :data:`MEASUREMENT_COLUMNS`, sorted by ``t_arrival_s``; optionally ``sigma_range_m``,
        ``sigma_v_r_mps`` (or ``range_std_m``, ``v_r_std_mps``).
    imu : dict of ndarray
        Columns of :data:`IMU_COLUMNS`, strictly increasing ``t_s`` at any spacing; optionally
        ``heading_std_rad`` (per-sample heading σ, inertial filters).
    beacon_xy, start_xy : (float, float)
        Local positions [m].
    start_speed_mps : float
        Initial speed [m/s]. The start heading is the first IMU heading reading.
    filter : {"inertial", "inertial-range", "proposed", "rosb"}
        The inertial filter with range and v_r (default) or range only, or paper 000's EKF (``"proposed"``)
        and its range-only baseline (``"rosb"``), paper-faithful (module notes).
    r_from_records : bool
        Paper filters: R of range and v_r from each record's σ instead of eq 25's 12 m² and 0.2 m²/s². The
        inertial filters use the records' σ by default; for them the flag changes nothing.
    depths : (float, float), optional
        Vehicle and beacon depths [m]: slant ranges become horizontal (paper 004 eq 10).
    depth_log : dict, optional
        ``t_s``, ``depth_m`` of the vehicle (:func:`~.logs.read_depth`): each frame's slant range becomes
        horizontal with the vehicle's depth at its arrival time and ``beacon_depth_m``.
    sound_speed_profile : SoundSpeedProfile, optional
        With the depths: each frame's ``tof_s`` becomes the horizontal range of the direct ray traced
        through it (:class:`~seamodem.water.ranging.ProfileRanging`) instead of ``range_m`` made horizontal.
    smooth : {None, "batch", "fixed-lag"} or bool
        Inertial filters: the batch smoother over the whole mission or the fixed-lag smoother (``lag_s``).
        Paper filters: ``True`` or ``"batch"`` is their Rauch-Tung-Striebel smoother (as before).
    lag_s : float
        Latency of the fixed-lag smoother [s].
    config : InertialConfig, optional
        Sensor noise densities, optional states and gating (default: the paper's IMU).
    range_floor_m, v_r_floor_mps : float
        Floors of the records' σ (module notes); σ used = max(record σ, floor).
    sigma_range_m, sigma_v_r_mps : float, optional
        σ of every frame, overriding the records' (default: the records' σ, or
        :data:`DEFAULT_SIGMA_RANGE_M`, :data:`DEFAULT_SIGMA_V_R_MPS` when they carry none).
    start_sigma_m : float
        1-σ error of the start position per axis [m] (a GNSS fix: 1 m by default).
    fixes : dict, optional
        Later position fixes ``t_s``, ``x_m``, ``y_m``, ``sigma_m`` (GNSS at the surface; inertial filters).
    use_bearing : bool
        Inertial filters: use the records' ``azimuth_body_rad`` (a hydrophone array) when they have it, with
        σ = max(``sigma_azimuth_body_rad`` (or :data:`DEFAULT_SIGMA_BEARING_RAD`), ``bearing_floor_rad``).

    Returns
    -------
    dict with ``t_s`` (N,), ``state`` (N, n), ``cov`` (N, n, n) after each event, ``names`` (the state
    components), ``frames`` (per record: ``frame_index``, ``t_arrival_s``, ``status`` (text,
    :data:`FRAME_STATUS`), ``nis``, ``sigma_range_m``, ``sigma_v_r_mps`` used) and ``settings`` (what was
    used, for the sidecar). Inertial filters add ``run`` (the :class:`~.inertial.FilterRun`).
    """
    if filter not in FILTERS:
        raise ConfigError("filter", f"must be one of {', '.join(FILTERS)}, got {filter!r}")
    if smooth is True:
        smooth = "batch"
    elif smooth is False:
        smooth = None
    if smooth not in SMOOTHERS:
        raise ConfigError("smooth", f"must be None, 'batch' or 'fixed-lag', got {smooth!r}")
    meas = normalise_sigma_columns(meas)
    ranges = horizontal_ranges(meas, depths, depth_log, beacon_depth_m, sound_speed_profile)
    if filter in ("proposed", "rosb"):
        if smooth == "fixed-lag":
            raise ConfigError("smooth", f"the fixed-lag smoother needs an inertial filter, not {filter!r}")
        if fixes is not None and len(fixes["t_s"]):
            raise ConfigError("fixes", f"GNSS fixes need an inertial filter, not {filter!r}")
        if r_from_records:
            for c in ("sigma_range_m", "sigma_v_r_mps"):
                if c not in meas:
                    raise ConfigError("r_from_records", "needs columns sigma_range_m and sigma_v_r_mps "
                                                        "(or range_std_m, v_r_std_mps) in the measurement file")
                if not np.all(np.isfinite(meas[c])):
                    raise ConfigError("r_from_records", f"column {c} has NaN values")
        paper_meas = {**meas, "range_m": ranges, "range_std_m": meas.get("sigma_range_m"),
                      "v_r_std_mps": meas.get("sigma_v_r_mps")}
        out = _paper_track(paper_meas, imu, beacon_xy=beacon_xy, start_xy=start_xy,
                           start_speed_mps=start_speed_mps, filter=filter, r_from_records=r_from_records,
                           smooth=smooth == "batch")
        n = ranges.size
        sr = np.sqrt(EQ25_R["range"]) * np.ones(n) if not r_from_records else meas["sigma_range_m"]
        sv = np.sqrt(EQ25_R["v_r"]) * np.ones(n) if not r_from_records else meas["sigma_v_r_mps"]
        t_imu = np.asarray(imu["t_s"], dtype=float)
        inside = np.asarray(meas["t_arrival_s"]) >= t_imu[0]
        out["names"] = ("x", "y", "psi", "v", "omega", "a")
        out["frames"] = {"frame_index": np.asarray(meas["frame_index"]), "t_arrival_s": np.asarray(meas["t_arrival_s"]),
                         "status": np.where(inside, FRAME_STATUS[1], FRAME_STATUS[-1]), "nis": np.full(n, np.nan),
                         "sigma_range_m": sr, "sigma_v_r_mps": sv if filter == "proposed" else np.full(n, np.nan)}
        out["settings"] = {"filter": filter, "description": "paper 000 6-state EKF, Q = Δt⁸ I6, R = "
                           + ("records' σ" if r_from_records else f"eq 25 {eq25_r_text()}")
                           + " (paper-faithful)", "smoother": "rts" if smooth else None,
                           "r_from_records": bool(r_from_records), "depths_m": list(depths) if depths else None}
        return out
    return _inertial_track(meas, ranges, imu, beacon_xy=beacon_xy, start_xy=start_xy,
                           start_speed_mps=start_speed_mps, use_vr=filter == "inertial", smooth=smooth, lag_s=lag_s,
                           config=config, range_floor_m=range_floor_m, v_r_floor_mps=v_r_floor_mps,
                           sigma_range_m=sigma_range_m, sigma_v_r_mps=sigma_v_r_mps, start_sigma_m=start_sigma_m,
                           fixes=fixes, filter=filter, depths=depths, use_bearing=use_bearing,
                           bearing_floor_rad=bearing_floor_rad)


def record_sigma(meas, column, given, default, floor, name) -> tuple[np.ndarray, str]:
    """σ per record: the user's value, else the record's raised to the floor (NaN rows: the default)."""
    n = np.asarray(meas["range_m"]).size
    if given is not None:
        check_positive(name, given)
        return np.full(n, float(given)), "command line"
    if column in meas:
        sigma = np.asarray(meas[column], dtype=float)
        source = "records"
        missing = ~np.isfinite(sigma)
        if missing.any():
            source = f"records ({int(missing.sum())} without: {default:g})"
        sigma = np.where(missing, default, np.maximum(sigma, floor))
        return sigma, source
    return np.full(n, float(default)), "default (records carry none)"


def inertial_config(config, *, start_sigma_m, range_floor_m, v_r_floor_mps):
    """The inertial filter's configuration with the start σ, once the floors and the start σ are checked."""
    from .inertial import InertialConfig

    for name, value in (("range_floor_m", range_floor_m), ("v_r_floor_mps", v_r_floor_mps)):
        if not (value is not None and math.isfinite(value) and value >= 0):
            raise ConfigError(name, f"must be a finite number >= 0, got {value!r}")
    check_positive("start_sigma_m", start_sigma_m)
    return replace(config if config is not None else InertialConfig(), p0_position_m=float(start_sigma_m))


def bearing_sigma(meas: dict, bearing_floor_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """The records' ``azimuth_body_rad`` and the σ used for each: the record's (or
    :data:`DEFAULT_SIGMA_BEARING_RAD`) raised to ``bearing_floor_rad``."""
    az = np.asarray(meas["azimuth_body_rad"], dtype=float)
    sb = np.asarray(meas.get("sigma_azimuth_body_rad", np.full(az.size, np.nan)), dtype=float)
    return az, np.maximum(np.where(np.isfinite(sb) & (sb > 0), sb, DEFAULT_SIGMA_BEARING_RAD), bearing_floor_rad)


def _inertial_track(meas, ranges, imu, *, beacon_xy, start_xy, start_speed_mps, use_vr, smooth, lag_s, config,
                    range_floor_m, v_r_floor_mps, sigma_range_m, sigma_v_r_mps, start_sigma_m, fixes, filter,
                    depths, use_bearing=True, bearing_floor_rad=BEARING_FLOOR_RAD) -> dict:
    from .inertial import add_bearings, add_fixes, build_nodes, run_filter, state_names
    from .inertial.smoothers import batch_smooth, fixed_lag_smooth

    if smooth == "fixed-lag":
        check_positive("lag_s", lag_s)
    cfg = inertial_config(config, start_sigma_m=start_sigma_m, range_floor_m=range_floor_m,
                          v_r_floor_mps=v_r_floor_mps)
    t_imu = np.asarray(imu["t_s"], dtype=float)
    if t_imu.size < 2 or np.any(np.diff(t_imu) <= 0):
        raise InputFileError("IMU samples: need at least two, with strictly increasing t_s")
    heading = np.asarray(imu["heading_rad"], dtype=float)
    if not math.isfinite(heading[0]):
        raise InputFileError("IMU samples: the first heading (the start heading) is not a number")
    sr, r_source = record_sigma(meas, "sigma_range_m", sigma_range_m, DEFAULT_SIGMA_RANGE_M, range_floor_m,
                                 "sigma_range_m")
    sv, v_source = record_sigma(meas, "sigma_v_r_mps", sigma_v_r_mps, DEFAULT_SIGMA_V_R_MPS, v_r_floor_mps,
                                 "sigma_v_r_mps")
    t_frame = np.asarray(meas["t_arrival_s"], dtype=float)
    inside = (t_frame >= t_imu[0]) & (t_frame <= t_imu[-1])
    if (~inside).any():
        _warn(f"measurements: {int((~inside).sum())} of {t_frame.size} frame(s) arrive outside the IMU's time span "
              f"[{t_imu[0]:g}, {t_imu[-1]:g}] s and are not used (status outside_imu)")
    heading_var = (np.asarray(imu["heading_std_rad"], dtype=float) ** 2 if "heading_std_rad" in imu
                   else cfg.heading_sigma_rad**2)
    nodes = build_nodes(t_imu, heading, imu["omega_rad_s"], imu["accel_mps2"], t_frame[inside], ranges[inside],
                        np.asarray(meas["v_r_mps"], dtype=float)[inside], sr[inside] ** 2, sv[inside] ** 2,
                        heading_var=heading_var, t_start=t_imu[0])
    n_fix_used = 0
    fixes_xy = None
    if fixes is not None and len(fixes["t_s"]):
        ft = np.asarray(fixes["t_s"], dtype=float)
        nodes = add_fixes(nodes, ft, fixes["x_m"], fixes["y_m"], fixes["sigma_m"])
        n_fix_used = int(nodes.has_fix.sum())
        if n_fix_used < ft.size:
            _warn(f"fixes: {ft.size - n_fix_used} of {ft.size} fix(es) are more than half an IMU step from every "
                  f"IMU sample or frame (outside the track's time span?) and are not used")
        fixes_xy = np.c_[np.asarray(fixes["x_m"], dtype=float), np.asarray(fixes["y_m"], dtype=float)]
    n_bearings = 0
    if not (bearing_floor_rad is not None and math.isfinite(bearing_floor_rad) and bearing_floor_rad >= 0):
        raise ConfigError("bearing_floor_rad", f"must be a finite number >= 0, got {bearing_floor_rad!r}")
    if use_bearing and "azimuth_body_rad" in meas and np.isfinite(meas["azimuth_body_rad"]).any():
        az, sb = bearing_sigma(meas, bearing_floor_rad)
        nodes = add_bearings(nodes, az[inside], sb[inside])
        n_bearings = int(nodes.has_bearing.sum())
    z0, P0 = cfg.initial(float(start_xy[0]), float(start_xy[1]), float(heading[0]), float(start_speed_mps))
    run = run_filter(nodes, cfg, beacon_xy=beacon_xy, z0=z0, P0=P0, use_vr=use_vr)
    states, covs = run.states, run.covariances
    smoother_info = None
    if smooth == "batch":
        smoothed = batch_smooth(run)
        states, covs = smoothed.states, smoothed.covariances
        smoother_info = {"iterations": smoothed.iterations, "converged": bool(smoothed.converged)}
        if not smoothed.converged:
            _warn(f"batch smoother: not converged after {smoothed.iterations} Gauss-Newton iterations; "
                  f"the track is the last iterate")
    elif smooth == "fixed-lag":
        smoothed = fixed_lag_smooth(run, lag_s=float(lag_s))
        states, covs = smoothed.states, smoothed.covariances
        smoother_info = {"lag_s": float(lag_s)}
    # per-record table: the status at the record's node, outside_imu for those not in the nodes
    n = t_frame.size
    status = np.full(n, -1, dtype=int)
    nis = np.full(n, np.nan)
    where = np.flatnonzero(nodes.frame >= 0)
    rec = np.flatnonzero(inside)[nodes.frame[where]]
    status[rec] = run.status[where]
    nis[rec] = run.nis[where]
    frames = {"frame_index": np.asarray(meas["frame_index"]), "t_arrival_s": t_frame,
              "status": np.array([FRAME_STATUS[int(s)] for s in status], dtype=object), "nis": nis,
              "sigma_range_m": sr, "sigma_v_r_mps": sv if use_vr else np.full(n, np.nan)}
    if n_bearings:
        b_status = np.full(n, -1, dtype=int)
        b_status[rec] = run.bearing_status[where]
        names = {**FRAME_STATUS, 0: "none"}
        frames["bearing_status"] = np.array([names[int(s)] for s in b_status], dtype=object)
    settings = {
        "filter": filter,
        "description": ("inertial beacon filter (navigation.inertial): IMU-driven, heading bias state, "
                        "process noise from the sensors' densities, chi2-gated iterated acoustic updates, "
                        + ("range and v_r" if use_vr else "range only")),
        "smoother": smooth, "smoother_info": smoother_info,
        "inertial_config": asdict(cfg),
        "r": {"range_source": r_source, "v_r_source": v_source if use_vr else "not used",
              "range_floor_m": float(range_floor_m), "v_r_floor_mps": float(v_r_floor_mps),
              "sigma_range_m": sigma_range_m, "sigma_v_r_mps": sigma_v_r_mps,
              "default_sigma_range_m": DEFAULT_SIGMA_RANGE_M, "default_sigma_v_r_mps": DEFAULT_SIGMA_V_R_MPS},
        "start": {"x_m": float(start_xy[0]), "y_m": float(start_xy[1]), "sigma_m": float(start_sigma_m),
                  "speed_mps": float(start_speed_mps), "heading_rad": float(heading[0]),
                  "heading_from": "first IMU heading reading"},
        "fixes_used": n_fix_used, "depths_m": list(depths) if depths else None,
        "bearings_used": n_bearings, "bearing_floor_deg": math.degrees(bearing_floor_rad),
    }
    return {"t_s": nodes.t_s.copy(), "state": states, "cov": covs, "names": state_names(cfg), "frames": frames,
            "settings": settings, "run": run, "fixes_xy": fixes_xy}


def _paper_track(meas: dict, imu: dict, *, beacon_xy, start_xy, start_speed_mps=0.0, filter="proposed",
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
        (:func:`~seamodem.navigation.ekf_smoother.rts_smooth`): each state then uses
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
    ekf = ExtendedKalmanFilter(model, x0, np.eye(6), lambda dt: eq25_q(dt) * np.eye(6), t0_s=float(imu["t_s"][0]))
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


def frames_path(output) -> Path:
    """``OUT_frames.csv`` beside ``OUT.csv``: the per-frame table."""
    out = Path(output)
    return out.with_name(out.stem + "_frames.csv")


def _error_stats(t, state, cov, truth_cols, truth_path):
    truth_xy = np.c_[np.interp(t, truth_cols["t_s"], truth_cols["x_m"]), np.interp(t, truth_cols["t_s"], truth_cols["y_m"])]
    inside = (t >= truth_cols["t_s"][0]) & (t <= truth_cols["t_s"][-1])
    e = state[inside, :2] - truth_xy[inside]
    err = np.hypot(*e.T)
    if err.size == 0:
        raise InputFileError(f"truth file {truth_path}: its times do not overlap the track")
    stats = {"mean_error_m": float(err.mean()), "rms_error_m": float(np.sqrt(np.mean(err**2))),
             "max_error_m": float(err.max()), "final_error_m": float(err[-1]), "error_variance_m2": float(err.var()),
             "n_points": int(err.size)}
    c = cov[inside][:, :2, :2]
    det = c[:, 0, 0] * c[:, 1, 1] - c[:, 0, 1] ** 2
    if np.all(det > 0):
        # position NEES e^T P^-1 e: chi2 with 2 dof (mean 2) when the covariance is right
        nees = (c[:, 1, 1] * e[:, 0] ** 2 - 2 * c[:, 0, 1] * e[:, 0] * e[:, 1] + c[:, 0, 0] * e[:, 1] ** 2) / det
        stats["position_nees_mean"] = float(nees.mean())
        stats["inside_95pct_ellipse"] = float(np.mean(nees <= CHI2_2DOF_95))
        stats["inside_2sigma_ellipse"] = float(np.mean(nees <= 4.0))
    return stats, truth_xy


def track_from_files(measurements, imu, *, beacon, start, start_speed_mps=0.0, geodetic=False, depths=None,
                     depth_log=None, beacon_depth_m=0.0, sound_speed_profile=None, filter="inertial",
                     r_from_records=False, smooth=None,
                     lag_s=None, config=None, range_floor_m=RANGE_FLOOR_M, v_r_floor_mps=V_R_FLOOR_MPS,
                     sigma_range_m=None, sigma_v_r_mps=None, start_sigma_m=1.0, fixes=None, truth=None,
                     command=None, output, use_bearing=True, bearing_floor_rad=BEARING_FLOOR_RAD) -> str:
    """Read, track, write OUT.csv, OUT_frames.csv, OUT.png and OUT.json; return a one-paragraph summary.

    The readers are :func:`~.logs.read_measurements`, :func:`~.logs.read_imu`, :func:`~.logs.read_fixes`
    and :func:`~.logs.read_depth`: what they repair is a :class:`~.logs.LogWarning` (one line each), what
    they cannot a one-line error. See :func:`run_track` for the other parameters; ``depth_log``,
    ``fixes`` and ``truth`` are file paths here, ``command`` the command line for the sidecar,
    ``sound_speed_profile`` a :class:`~seamodem.water.SoundSpeedProfile`.
    """
    out = check_writable(output)
    if out.suffix.lower() != ".csv":
        raise ConfigError("output", f"must be a .csv path, got {str(out)!r}")
    if smooth is True:
        smooth = "batch"
    if smooth not in SMOOTHERS and smooth is not False:
        raise ConfigError("smooth", f"must be None, 'batch' or 'fixed-lag', got {smooth!r}")
    smooth = smooth or None
    beacon_pair = _pair(beacon, "beacon")
    if geodetic:
        origin = parse_position(beacon, geodetic=False, parameter="beacon")
        from .geometry import check_lat_lon

        check_lat_lon(*origin, "beacon")
        beacon_xy = (0.0, 0.0)
        start_xy = parse_position(start, geodetic=True, origin=origin, parameter="start")
    else:
        origin = None
        beacon_xy, start_xy = beacon_pair, _pair(start, "start")
    meas = read_measurements(measurements)
    samples = read_imu(imu)
    truth_cols = read_columns(truth, TRUTH_COLUMNS, time_column="t_s", what="truth file") if truth else None
    fix_cols = None
    if fixes is not None:
        fix_cols = read_fixes(fixes, origin=origin)
        if "x_m" not in fix_cols:
            raise ConfigError("fixes", f"{fixes} gives lat_deg, lon_deg: use --geodetic with the beacon as lat,lon")
    depth_cols = read_depth(depth_log) if depth_log is not None else None
    result = run_track(meas, samples, beacon_xy=beacon_xy, start_xy=start_xy, start_speed_mps=start_speed_mps,
                       filter=filter, r_from_records=r_from_records, depths=depths, depth_log=depth_cols,
                       beacon_depth_m=beacon_depth_m, sound_speed_profile=sound_speed_profile, smooth=smooth,
                       lag_s=lag_s, config=config,
                       range_floor_m=range_floor_m, v_r_floor_mps=v_r_floor_mps, sigma_range_m=sigma_range_m,
                       sigma_v_r_mps=sigma_v_r_mps, start_sigma_m=start_sigma_m, fixes=fix_cols,
                       use_bearing=use_bearing, bearing_floor_rad=bearing_floor_rad)
    t, state, cov, names = result["t_s"], result["state"], result["cov"], result["names"]
    columns = {"t_s": t, "x_m": state[:, 0], "y_m": state[:, 1], "heading_rad": state[:, 2],
               "speed_mps": state[:, 3]}
    units = {"bias": "bias_rad", "bias_rate": "bias_rate_rad_s", "current_x": "current_x_mps",
             "current_y": "current_y_mps", "range_scale": "range_scale"}
    for k, name in enumerate(names):
        if name in units:
            columns[units[name]] = state[:, k]
    columns.update({"var_x_m2": cov[:, 0, 0], "cov_xy_m2": cov[:, 0, 1], "var_y_m2": cov[:, 1, 1]})
    if geodetic:
        columns["lat_deg"], columns["lon_deg"] = local_to_geodetic(state[:, 0], state[:, 1], *origin)
    frames = result["frames"]
    counts = {s: int(np.sum(frames["status"] == s)) for s in FRAME_STATUS.values()}
    stats, truth_xy = (None, None)
    if truth_cols is not None:
        stats, truth_xy = _error_stats(t, state, cov, truth_cols, truth)
    settings = result["settings"]
    smoothed = settings.get("smoother") is not None
    sidecar = {"format": "seamodem.track/1", "command": command, **settings, "smoothed": smoothed,
               "inputs": {"measurements": str(measurements), "imu": str(imu), "fixes": fixes and str(fixes),
                          "depth_log": depth_log and str(depth_log), "truth": truth and str(truth),
                          "beacon": beacon, "start": start, "geodetic": bool(geodetic),
                          "beacon_depth_m": beacon_depth_m if depth_log is not None else None,
                          "sound_speed_profile": sound_speed_profile.source if sound_speed_profile else None},
               "outputs": {"track": str(out), "frames": str(frames_path(out)), "plot": str(out.with_suffix(".png"))},
               "frames": {"records": int(frames["status"].size), **counts},
               "states": list(names)}
    if stats:
        sidecar.update(stats)
    from .figures import plot_track

    fpath = frames_path(out)
    smoother_label = {None: "", "batch": ", batch-smoothed", "fixed-lag": f", fixed-lag {lag_s} s",
                      "rts": " (RTS-smoothed)"}[settings.get("smoother")]
    with atomic_outputs(out, fpath, out.with_suffix(".png"), out.with_suffix(".json")) as temps:
        with open(temps[0], "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(columns)
            writer.writerows(zip(*(np.round(v, 9) for v in columns.values())))
        with open(temps[1], "w", newline="") as f:
            writer = csv.writer(f)
            bearing = frames.get("bearing_status")
            writer.writerow(["frame_index", "t_arrival_s", "status", "nis", "sigma_range_m", "sigma_v_r_mps"]
                            + (["bearing_status"] if bearing is not None else []))
            for i, row in enumerate(zip(frames["frame_index"], frames["t_arrival_s"], frames["status"], frames["nis"],
                                        frames["sigma_range_m"], frames["sigma_v_r_mps"])):
                writer.writerow([int(row[0]), f"{row[1]:.9g}", row[2]] + ["" if not np.isfinite(v) else f"{v:.6g}"
                                                                          for v in row[3:]]
                                + ([bearing[i]] if bearing is not None else []))
        plot_track(t, state[:, :2], temps[2], beacon_xy=beacon_xy, cov_xy=cov[:, :2, :2], truth_xy=truth_xy,
                   fixes_xy=result.get("fixes_xy"),
                   title=f"{filter}{smoother_label}: {frames['status'].size} frames ({counts['gated']} gated), "
                         f"{samples['t_s'].size} IMU samples")
        Path(temps[3]).write_text(json.dumps(sidecar, indent=1, default=_jsonable) + "\n", encoding="utf-8")
    text = (f"wrote {out} ({t.size} states), {fpath}, {out.with_suffix('.png')}, {out.with_suffix('.json')}; "
            f"frames: {counts['accepted'] + counts['accepted_after_gates']} used, {counts['gated']} gated")
    if "bearing_status" in frames:
        b = frames["bearing_status"]
        text += (f"; array bearings: {int(np.isin(b, ('accepted', 'accepted_after_gates')).sum())} used, "
                 f"{int((b == 'gated').sum())} gated")
    if counts["accepted_after_gates"]:
        text += f", {counts['accepted_after_gates']} accepted after a run of gated ones"
    if counts["outside_imu"]:
        text += f", {counts['outside_imu']} outside the IMU's time span"
    if counts["gated"] or counts["accepted_after_gates"] or counts["outside_imu"]:
        text += f" (listed in {fpath})"
    if stats:
        text += (f"; error vs truth: mean {stats['mean_error_m']:.2f} m, RMS {stats['rms_error_m']:.2f} m, "
                 f"max {stats['max_error_m']:.2f} m")
        if "inside_95pct_ellipse" in stats:
            text += f", truth inside the 95 % ellipse at {100 * stats['inside_95pct_ellipse']:.0f} % of the states"
    return text


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
