"""``seamodem nav``: navigation — reproduce paper 000's Monte Carlo, or track from measurement records."""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import asdict, replace
from pathlib import Path

from .._progress import progress_bar
from ..errors import SeamodemError
from ..io.files import atomic_outputs
from ._common import command_line

TABLE_COLUMNS = ("tcom_s", "filter", "mean_error_m", "error_variance_m2", "etd_max_pct", "etd_mean_pct", "outliers")


def add_parser(sub) -> None:
    p = sub.add_parser("nav", help="navigation: Monte Carlo of paper 000, or a track from measurement records",
                       description="Single-beacon navigation with the papers' estimators.")
    nav = p.add_subparsers(dest="nav_command", metavar="ACTION", required=True)

    s = nav.add_parser(
        "simulate",
        help="reproduce paper 000 Tables 3-4 (proposed EKF vs ROSB) by Monte Carlo",
        description=(
            "Simulate RUNS boustrophedon missions per T_com (paper 000 §4.1), print Tables 3 and 4 beside the "
            "paper's values and write DIR/table.csv, DIR/table.txt, DIR/config.json and the figures "
            "DIR/fig7_top_view.png, DIR/fig8_error.png."
        ),
    )
    s.add_argument("--tcom", type=float, nargs="+", default=[3, 6, 9, 12, 15, 20], metavar="S",
                   help="communication periods T_com [s] (default 3 6 9 12 15 20)")
    s.add_argument("--runs", type=int, default=300, help="missions per row (default 300)")
    s.add_argument("--seed", type=int, default=0, help="seed; run r uses default_rng([seed, r]) (default 0)")
    s.add_argument("--steer", choices=("estimate", "truth"), default="estimate",
                   help="the controller steers on the filter's estimate (a real vehicle, default) or on the truth")
    s.add_argument("--sigma-range", type=float, metavar="M", help="emulated range noise [m] (default √12 = 3.46)")
    s.add_argument("--sigma-vr", type=float, metavar="MPS", help="emulated v_r noise [m/s] (default √0.2 = 0.447)")
    s.add_argument("--matched-r", action="store_true",
                   help="set the filter's R for range and v_r to the emulated variances (default: eq 25's 12 and 0.2)")
    s.add_argument("--q", type=float, metavar="VAR",
                   help="filter process noise variance per state and step (default Δt⁸ = 1.5e-5, eq 25)")
    s.add_argument("--error-of", choices=("estimate", "smoothed", "last-fix"), default="estimate",
                   help="position the error is measured on: the filter's real-time estimate (paper 000, default), "
                        "the RTS-smoothed track (post-processing), or the last frame's fix held until the next "
                        "(the diagnostic of docs/navigation.md)")
    s.add_argument("--workers", type=int, help="threads, or processes with --backend (default: all cores)")
    s.add_argument("--backend", choices=("threads", "serial", "processes", "dask"), default="threads",
                   help="where the runs go: local threads (default), serially, local processes, or a Dask "
                        "cluster (--scheduler); the table is the same bit for bit")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask scheduler tcp://HOST:8786 (implies --backend dask; pip install 'seamodem[dask]')")
    s.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created if missing)")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.set_defaults(run=run_simulate)

    t = nav.add_parser(
        "track",
        help="estimate a track from the receiver's measurement CSV and an IMU/AHRS CSV",
        description=(
            "Run the 6-state EKF of paper 000 (or ROSB) on measurement records (columns frame_index, t_emit_s, "
            "t_arrival_s, tof_s, range_m, v_r_mps, snr_db, optional range_std_m, v_r_std_mps) and IMU samples "
            "(columns t_s, heading_rad, omega_rad_s, accel_mps2). Writes OUT.csv (t_s, x_m, y_m, heading_rad, "
            "speed_mps, covariance of x and y), OUT.png and, with --truth, error statistics in OUT.json."
        ),
    )
    t.add_argument("measurements", metavar="MEAS.csv")
    t.add_argument("--imu", required=True, metavar="IMU.csv", help="IMU/AHRS samples, sorted by t_s")
    t.add_argument("--beacon", required=True, metavar="X,Y",
                   help="beacon position: local x,y [m], or lat,lon [deg] with --geodetic")
    t.add_argument("--geodetic", action="store_true",
                   help="--beacon and --start are lat,lon; the output adds lat_deg, lon_deg")
    t.add_argument("--start", required=True, metavar="X,Y", help="initial position (GNSS fix before diving)")
    t.add_argument("--start-speed", type=float, default=0.0, metavar="MPS", help="initial speed [m/s] (default 0)")
    t.add_argument("--depth", type=float, nargs=2, metavar=("VEHICLE", "BEACON"),
                   help="known depths [m]: slant ranges become horizontal (paper 004 eq 10)")
    t.add_argument("--filter", choices=("proposed", "rosb"), default="proposed", help="with or without v_r")
    t.add_argument("--r-from-records", action="store_true",
                   help="use each record's range_std_m and v_r_std_mps as R (SNR-dependent) instead of eq 25")
    t.add_argument("--smooth", action="store_true",
                   help="post-process: Rauch-Tung-Striebel smoothing of the whole track (uses later frames too)")
    t.add_argument("--truth", metavar="TRUTH.csv", help="true track (t_s, x_m, y_m) for error statistics")
    t.add_argument("-o", "--output", required=True, metavar="OUT.csv", help="track output; OUT.png beside it")
    t.set_defaults(run=run_track)


