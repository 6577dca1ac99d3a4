"""Sound speed as it is in the water: the ray tracer, and what a profile does to ranges and positions.

Run: python benchmarks/bench_sound_speed.py [--quick] [--skip-demo] [--figures docs/images]  (about 5 minutes)

1. Ray tracer against closed forms: a linear gradient c = c0 + g z (rays are circular arcs;
   t = arccosh(1 + g² d² / (2 c_s c_r)) / |g|) at 50 m – 2 km; travel-time and angle errors, and speed
   (eigenrays per second, one geometry at a time and vectorised in a table).
2. TEOS-10 through seamodem.water against gsw called directly, and against Mackenzie.
3. Thermocline (c 1530 → 1490 m/s between 15 and 35 m; beacon 25 m, vehicle 5 m, water 60 m): recordings
   simulated with the ray-traced channel ([water]), received by the receiver at c = 1500 m/s; the
   horizontal range from each frame's time of flight three ways: c = 1500 m/s, the profile's mean c between
   the two depths, and the profile (the direct ray traced). Bias = mean over frames − true range.
4. The demo mission (seamodem demo's survey, beacon 25 m deep, vehicle 5 m) in that water, tracked by the
   inertial filter: c = 1500 m/s, the filter's range-scale state, the profile; and the same mission in
   isovelocity water at 1500 m/s as the reference.

One core; every random draw is seeded.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from seamodem.water import RayTracer, SoundSpeedProfile, TravelTimeTable, sound_speed_mackenzie, sound_speed_teos10
from seamodem.water.closed_form import linear_gradient_arc
from seamodem.water.ranging import ProfileRanging

THERMOCLINE = SoundSpeedProfile([0.0, 15.0, 35.0], [1530.0, 1530.0, 1490.0], source="thermocline")
BEACON_DEPTH, VEHICLE_DEPTH, WATER_DEPTH = 25.0, 5.0, 60.0
GRADIENTS = [(1500.0, 0.05, 200.0, 60.0, 20.0), (1520.0, -0.02, 200.0, 100.0, 50.0), (1500.0, 0.017, 500.0, 300.0, 10.0),
             (1540.0, -0.1, 100.0, 30.0, 10.0)]


def ray_accuracy(ranges) -> None:
    print("1. Ray tracer against the linear gradient's circular arcs (direct ray)")
    print(f"{'c0':>6} {'g [1/s]':>8} {'zs':>5} {'zr':>5} {'R [m]':>6}  {'turns':>5} {'|dt| [ns]':>10} "
          f"{'|d launch| [deg]':>17} {'|d arrival| [deg]':>18}")
    worst_t = worst_a = 0.0
    for c0, g, depth, zs, zr in GRADIENTS:
        tracer = RayTracer(SoundSpeedProfile.linear(c0, g, depth), water_depth_m=depth)
        for r in ranges:
            rays = [e for e in tracer.eigenrays(zs, zr, r) if e.name == "direct"]
            t, launch, arrival = linear_gradient_arc(c0, g, zs, zr, r)
            if not rays:
                print(f"{c0:6g} {g:8g} {zs:5g} {zr:5g} {r:6g}  no direct ray (the arc would leave the water)")
                continue
            e = rays[0]
            dt, dl, da = abs(e.travel_time_s - t), abs(np.degrees(e.launch_angle_rad - launch)), \
                abs(np.degrees(e.arrival_angle_rad - arrival))
            worst_t, worst_a = max(worst_t, dt), max(worst_a, dl, da)
            print(f"{c0:6g} {g:8g} {zs:5g} {zr:5g} {r:6g}  {e.n_turning:5d} {dt * 1e9:10.1e} {dl:17.2e} {da:18.2e}")
    print(f"worst: travel time {worst_t * 1e9:.1e} ns (goal 1000 ns), angle {worst_a:.2e} deg (goal 0.01 deg)\n")


def ray_speed() -> None:
    print("   speed (one core)")
    tracer = RayTracer(THERMOCLINE, water_depth_m=WATER_DEPTH)
    rng = np.random.default_rng(1)
    ranges = rng.uniform(50.0, 1000.0, 200)
    tracer.eigenrays(BEACON_DEPTH, VEHICLE_DEPTH, 300.0)
    t0 = time.perf_counter()
    n = sum(len(tracer.eigenrays(BEACON_DEPTH, VEHICLE_DEPTH, r)) for r in ranges)
    dt = time.perf_counter() - t0
    print(f"   eigenrays(): {ranges.size} geometries, {n} eigenrays (≤ 2 vertices) in {dt:.2f} s: "
          f"{n / dt:,.0f} eigenrays/s, {ranges.size / dt:,.0f} geometries/s")
    grid_r = np.arange(10.0, 1200.0, 1.0)
    grid_z = np.arange(2.0, 8.01, 0.5)
    t0 = time.perf_counter()
    table = TravelTimeTable(tracer, BEACON_DEPTH, grid_z, grid_r, max_vertices=1)
    dt = time.perf_counter() - t0
    nodes = int(np.isfinite(table.time_s).sum())
    print(f"   TravelTimeTable (direct path, {grid_z.size} depths × {grid_r.size} ranges): {dt:.2f} s, "
          f"{nodes / dt:,.0f} direct eigenrays/s")
    zq, rq = rng.uniform(2.0, 8.0, 100_000), rng.uniform(50.0, 1000.0, 100_000)
    t0 = time.perf_counter()
    table.travel_time(zq, rq)
    dt = time.perf_counter() - t0
    print(f"   table look-ups: {zq.size / dt:,.0f} travel times/s")
    exact = np.array([tracer.eigenrays(BEACON_DEPTH, z, r, max_vertices=1)[0].travel_time_s
                      for z, r in zip(zq[:200], rq[:200])])
    err = np.abs(table.travel_time(zq[:200], rq[:200]) - exact)
    back = np.abs(table.horizontal_range(zq[:200], exact) - rq[:200])
    print(f"   table vs tracer (200 random points): travel time max {err.max() * 1e9:.2f} ns, "
          f"range back from time max {back.max() * 1e6:.2f} µm\n")


def teos10() -> None:
    import gsw

    print("2. TEOS-10 (seamodem.water.sound_speed_teos10) against gsw called directly, and Mackenzie (1981)")
    t, s, p = np.meshgrid(np.linspace(0, 30, 16), np.linspace(30, 38, 9), np.linspace(0, 1000, 21), indexing="ij")
    lat, lon = 43.0, 6.0
    ours = sound_speed_teos10(t, s, p, latitude_deg=lat, longitude_deg=lon)
    sa = gsw.SA_from_SP(s, p, lon, lat)
    ref = gsw.sound_speed(sa, gsw.CT_from_t(sa, t, p), p)
    mack = sound_speed_mackenzie(t, s, -gsw.z_from_p(p, lat))
    print(f"   {t.size} (T, S, p) points, 0–30 °C, 30–38 psu, 0–1000 dbar: |ours − gsw| max "
          f"{np.max(np.abs(ours - ref)):.1e} m/s (goal 0.01); |Mackenzie − TEOS-10| max "
          f"{np.max(np.abs(mack - ref)):.3f} m/s, mean {np.mean(np.abs(mack - ref)):.3f} m/s\n")


def _write_beacon(folder: Path, count: int, period_s: float, payloads=None):
    from seamodem import BeaconSchedule, get_preset
    from seamodem.transmit.beacon import write_beacon

    cfg = get_preset("jmse2024")
    write_beacon(folder / "beacon.wav", cfg, BeaconSchedule(count=count, period_s=period_s, start_s=0.1), payloads,
                 progress=False)
    return cfg


def thermocline_bias(ranges, folder: Path) -> None:
    from seamodem.channel import parse_scenario, simulate_file
    from seamodem.demo.mission import receive

    print("3. Thermocline, ray-traced channel ([water]), receiver at c = 1500 m/s: horizontal-range bias [m]")
    c_mean = THERMOCLINE.mean_speed(VEHICLE_DEPTH, BEACON_DEPTH)
    print(f"   profile's mean c between {VEHICLE_DEPTH:g} and {BEACON_DEPTH:g} m: {c_mean:.2f} m/s; "
          "3 frames per range, white noise at 30 dB in-band SNR, surface and bottom echoes (−1, 0.5)")
    print(f"{'R [m]':>7} {'tof err [ns]':>12} {'c=1500':>9} {'mean c':>9} {'profile':>9} {'profile σ':>10} "
          f"{'echo lag [µs]':>14}")
    _write_beacon(folder, 3, 1.0)
    ranging = ProfileRanging(THERMOCLINE, BEACON_DEPTH, [VEHICLE_DEPTH], max_range_m=max(ranges) + 50.0)
    tracer = RayTracer(THERMOCLINE, water_depth_m=WATER_DEPTH)
    dz = BEACON_DEPTH - VEHICLE_DEPTH
    worst = 0.0
    for r in ranges:
        scenario = parse_scenario({
            "mode": "geometry", "seed": 3,
            "environment": {"sound_speed_mps": 1500.0, "water_depth_m": WATER_DEPTH, "absorption": True},
            "beacon": {"position_m": [0.0, 0.0, -BEACON_DEPTH]},
            "vehicle": {"start_m": [float(r), 0.0, -VEHICLE_DEPTH], "velocity_mps": [0.0, 0.0, 0.0]},
            "multipath": {"max_bounces": 1, "surface_reflection": -1.0, "bottom_reflection": 0.5},
            "water": {"depth_m": THERMOCLINE.depth_m.tolist(), "c_mps": THERMOCLINE.c_mps.tolist()},
            "noise": {"kind": "white", "snr_db": 30.0},
        }, base_dir=folder)
        sidecar = simulate_file(folder / "beacon.wav", scenario, folder / "received.wav", progress=False)
        records, _ = receive(folder / "received.wav", sidecar)
        truth = {row["frame_index"]: row for row in sidecar["truth"]}
        tof = np.array([m.tof_s for m in records])
        tof_err = tof - np.array([truth[m.frame_index]["tof_true_s"] for m in records])
        h1500 = np.sqrt(np.maximum((1500.0 * tof) ** 2 - dz * dz, 0.0))
        hmean = np.sqrt(np.maximum((c_mean * tof) ** 2 - dz * dz, 0.0))
        hprof = ranging.horizontal_range(tof, VEHICLE_DEPTH)
        rays = {e.name: e.travel_time_s for e in tracer.eigenrays(BEACON_DEPTH, VEHICLE_DEPTH, float(r), max_vertices=1)}
        lag = rays.get("surface", np.nan) - rays["direct"]
        bias = hprof.mean() - r
        worst = max(worst, abs(bias))
        print(f"{r:7g} {np.mean(tof_err) * 1e9:12.1f} {h1500.mean() - r:9.3f} {hmean.mean() - r:9.3f} {bias:9.4f} "
              f"{hprof.std():10.4f} {lag * 1e6:14.1f}")
    print(f"   worst |bias| with the profile: {worst * 100:.2f} cm (goal ≤ 2 cm at every range)\n")


def _mission_records(cfg, vehicle, folder: Path, water: dict | None):
    """The demo's survey through the channel (beacon 25 m, vehicle 5 m, 60 m of water), received at 1500 m/s."""
    from seamodem.channel import parse_scenario, simulate_file
    from seamodem.demo.mission import make_scenario, receive, records_to_columns, write_track_csv
    from seamodem.transmit import BeaconSchedule, payloads_from_text, write_beacon

    count = cfg.frame_count()
    write_beacon(folder / "beacon.wav", cfg.frame_config, BeaconSchedule(count=count, period_s=cfg.tcom_s),
                 payloads_from_text("seamodem demo frame {index}", count), progress=False)
    write_track_csv(folder / "vehicle_track.csv", vehicle, VEHICLE_DEPTH)
    tables = make_scenario(cfg, folder / "vehicle_track.csv")
    tables["beacon"] = {"position_m": [*cfg.beacon_xy_m, -BEACON_DEPTH]}
    tables["environment"]["water_depth_m"] = WATER_DEPTH
    if water is not None:
        tables["water"] = water
    sidecar = simulate_file(folder / "beacon.wav", parse_scenario(tables, base_dir=folder), folder / "received.wav",
                            progress=False)
    records, _ = receive(folder / "received.wav", sidecar)
    return records_to_columns(records)


