"""``seamodem nav``: navigation — reproduce paper 000's Monte Carlo, or track from measurement records."""

from __future__ import annotations

import argparse
import csv
import json
import math
from dataclasses import asdict, replace
from pathlib import Path

from .._progress import progress_bar
from ..errors import SeamodemError
from ..io.files import atomic_outputs
from ._common import add_profile_option, command_line, reported_warnings, sound_speed_profile

TABLE_COLUMNS = ("tcom_s", "filter", "mean_error_m", "error_variance_m2", "etd_max_pct", "etd_mean_pct", "outliers",
                 "diverged", "median_error_m")

#: ``nav simulate``'s estimators by their command-line names (hyphens) and table names (underscores).
SIM_FILTERS = ("inertial", "inertial-range", "fixed-lag", "batch", "proposed", "rosb")


def _speed_floor(text: str) -> float | None:
    """``--min-speed``: a finite speed [m/s] or ``none``."""
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a speed in m/s or 'none', got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def _add_inertial_options(parser: argparse.ArgumentParser) -> None:
    """The inertial filter's --window and --min-speed, shared by nav simulate and nav track."""
    parser.add_argument("--window", type=float, default=120.0, metavar="S",
                        help="after a frame the filter finds improbable (NIS above its chi2 0.99 quantile), re-solve "
                             "the last S seconds by Gauss-Newton and continue from the result (default 120; 0: off, "
                             "the plain filter)")
    parser.add_argument("--min-speed", type=_speed_floor, default=0.0, metavar="MPS",
                        help="the filter's speed floor [m/s]: an estimated speed below it is projected onto it (the "
                             "vehicle moves forward; range and v_r cannot tell it from one backing along the "
                             "reflected track; default 0; 'none': no floor)")


