"""Use 4: feed an estimator from a measurement file — the EKF of paper 000 on range/v_r records and an IMU file.

    python examples/feed_estimator.py [OUTDIR]                              (default: estimator_out/)
    python examples/feed_estimator.py OUTDIR MEAS.csv IMU.csv TRUTH.csv BEACON_X,BEACON_Y

The files are those of ``seamodem nav track`` (``docs/navigation.md``): the
measurement records (columns frame_index, t_emit_s, t_arrival_s, tof_s, range_m,
v_r_mps, snr_db — what ``seamodem rx`` writes), the IMU/AHRS samples (t_s,
heading_rad, omega_rad_s, accel_mps2) and, optionally, the truth (t_s, x_m, y_m).
``seamodem demo`` leaves all three in demo_out/ (beacon at 45,-25):

    python examples/feed_estimator.py est_out demo_out/measurements.csv demo_out/imu.csv demo_out/truth.csv 45,-25

Without files, the script writes a set itself: the demo's vehicle on its 151 s
survey, with range and v_r emulated from the geometry (σ = 0.5 m and 0.05 m/s).
"""

import json
import sys
from pathlib import Path

import numpy as np

from seamodem.demo import DemoConfig, simulate_vehicle
from seamodem.navigation import closing_speed
from seamodem.navigation.track import track_from_files


def write_emulated_files(out: Path, c_mps: float = 1500.0) -> tuple[Path, Path, Path, str]:
    cfg = DemoConfig()
    rng = np.random.default_rng(7)
    vehicle = simulate_vehicle(cfg, t_end_s=cfg.mission_s(), rng=rng)
    bx, by = cfg.beacon_xy_m
    t_emit = np.arange(0.0, cfg.mission_s() - 1.0, cfg.tcom_s)
    k = np.searchsorted(vehicle.t_s, t_emit)  # emission instants fall on the 0.25 s grid
    x, y = vehicle.xy_m[k].T
    rng_m = np.hypot(x - bx, y - by)
    v_r = closing_speed(x, y, vehicle.heading_rad[k], vehicle.speed_mps[k], (bx, by))
    meas = np.column_stack([np.arange(t_emit.size), t_emit, t_emit + rng_m / c_mps, rng_m / c_mps,
                            rng_m + 0.5 * rng.standard_normal(t_emit.size),
                            v_r + 0.05 * rng.standard_normal(t_emit.size), np.full(t_emit.size, 12.0)])
    files = out / "meas.csv", out / "imu.csv", out / "truth.csv"
    np.savetxt(files[0], meas, delimiter=",", comments="", fmt="%.9g",
               header="frame_index,t_emit_s,t_arrival_s,tof_s,range_m,v_r_mps,snr_db")
    imu = vehicle.imu
    np.savetxt(files[1], np.column_stack([imu[c] for c in ("t_s", "heading_rad", "omega_rad_s", "accel_mps2")]),
               delimiter=",", comments="", fmt="%.9g", header="t_s,heading_rad,omega_rad_s,accel_mps2")
    np.savetxt(files[2], np.column_stack([vehicle.t_s, vehicle.xy_m]), delimiter=",", comments="", fmt="%.9g",
               header="t_s,x_m,y_m")
    return (*files, f"{bx},{by}")


def main(out: Path, args: list[str]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    if args:
        meas, imu, truth, beacon = Path(args[0]), Path(args[1]), Path(args[2]), args[3]
    else:
        meas, imu, truth, beacon = write_emulated_files(out)
    (t0, x0, y0), (t1, x1, y1) = np.loadtxt(truth, delimiter=",", skiprows=1, max_rows=2)
    speed = float(np.hypot(x1 - x0, y1 - y0) / (t1 - t0))
    for f in ("proposed", "rosb"):
        # start at the first truth point and speed (a GNSS fix before diving); the same call as `seamodem nav track`
        text = track_from_files(meas, imu, beacon=beacon, start=f"{x0},{y0}", start_speed_mps=speed, filter=f,
                                truth=truth,
                                output=out / f"track_{f}.csv")
        stats = json.loads((out / f"track_{f}.json").read_text())
        print(f"{f:8s}: mean error {stats['mean_error_m']:.2f} m, RMS {stats['rms_error_m']:.2f} m; {text}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "estimator_out"), sys.argv[2:])