def _position_error(meas, vehicle, cfg, **options) -> float:
    from seamodem.navigation.track import run_track

    out = run_track(meas, vehicle.imu, beacon_xy=cfg.beacon_xy_m, start_xy=tuple(vehicle.xy_m[0]),
                    start_speed_mps=float(vehicle.speed_mps[0]), filter="inertial",
                    depths=(VEHICLE_DEPTH, BEACON_DEPTH), **options)
    truth = np.column_stack([np.interp(out["t_s"], vehicle.t_s, vehicle.xy_m[:, k]) for k in (0, 1)])
    return float(np.mean(np.hypot(*(out["state"][:, :2] - truth).T)))


def demo_mission(folder: Path, seeds) -> None:
    from seamodem.demo import DemoConfig
    from seamodem.demo.mission import simulate_vehicle
    from seamodem.navigation.inertial import InertialConfig

    d = DemoConfig()
    print(f"4. The demo mission ({d.n_lanes} lanes of {d.lane_length_m:g} m, a frame every {d.tcom_s:g} s, "
          f"{d.snr_db:g} dB SNR, {d.mission_s():.0f} s) with the beacon {BEACON_DEPTH:g} m deep and the vehicle at "
          f"{VEHICLE_DEPTH:g} m in {WATER_DEPTH:g} m of water; inertial filter, depths known; mean position error [m]")
    print(f"{'seed':>5} {'isovelocity 1500':>17} {'c=1500':>9} {'range-scale':>12} {'profile':>9} "
          f"{'profile/iso':>12}")
    water = {"depth_m": THERMOCLINE.depth_m.tolist(), "c_mps": THERMOCLINE.c_mps.tolist()}
    rows = []
    for seed in seeds:
        cfg = DemoConfig(seed=seed, water_depth_m=WATER_DEPTH)
        vehicle = simulate_vehicle(cfg, t_end_s=cfg.mission_s() + 2.0, rng=np.random.default_rng(seed))
        iso = _mission_records(cfg, vehicle, folder, None)
        thermo = _mission_records(cfg, vehicle, folder, water)
        row = (_position_error(iso, vehicle, cfg), _position_error(thermo, vehicle, cfg),
               _position_error(thermo, vehicle, cfg, config=InertialConfig(estimate_range_scale=True)),
               _position_error(thermo, vehicle, cfg, sound_speed_profile=THERMOCLINE))
        rows.append(row)
        print(f"{seed:5d} {row[0]:17.3f} {row[1]:9.3f} {row[2]:12.3f} {row[3]:9.3f} {row[3] / row[0]:12.3f}")
    m = np.mean(rows, axis=0)
    print(f"{'mean':>5} {m[0]:17.3f} {m[1]:9.3f} {m[2]:12.3f} {m[3]:9.3f} {m[3] / m[0]:12.3f}")
    print("   goal: with the profile within 10 % of the isovelocity mission's error\n")