def add_parser(sub) -> None:
    p = sub.add_parser("nav", help="navigation: Monte Carlo of paper 000, or a track from measurement records",
                       description="Single-beacon navigation with the papers' estimators.")
    nav = p.add_subparsers(dest="nav_command", metavar="ACTION", required=True)

    s = nav.add_parser(
        "simulate",
        help="Monte Carlo of paper 000's mission: the inertial filter and smoothers, or the paper's filters",
        description=(
            "Simulate RUNS boustrophedon missions per T_com (paper 000 §4.1) for each estimator, print the mean "
            "position error per T_com beside the paper's Table 3-4 values, with outliers and diverged runs "
            "counted, and write DIR/table.csv, DIR/table.txt, DIR/config.json and the figures "
            "DIR/fig7_top_view.png, DIR/fig8_error.png. Default: the inertial filter, the controller steering on "
            "the estimate, receiver-grade noise (range 1 cm, v_r 2 cm/s: what seamodem's receiver measures, "
            "with margin). --paper-noise uses paper 000's noise (3.46 m, 0.447 m/s); --paper runs the "
            "paper-faithful reproduction (paper 000's EKF and ROSB, eq 25, its noise, steering on the truth)."
        ),
    )
    s.add_argument("--tcom", type=float, nargs="+", default=[3, 6, 9, 12, 15, 20], metavar="S",
                   help="communication periods T_com [s] (default 3 6 9 12 15 20)")
    s.add_argument("--runs", type=int, default=300, help="missions per row (default 300)")
    s.add_argument("--seed", type=int, default=0, help="seed; run r uses default_rng([seed, r]) (default 0)")
    s.add_argument("--filters", nargs="+", choices=SIM_FILTERS, metavar="NAME",
                   help="estimators: " + ", ".join(SIM_FILTERS) + " (default: inertial; inertial-range is "
                        "the same filter without v_r; fixed-lag and batch smooth the inertial filter's mission; "
                        "proposed and rosb are paper 000's EKFs)")
    s.add_argument("--paper", action="store_true",
                   help="paper-faithful reproduction of Tables 3-4: --filters proposed rosb --steer truth "
                        "--paper-noise")
    s.add_argument("--paper-noise", action="store_true",
                   help="paper 000's measurement noise, range √12 = 3.46 m and v_r √0.2 = 0.447 m/s (eq 25's R); "
                        "the default is receiver-grade, 0.01 m and 0.02 m/s")
    s.add_argument("--steer", choices=("estimate", "truth"),
                   help="the controller steers on the filter's estimate (a real vehicle; default) or on the truth "
                        "(default with --paper)")
    s.add_argument("--bias-model", choices=("random_walk", "drift"), default="random_walk",
                   help="heading bias of 5 deg/h as a random walk (default) or a constant drift rate per run")
    s.add_argument("--lag", type=float, default=10.0, metavar="S",
                   help="latency of the fixed-lag smoother [s] (default 10)")
    s.add_argument("--sigma-range", type=float, metavar="M",
                   help="emulated range noise [m] (default 0.01; 3.46 with --paper or --paper-noise)")
    s.add_argument("--sigma-vr", type=float, metavar="MPS",
                   help="emulated v_r noise [m/s] (default 0.02; 0.447 with --paper or --paper-noise)")
    s.add_argument("--sigma-bearing", type=float, default=0.0, metavar="DEG",
                   help="a hydrophone array's body-frame azimuth of the beacon per frame, its noise [deg] "
                        "(default 0: no array); the inertial filters and smoothers use it")
    s.add_argument("--gate", type=float, choices=(0.99, 0.999, 0.9999, 0.99999), metavar="P",
                   help="chi2 gate of the inertial filter's acoustic updates (default none: the simulated "
                        "measurements have no outliers; nav track gates records at 0.9999)")
    _add_inertial_options(s)
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
            "Estimate the vehicle's track from measurement records (columns frame_index, t_emit_s, t_arrival_s, "
            "tof_s, range_m, v_r_mps, snr_db, optional sigma_range_m, sigma_v_r_mps) and IMU/AHRS samples at any "
            "time stamps (columns t_s, heading_rad or heading_deg, omega_rad_s, accel_mps2). Default: the inertial "
            "filter (heading bias as a state, process noise from the IMU's noise densities, each frame's own σ "
            "raised to a floor, chi2-gated frames reported). Writes OUT.csv (t_s, x_m, y_m, heading_rad, "
            "speed_mps, bias_rad, var_x_m2, cov_xy_m2, var_y_m2), OUT_frames.csv (each frame: accepted, gated or "
            "outside the IMU's span, its NIS), OUT.png (track with 2-σ ellipses) and OUT.json (configuration, "
            "error statistics with --truth). --filter proposed/rosb run paper 000's EKF exactly as published."
        ),
    )
    t.add_argument("measurements", metavar="MEAS.csv")
    t.add_argument("--imu", required=True, metavar="IMU.csv", help="IMU/AHRS samples (any time stamps)")
    t.add_argument("--beacon", required=True, metavar="X,Y",
                   help="beacon position: local x,y [m], or lat,lon [deg] with --geodetic")
    t.add_argument("--geodetic", action="store_true",
                   help="--beacon and --start are lat,lon; the output adds lat_deg, lon_deg")
    t.add_argument("--start", required=True, metavar="X,Y", help="initial position (GNSS fix before diving)")
    t.add_argument("--start-speed", type=float, default=0.0, metavar="MPS", help="initial speed [m/s] (default 0)")
    t.add_argument("--start-sigma", type=float, default=1.0, metavar="M",
                   help="1-σ error of --start per axis [m] (default 1: a GNSS fix; inertial filters)")
    t.add_argument("--fixes", metavar="FIXES.csv",
                   help="GNSS fixes at the surface: t_s and x_m,y_m (or lat_deg,lon_deg with --geodetic), "
                        "optional sigma_m (default 3 m); inertial filters")
    depth = t.add_mutually_exclusive_group()
    depth.add_argument("--depth", type=float, nargs=2, metavar=("VEHICLE", "BEACON"),
                       help="known depths [m]: slant ranges become horizontal (paper 004 eq 10)")
    depth.add_argument("--depth-log", metavar="DEPTH.csv",
                       help="vehicle depth log (t_s, depth_m): each frame's slant range becomes horizontal with "
                            "the depth at its arrival and --beacon-depth")
    t.add_argument("--beacon-depth", type=float, default=0.0, metavar="M",
                   help="beacon depth [m] with --depth-log (default 0)")
    add_profile_option(t, what="each frame's tof_s becomes the horizontal range of the ray traced through it "
                               "(needs --depth or --depth-log)")
    t.add_argument("--filter", choices=("inertial", "inertial-range", "proposed", "rosb"), default="inertial",
                   help="inertial (range and v_r, default), inertial-range (range only), or paper 000's EKF "
                        "'proposed' / its range-only baseline 'rosb' (paper-faithful: R of eq 25, Q = Δt⁸)")
    smooth = t.add_mutually_exclusive_group()
    smooth.add_argument("--smooth", action="store_true",
                        help="post-process: batch smoother over the whole mission (paper filters: RTS)")
    smooth.add_argument("--fixed-lag", type=float, metavar="S",
                        help="fixed-lag smoother: each state uses the frames up to S seconds later (inertial)")
    t.add_argument("--sigma-range", type=float, metavar="M",
                   help="σ of every range [m], overriding the records' (default: each record's σ, or 0.05 when "
                        "the records carry none)")
    t.add_argument("--sigma-vr", type=float, metavar="MPS",
                   help="σ of every v_r [m/s], overriding the records' (default: each record's σ, or 0.05)")
    t.add_argument("--range-floor", type=float, default=0.01, metavar="M",
                   help="floor of the records' range σ [m] (default 0.01: clock sync, sound speed; see docs)")
    t.add_argument("--vr-floor", type=float, default=0.05, metavar="MPS",
                   help="floor of the records' v_r σ [m/s] (default 0.05: multipath Doppler spread, motion "
                        "during the frame; see docs)")
    t.add_argument("--bearing-floor", type=float, default=0.5, metavar="DEG",
                   help="floor of the records' bearing σ [deg] (default 0.5: array mounting and element position "
                        "errors; see docs); bearings are used when the records carry azimuth_body_rad")
    t.add_argument("--no-bearing", action="store_true",
                   help="ignore the records' azimuth_body_rad (a hydrophone array's bearing)")
    t.add_argument("--r-from-records", action="store_true",
                   help="paper filters: R from each record's σ instead of eq 25 (the inertial filters do it by "
                        "default; accepted and ignored for them)")
    t.add_argument("--gyro-arw", type=float, metavar="RAD/√S",
                   help="gyro angle random walk [rad/√s] (default 0.0354: the paper's IMU)")
    t.add_argument("--accel-vrw", type=float, metavar="MPS/√S",
                   help="accelerometer velocity random walk [m/s/√s] (default 0.0354: the paper's IMU)")
    t.add_argument("--heading-sigma-deg", type=float, metavar="DEG",
                   help="white noise of the heading sensor [deg] (default 1)")
    t.add_argument("--bias-instability-deg-h", type=float, metavar="DEG/H",
                   help="heading bias random walk, as degrees after one hour (default 5)")
    _add_inertial_options(t)
    t.add_argument("--estimate", nargs="+", choices=("bias-drift", "current", "range-scale"), default=(),
                   metavar="STATE",
                   help="extra states of the inertial filter: bias-drift, current (2 states), range-scale")
    t.add_argument("--truth", metavar="TRUTH.csv", help="true track (t_s, x_m, y_m) for error statistics")
    t.add_argument("-o", "--output", required=True, metavar="OUT.csv",
                   help="track output; OUT_frames.csv, OUT.png and OUT.json beside it")
    from .nav_follow import add_follow_options  # --follow: real time, NMEA out (docs/live.md)

    add_follow_options(t)
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
    filters = tuple(f.replace("-", "_") for f in (args.filters or (("proposed", "rosb") if args.paper
                                                                   else ("inertial",))))
    steer = args.steer or ("truth" if args.paper else "estimate")
    if not (args.sigma_bearing >= 0 and math.isfinite(args.sigma_bearing)):
        raise SeamodemError(f"--sigma-bearing: must be >= 0 deg, got {args.sigma_bearing}")
    noise = NoiseModel(heading_bias_model=args.bias_model, sigma_bearing_deg=args.sigma_bearing)
    if not (args.paper or args.paper_noise):  # receiver-grade; NoiseModel's own defaults are the paper's
        noise = replace(noise, sigma_range_m=0.01, sigma_vr_mps=0.02)
    if args.sigma_range is not None:
        noise = replace(noise, sigma_range_m=args.sigma_range)
    if args.sigma_vr is not None:
        noise = replace(noise, sigma_vr_mps=args.sigma_vr)
    error_of = args.error_of.replace("-", "_")
    if error_of != "estimate" and any(f not in ("proposed", "rosb") for f in filters):
        raise SeamodemError("--error-of: applies to the paper's filters only (the inertial filter has "
                            "--filters fixed-lag batch)")
    config = MissionConfig(noise=noise, steer_on_estimate=steer == "estimate", q=args.q, error_of=error_of,
                           lag_s=args.lag)
    if args.matched_r:
        config = replace(config, r_diag=(noise.sigma_range_m**2, noise.sigma_vr_mps**2, *config.r_diag[2:]))
    if args.gate is not None:
        config = replace(config, inertial=replace(config.inertial_config, gate_probability=args.gate))
    if args.window != 120.0 or args.min_speed != 0.0:
        config = replace(config, inertial=replace(config.inertial_config, window_s=args.window,
                                                  min_speed_mps=args.min_speed))
    for t in args.tcom:
        replace(config, tcom_s=t)  # validates every T_com before any work
    out.mkdir(parents=True, exist_ok=True)
    total = len(filters) * len(args.tcom) * args.runs
    with progress_bar(total=total, desc="missions", enabled=False if args.quiet else None) as bar:
        backend = "dask" if args.scheduler else (None if args.backend == "threads" else args.backend)
        result = run_monte_carlo(config, tcoms=tuple(args.tcom), runs=args.runs, seed=args.seed,
                                 filters=filters, workers=args.workers, progress=bar.update, backend=backend,
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
                                           "tcom_s": list(result.tcoms), "filters": list(filters),
                                           "mission": asdict(config),
                                           "inertial_filter": asdict(config.inertial_config)}, indent=1,
                                          default=str) + "\n", encoding="utf-8")
    plot_top_view(result, out / "fig7_top_view.png")
    plot_error_curves(result, out / "fig8_error.png")
    return 0