def run_simulate(args: argparse.Namespace) -> int:
    from ..navigation.figures import plot_error_curves, plot_top_view
    from ..navigation.montecarlo import MissionConfig, NoiseModel, format_table, run_monte_carlo

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise SeamodemError(f"output: {out} exists and is not a folder")
    if args.runs < 4:
        raise SeamodemError(f"--runs: must be >= 4 (quartiles for the outlier rule), got {args.runs}")
    if args.workers is not None and args.workers < 1:
        raise SeamodemError(f"--workers: must be >= 1, got {args.workers}")
    if args.seed < 0:
        raise SeamodemError(f"--seed: must be >= 0, got {args.seed}")
    noise = NoiseModel()
    if args.sigma_range is not None:
        noise = replace(noise, sigma_range_m=args.sigma_range)
    if args.sigma_vr is not None:
        noise = replace(noise, sigma_vr_mps=args.sigma_vr)
    config = MissionConfig(noise=noise, steer_on_estimate=args.steer == "estimate", q=args.q,
                           error_of=args.error_of.replace("-", "_"))
    if args.matched_r:
        config = replace(config, r_diag=(noise.sigma_range_m**2, noise.sigma_vr_mps**2, *config.r_diag[2:]))
    for t in args.tcom:
        replace(config, tcom_s=t)  # validates every T_com before any work
    out.mkdir(parents=True, exist_ok=True)
    total = 2 * len(args.tcom) * args.runs
    with progress_bar(total=total, desc="missions", enabled=False if args.quiet else None) as bar:
        backend = "dask" if args.scheduler else (None if args.backend == "threads" else args.backend)
        result = run_monte_carlo(config, tcoms=tuple(args.tcom), runs=args.runs, seed=args.seed,
                                 workers=args.workers, progress=bar.update, backend=backend,
                                 scheduler=args.scheduler)
    text = format_table(result)
    print(text)
    with atomic_outputs(out / "table.csv", out / "table.txt", out / "config.json") as (tcsv, ttxt, tjson):
        with open(tcsv, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=TABLE_COLUMNS)
            writer.writeheader()
            for row in result.rows:
                writer.writerow({k: row[k] for k in TABLE_COLUMNS})
        Path(ttxt).write_text(text + "\n", encoding="utf-8")
        Path(tjson).write_text(json.dumps({"command": command_line(), "runs": args.runs, "seed": args.seed,
                                           "tcom_s": list(result.tcoms), "mission": asdict(config)}, indent=1,
                                          default=str) + "\n", encoding="utf-8")
    plot_top_view(result, out / "fig7_top_view.png")
    plot_error_curves(result, out / "fig8_error.png")
    return 0


def run_track(args: argparse.Namespace) -> int:
    from ..navigation.track import track_from_files

    summary = track_from_files(
        args.measurements,
        args.imu,
        beacon=args.beacon,
        start=args.start,
        start_speed_mps=args.start_speed,
        geodetic=args.geodetic,
        depths=args.depth,
        filter=args.filter,
        r_from_records=args.r_from_records,
        smooth=args.smooth,
        truth=args.truth,
        output=args.output,
    )
    print(summary)
    return 0