def figures(folder: Path) -> None:
    from seamodem.plots import pyplot, save_figure
    from seamodem.water.plot import plot_profile

    folder.mkdir(parents=True, exist_ok=True)
    plot_profile(THERMOCLINE, folder / "sound_speed_thermocline.png",
                 depths_m={"beacon": BEACON_DEPTH, "vehicle": VEHICLE_DEPTH}, water_depth_m=WATER_DEPTH)
    tracer = RayTracer(THERMOCLINE, water_depth_m=WATER_DEPTH)
    ranges = np.arange(20.0, 1001.0, 10.0)
    table = TravelTimeTable(tracer, BEACON_DEPTH, [VEHICLE_DEPTH], ranges, max_vertices=1)
    t = table.time_s[0]
    dz = BEACON_DEPTH - VEHICLE_DEPTH
    c_mean = THERMOCLINE.mean_speed(VEHICLE_DEPTH, BEACON_DEPTH)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    for c, label in ((1500.0, "c = 1500 m/s"), (c_mean, f"mean c = {c_mean:g} m/s")):
        ax.plot(ranges, np.sqrt(np.maximum((c * t) ** 2 - dz * dz, 0)) - ranges, label=label)
    ax.plot(ranges, table.horizontal_range(VEHICLE_DEPTH, t) - ranges, label="profile (traced ray)")
    ax.set_xlabel("horizontal range [m]")
    ax.set_ylabel("range error [m]")
    ax.set_title("Thermocline: range from the direct ray's travel time", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, folder / "sound_speed_range_bias.png")
    print(f"figures in {folder}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer ranges and one demo seed")
    parser.add_argument("--figures", metavar="DIR", help="write the profile and range-bias figures to DIR")
    parser.add_argument("--skip-demo", action="store_true", help="leave out part 4 (the mission, the slowest)")
    args = parser.parse_args()
    ray_accuracy([50.0, 200.0, 1000.0, 2000.0] if args.quick else [50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0])
    ray_speed()
    teos10()
    with tempfile.TemporaryDirectory() as tmp:
        thermocline_bias([50.0, 200.0, 1000.0] if args.quick else [50.0, 100.0, 200.0, 300.0, 500.0, 700.0, 1000.0],
                         Path(tmp))
        if not args.skip_demo:
            demo_mission(Path(tmp), [1] if args.quick else [1, 2, 3])
    if args.figures:
        figures(Path(args.figures))


if __name__ == "__main__":
    main()