def run_track(args: argparse.Namespace) -> int:
    import math

    from ..navigation.inertial import InertialConfig
    from ..navigation.track import track_from_files

    overrides = {}
    for name, value in (("gyro_arw", args.gyro_arw), ("accel_vrw", args.accel_vrw)):
        if value is not None:
            overrides[name] = value
    if args.heading_sigma_deg is not None:
        overrides["heading_sigma_rad"] = math.radians(args.heading_sigma_deg)
    if args.bias_instability_deg_h is not None:
        overrides["bias_rw"] = math.radians(args.bias_instability_deg_h) / 60.0  # σ after 3600 s = value
    for state in args.estimate:
        overrides["estimate_" + state.replace("-", "_")] = True
    overrides["window_s"] = args.window
    overrides["min_speed_mps"] = args.min_speed
    smooth = "batch" if args.smooth else ("fixed-lag" if args.fixed_lag is not None else None)
    if args.follow:
        from .nav_follow import follow

        args.profile = sound_speed_profile(args)
        with reported_warnings("nav track"):
            return follow(args, InertialConfig(**overrides), command_line())
    if args.nmea or args.utc_start or args.stall_timeout is not None:
        raise SeamodemError("nmea: --nmea, --utc-start and --stall-timeout go with --follow")
    # what the readers repaired: one line each on stderr (also when the run then fails)
    with reported_warnings("nav track"):
        summary = track_from_files(
            args.measurements,
            args.imu,
            beacon=args.beacon,
            start=args.start,
            start_speed_mps=args.start_speed,
            start_sigma_m=args.start_sigma,
            geodetic=args.geodetic,
            depths=args.depth,
            depth_log=args.depth_log,
            beacon_depth_m=args.beacon_depth,
            sound_speed_profile=sound_speed_profile(args),
            fixes=args.fixes,
            filter=args.filter,
            r_from_records=args.r_from_records,
            smooth=smooth,
            lag_s=args.fixed_lag,
            config=InertialConfig(**overrides),
            range_floor_m=args.range_floor,
            v_r_floor_mps=args.vr_floor,
            sigma_range_m=args.sigma_range,
            sigma_v_r_mps=args.sigma_vr,
            use_bearing=not args.no_bearing,
            bearing_floor_rad=math.radians(args.bearing_floor),  # NaN and inf stay so: run_track refuses them
            truth=args.truth,
            command=command_line(),
            output=args.output,
        )
    print(summary)
    return 0
