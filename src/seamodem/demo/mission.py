"""The demo mission's steps (vehicle, beacon and channel, receiver, navigation, array) and :func:`run_demo`."""

from __future__ import annotations

import json
import math
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..config import FrameConfig
from .config import FILTERS, DemoConfig, VehicleRun, receiver_settings
from .figures import plot_constellation, plot_errors, plot_map, plot_psd
from .summary import mission_summary, rms

__all__ = ["DemoResult", "simulate_vehicle", "make_scenario", "write_track_csv", "emit_and_propagate",
           "receive", "measurement_errors", "records_to_columns", "emulate_measurements", "navigate",
           "array_mission", "run_demo"]


def simulate_vehicle(cfg: DemoConfig, *, t_end_s: float, rng: np.random.Generator) -> VehicleRun:
    """Run the vehicle along the survey from t = 0 to ``t_end_s`` [s] (controller on the truth).

    The vehicle starts on the path with its heading and speed; the controller
    (paper 000 eq 2, limits |Ω| ≤ 0.5 rad/s, |a| ≤ 0.5 m/s²) steers on the true
    state — the recording must exist before the filters run, so they cannot
    close the loop. IMU: :mod:`seamodem.navigation.imu` (the Monte Carlo's model),
    its bias random walk starting from one step's draw rather than from 0 (the
    sensor ran before the mission began).

    Parameters
    ----------
    cfg : DemoConfig
        The mission (survey, speed, IMU noise, Δt).
    t_end_s : float
        Last time to simulate [s].
    rng : numpy.random.Generator
        Draws the IMU noise.

    Returns
    -------
    VehicleRun
        True track and IMU/AHRS readings every Δt.
    """
    from ..navigation.imu import imu_sigmas, simulate_imu
    from ..navigation.vehicle import feedback_command, vehicle_step

    path = cfg.path()
    dt = cfg.dt_s
    n = int(math.ceil(t_end_s / dt)) + 1
    t = np.arange(n) * dt
    ref = path.sample(t)
    x, y = ref.position[0]
    psi = math.atan2(ref.velocity[0, 1], ref.velocity[0, 0])
    v = float(np.hypot(*ref.velocity[0]))
    v_min, v_max, omega_max, accel_max = 0.1, 3.0, 0.5, 0.5
    xy, heading, speed = np.zeros((n, 2)), np.zeros(n), np.zeros(n)
    omega_true, accel_true = np.zeros(n), np.zeros(n)
    xy[0], heading[0], speed[0] = (x, y), psi, v
    for k in range(n):
        omega, accel = feedback_command(x, y, psi, v, *ref.position[k], *ref.velocity[k], *ref.acceleration[k],
                                        v_min, omega_max, accel_max)
        if k + 1 < n:
            v_old = v
            x, y, psi, v = vehicle_step(x, y, psi, v, omega, accel, dt, v_min, v_max)
            xy[k + 1], heading[k + 1], speed[k + 1] = (x, y), psi, v
            omega_true[k + 1], accel_true[k + 1] = omega, (v - v_old) / dt
    sigmas = imu_sigmas(sigma_heading_deg=cfg.sigma_heading_deg, heading_drift_deg_per_h=cfg.heading_drift_deg_per_h,
                        sigma_omega_rad_s=cfg.sigma_omega_rad_s, sigma_accel_mps2=cfg.sigma_accel_mps2, dt_s=dt)
    noise = rng.standard_normal((n, 4))
    readings, _ = simulate_imu(heading, omega_true, accel_true, noise, sigmas, dt_s=dt,
                               bias0_rad=sigmas[3] * noise[0, 3])
    return VehicleRun(t, xy, heading, speed, {"t_s": t, **readings})


def make_scenario(cfg: DemoConfig, track_csv: Path) -> dict[str, Any]:
    """The channel scenario (the TOML tables as a dict) for the vehicle track in ``track_csv``.

    Parameters
    ----------
    cfg : DemoConfig
        The mission (beacon, depths, sound speed, reflections, SNR [dB], seed).
    track_csv : Path
        The vehicle's track (:func:`write_track_csv`); the scenario names it relative to its folder.

    Returns
    -------
    dict
        The scenario's tables (:func:`seamodem.channel.parse_scenario` reads it).
    """
    return {
        "mode": "geometry",
        "seed": cfg.seed,
        "description": "seamodem demo: survey around a fixed beacon",
        "environment": {"sound_speed_mps": cfg.sound_speed_mps, "water_depth_m": cfg.water_depth_m},
        "beacon": {"position_m": [*cfg.beacon_xy_m, -cfg.depth_m]},
        "vehicle": {"track_file": track_csv.name},
        "multipath": {"max_bounces": 1, "surface_reflection": cfg.surface_reflection,
                      "bottom_reflection": cfg.bottom_reflection},
        "noise": {"kind": "white", "snr_db": cfg.snr_db},
    }


def write_track_csv(path: Path, vehicle: VehicleRun, depth_m: float) -> None:
    """The true track as the channel reads it: ``t_s,x_m,y_m,z_m`` (z up).

    Parameters
    ----------
    path : Path
        CSV file written.
    vehicle : VehicleRun
        The true vehicle.
    depth_m : float
        Its depth [m] (z = −depth).

    Returns
    -------
    None
    """
    rows = np.column_stack([vehicle.t_s, vehicle.xy_m, np.full(vehicle.t_s.size, -depth_m)])
    np.savetxt(path, rows, delimiter=",", header="t_s,x_m,y_m,z_m", comments="", fmt="%.6f")


def emit_and_propagate(cfg: DemoConfig, vehicle: VehicleRun, folder: Path, *, progress: bool | None = False) -> dict:
    """Write ``beacon.wav`` (frames, or JANUS packets: :mod:`.janus`) and ``received.wav`` in ``folder``.

    Parameters
    ----------
    cfg : DemoConfig
        The mission.
    vehicle : VehicleRun
        The true vehicle (its track is written to ``folder``/vehicle_track.csv for the channel).
    folder : Path
        Where the recordings go.
    progress : bool or None
        Progress bars of the beacon and the channel (None: when stderr is a terminal).

    Returns
    -------
    dict
        The received recording's sidecar (with the channel's ``truth`` per frame).
    """
    from ..channel import parse_scenario, simulate_file
    from ..transmit import BeaconSchedule, payloads_from_text, write_beacon

    folder = Path(folder)
    count = cfg.frame_count()
    schedule = BeaconSchedule(count=count, period_s=cfg.tcom_s)
    if cfg.waveform == "janus":
        from .janus import write_janus_demo_beacon

        write_janus_demo_beacon(folder / "beacon.wav", cfg, schedule)
    else:
        payloads = payloads_from_text("seamodem demo frame {index}", count)
        write_beacon(folder / "beacon.wav", cfg.frame_config, schedule, payloads, command="seamodem demo",
                     progress=progress)
    track = folder / "vehicle_track.csv"
    write_track_csv(track, vehicle, cfg.depth_m)
    scenario = parse_scenario(make_scenario(cfg, track), base_dir=folder)
    return simulate_file(folder / "beacon.wav", scenario, folder / "received.wav", command="seamodem demo",
                         progress=progress)


@dataclass
class _FrameGrab:
    """Keeps the baseband of one frame (the receiver's ``on_frame`` hook) for the constellation plot."""

    wanted: int
    frame: tuple | None = None
    seen: int = 0

    def __call__(self, m, bb, t0_s, fs):
        if self.seen == self.wanted:
            self.frame = (m, bb.copy(), t0_s, fs)
        self.seen += 1


def receive(recording: Path, sidecar: dict, *, grab_frame: int | None = None):
    """Measure and decode every frame (or JANUS packet: :mod:`.janus`) of ``recording``.

    Parameters
    ----------
    recording : Path
        The received recording.
    sidecar : dict
        Its sidecar (frame configuration, emission times, payloads, sound speed).
    grab_frame : int, optional
        Keep the baseband of this frame (0-based among those found) for the constellation plot.

    Returns
    -------
    records : list of MeasurementRecord
        One per frame found.
    grabbed : tuple or None
        (measurement, baseband, t0 [s], fs [Hz]) of the grabbed frame.
    """
    from ..io.sidecar import sidecar_payloads
    from ..receive import Emissions, receive_file

    if "janus" in sidecar:
        from .janus import receive_janus_recording

        return receive_janus_recording(recording, sidecar), None
    config = FrameConfig.from_dict(sidecar["config"])
    times = np.array([f["t_emit_s"] for f in sidecar["frames"]])
    grab = _FrameGrab(grab_frame) if grab_frame is not None else None
    records = list(receive_file(recording, config, emissions=Emissions(times_s=times), settings=receiver_settings(sidecar),
                                payloads=sidecar_payloads(sidecar), on_frame=grab, progress=False))
    return records, (grab.frame if grab else None)


def measurement_errors(records, truth: list[dict]) -> dict[str, np.ndarray]:
    """Per detected frame: arrival time, range and v_r errors against the channel's truth (direct path).

    Parameters
    ----------
    records : list of MeasurementRecord
        The receiver's records.
    truth : list of dict
        The channel's truth per frame (sidecar ``truth``).

    Returns
    -------
    dict of ndarray
        ``frame_index``, ``t_arrival_s`` [s], ``range_error_m`` [m], ``v_r_error_mps`` [m/s], ``snr_db`` and
        ``true_snr_db`` [dB].
    """
    by_index = {row["frame_index"]: row for row in truth}
    rows = [(r, by_index[r.frame_index]) for r in records if r.frame_index in by_index]
    return {
        "frame_index": np.array([r.frame_index for r, _ in rows], dtype=int),
        "t_arrival_s": np.array([r.t_arrival_s for r, _ in rows]),
        "range_error_m": np.array([r.range_m - t["range_m"] for r, t in rows]),
        "v_r_error_mps": np.array([r.v_r_mps - t["v_r_mps"] for r, t in rows]),
        "snr_db": np.array([r.snr_db for r, _ in rows]),
        "true_snr_db": np.array([t["snr_db"] for _, t in rows]),
    }


def records_to_columns(records) -> dict[str, np.ndarray]:
    """Measurement records as the column dict :func:`~seamodem.navigation.track.run_track` reads.

    Parameters
    ----------
    records : list of MeasurementRecord
        The receiver's records.

    Returns
    -------
    dict of ndarray
        ``frame_index``, ``t_emit_s``, ``t_arrival_s``, ``tof_s`` [s], ``range_m`` [m], ``v_r_mps`` [m/s],
        ``snr_db`` [dB], and the records' ``sigma_range_m`` [m] and ``sigma_v_r_mps`` [m/s]: the filters
        weight each frame by them as ``seamodem nav track`` does on the demo's measurements.csv.
    """
    names = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db", "sigma_range_m",
             "sigma_v_r_mps")
    return {n: np.array([getattr(r, n) for r in records], dtype=float) for n in names}


def emulate_measurements(truth: list[dict], frame_index, *, sigma_range_m: float, sigma_v_r_mps: float,
                         rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Range and v_r from the geometry (the channel's truth) plus white Gaussian noise, for the given frames.

    Parameters
    ----------
    truth : list of dict
        The channel's truth per frame.
    frame_index : array_like
        Frames to emulate.
    sigma_range_m : float
        Range noise [m].
    sigma_v_r_mps : float
        v_r noise [m/s].
    rng : numpy.random.Generator
        Draws the noise.

    Returns
    -------
    dict of ndarray
        The columns of :func:`records_to_columns`.
    """
    by_index = {row["frame_index"]: row for row in truth}
    rows = [by_index[int(k)] for k in frame_index]
    n = len(rows)
    return {
        "frame_index": np.array([r["frame_index"] for r in rows], dtype=float),
        "t_emit_s": np.array([r["t_emit_s"] for r in rows]),
        "t_arrival_s": np.array([r["t_arrival_s"] for r in rows]),
        "tof_s": np.array([r["tof_s"] for r in rows]),
        "range_m": np.array([r["range_true_m"] for r in rows]) + sigma_range_m * rng.standard_normal(n),
        "v_r_mps": np.array([r["v_r_true_mps"] for r in rows]) + sigma_v_r_mps * rng.standard_normal(n),
        "snr_db": np.array([r["snr_db"] for r in rows]),
        "sigma_range_m": np.full(n, sigma_range_m),  # the noise drawn, as a record states its own
        "sigma_v_r_mps": np.full(n, sigma_v_r_mps),
    }


def navigate(meas: dict, vehicle: VehicleRun, cfg: DemoConfig, *, filter: str) -> dict[str, np.ndarray]:
    """Run one filter; return its estimate and position error at the IMU instants.

    The filter starts at the true position and speed (a GNSS fix before
    diving), as in paper 000's Monte Carlo.

    Parameters
    ----------
    meas : dict of ndarray
        Measurement columns (:func:`records_to_columns`).
    vehicle : VehicleRun
        The true vehicle and its IMU.
    cfg : DemoConfig
        The mission (beacon position).
    filter : str
        One of :data:`~.config.FILTERS`.

    Returns
    -------
    dict of ndarray
        ``t_s`` [s], ``xy_m`` (n, 2) [m] and ``error_m`` [m] at the IMU instants.
    """
    from ..navigation.track import run_track

    smooth = "batch" if filter == "batch" else None
    out = run_track(meas, vehicle.imu, beacon_xy=cfg.beacon_xy_m, start_xy=tuple(vehicle.xy_m[0]),
                    start_speed_mps=float(vehicle.speed_mps[0]), filter="inertial" if smooth else filter,
                    smooth=smooth)
    # keep the state after each IMU sample (acoustic updates fall between them)
    t = out["t_s"]
    last = np.r_[t[1:] != t[:-1], True]
    t, state = t[last], out["state"][last]
    on_grid = np.isin(t, vehicle.t_s)
    t, state = t[on_grid], state[on_grid]
    idx = np.searchsorted(vehicle.t_s, t)
    error = np.hypot(*(state[:, :2] - vehicle.xy_m[idx]).T)
    return {"t_s": t, "xy_m": state[:, :2], "error_m": error}


def array_mission(cfg: DemoConfig, vehicle: VehicleRun, folder: Path, sidecar: dict) -> tuple[list, dict]:
    """Step 7: the beacon in ``folder``/beacon.wav through ``cfg.array`` along the vehicle's track.

    The array recording (same scenario, seed and SNR per element as the
    single hydrophone's) is received twice: by :func:`~seamodem.receive.array.receive_array`
    on all channels, and by the single-hydrophone receiver on element 0 alone.

    Parameters
    ----------
    cfg : DemoConfig
        The mission, with ``array`` set.
    vehicle : VehicleRun
        The true vehicle.
    folder : Path
        Holds beacon.wav and vehicle_track.csv (:func:`emit_and_propagate`).
    sidecar : dict
        The single hydrophone's sidecar (emission times, payloads, sound speed).

    Returns
    -------
    records : list of MeasurementRecord
        The array receiver's (with ``azimuth_body_rad`` …).
    summary : dict
        Both receivers' frames found, CRC ok, range RMSE; the array's azimuth
        error against the truth (RMS, median σ, share within 3σ) and the
        one-frame fix's horizontal error (range + body azimuth + the AHRS
        heading at the frame + the true depth).
    """
    import soundfile

    from ..channel import parse_scenario
    from ..channel.array import load_array, simulate_array
    from ..io.sidecar import sidecar_payloads
    from ..navigation.bearing import single_frame_fix
    from ..receive import Emissions, Receiver
    from ..receive.array import receive_array

    array = load_array(cfg.array)
    config = cfg.frame_config
    x, fs = soundfile.read(str(Path(folder) / "beacon.wav"), dtype="float64")
    times = np.array([f["t_emit_s"] for f in sidecar["frames"]])
    scenario = parse_scenario(make_scenario(cfg, Path(folder) / "vehicle_track.csv"), base_dir=folder)
    sim = simulate_array(x, fs, scenario, array, t_emit_s=times, frame_duration_s=config.frame_duration_s,
                         band_hz=config.data_band_hz)
    del x
    settings = receiver_settings(sidecar)
    payloads = sidecar_payloads(sidecar)
    emissions = Emissions(times_s=times)
    records, _ = receive_array(sim.output, fs, config, array.element_positions_m, emissions=emissions,
                               settings=settings, complex_gains=array.complex_gains,
                               position_sigma_m=array.position_sigma_m, payloads=payloads, assume=array.assume)
    one = list(Receiver(config, emissions=emissions, settings=settings, payloads=payloads).run([sim.output[:, 0]], fs=fs))
    truth = {row["frame_index"]: row for row in sim.truth}
    sent = {f["frame_index"]: f["payload_hex"] for f in sidecar["frames"]}

    c = settings.sound_speed_mps

    def receiver_summary(recs, element=None):
        """Frames, FER and range RMSE; one element's range is to that element (the array's to its body origin)."""
        matched = [(r, truth[r.frame_index]) for r in recs if r.frame_index in truth]
        ok = [r for r, _ in matched if r.crc_ok and r.payload_hex == sent.get(r.frame_index)]
        lever = [0.0 if element is None else c * (t["element_t_arrival_s"][element] - t["t_arrival_s"])
                 for _, t in matched]
        return {"frames_detected": len(recs), "payloads_correct": len(ok),
                "fer": 1.0 - len(ok) / max(len(truth), 1),
                "range_rmse_m": rms([r.range_m - t["range_m"] - d for (r, t), d in zip(matched, lever)])}

    az_err, z_az, fix_err = [], [], []
    for r in records:
        row = truth.get(r.frame_index)
        if row is None or not math.isfinite(r.azimuth_body_rad):
            continue
        e = math.remainder(r.azimuth_body_rad - row["paths"][0]["azimuth_body_rad"], 2 * math.pi)
        az_err.append(e)
        z_az.append(abs(e) / r.sigma_azimuth_body_rad)
        heading = float(np.interp(r.t_arrival_s, vehicle.imu["t_s"], np.unwrap(vehicle.imu["heading_rad"])))
        fix = single_frame_fix(r.range_m, r.azimuth_body_rad, heading, [*cfg.beacon_xy_m, -cfg.depth_m],
                               sigma_range_m=r.sigma_range_m, sigma_azimuth_rad=r.sigma_azimuth_body_rad,
                               sigma_heading_rad=math.radians(cfg.sigma_heading_deg), z_m=-cfg.depth_m)
        true_xy = [np.interp(r.t_arrival_s, vehicle.t_s, vehicle.xy_m[:, i]) for i in (0, 1)]
        fix_err.append(float(np.hypot(fix.x_m - true_xy[0], fix.y_m - true_xy[1])))
    summary = {
        "spec": cfg.array,
        "n_elements": int(array.n_elements),
        "aperture_m": array.aperture_m,
        "array": receiver_summary(records),
        "one_hydrophone": receiver_summary(one, element=0),
        "azimuth_rmse_deg": math.degrees(rms(az_err)),
        "azimuth_sigma_median_deg": math.degrees(float(np.median([r.sigma_azimuth_body_rad for r in records])))
        if records else math.nan,
        "azimuth_within_3_sigma": float(np.mean(np.array(z_az) <= 3)) if z_az else math.nan,
        "one_frame_fix_median_error_m": float(np.median(fix_err)) if fix_err else math.nan,
        "one_frame_fix_rms_error_m": rms(fix_err),
        "definition": "same beacon, scenario and SNR per element; one hydrophone = element 0 of the array recording "
                      "(its range against the range to that element, the array's against the body origin's); "
                      "one-frame fix = range + body azimuth + AHRS heading + true depth, no filter",
    }
    return records, summary


@dataclass
class DemoResult:
    """What :func:`run_demo` measured (``summary`` is also written as ``summary.json``).

    Parameters
    ----------
    config : DemoConfig
        The mission.
    summary : dict
        :func:`~.summary.mission_summary` with the total wall time.
    vehicle : VehicleRun
        The true vehicle.
    errors : dict
        The receiver's measurement errors (:func:`measurement_errors`).
    tracks : dict
        ``(source, filter)`` → track (:func:`navigate`).
    files : list of str
        Files written in the output folder.
    """

    config: DemoConfig
    summary: dict
    vehicle: VehicleRun
    errors: dict
    tracks: dict = field(default_factory=dict)
    files: list = field(default_factory=list)


def run_demo(cfg: DemoConfig = DemoConfig(), output_dir: str | Path = "demo_out", *, keep_audio: bool = False,
             plots: bool = True, images_dir: str | Path | None = None, progress: bool | None = False) -> DemoResult:
    """The whole mission: simulate, record, receive, decode, navigate; write summary, config and figures.

    Parameters
    ----------
    cfg : DemoConfig
    output_dir : str or Path
        Created if missing. Receives ``summary.json``, ``demo_config.json``,
        ``measurements.csv``, ``imu.csv``, ``truth.csv``, ``track_<filter>.csv``
        and the figures ``map.png``, ``errors.png``, ``psd.png``, ``constellation.png``.
    keep_audio : bool
        Also keep ``beacon.wav``, ``received.wav`` and their sidecars (≈ 90 MB
        for the default mission); otherwise they live in a temporary folder.
    images_dir : str or Path, optional
        Also copy ``map.png`` there as ``demo_map.png`` (the README's picture).
    plots : bool
        Draw the figures.
    progress : bool or None
        Progress bars of the beacon and the channel, and one over the mission's stages (receiver, filters,
        files): None shows them only when stderr is a terminal. The first run on a machine spends about a
        minute in the filters' stage while numba compiles their kernels; the bar says which stage is running.

    Returns
    -------
    DemoResult
    """
    from .._progress import progress_bar

    # every stage drawn (mininterval 0: four updates in all)
    with progress_bar(total=4, desc="demo: beacon and channel", unit="stage", enabled=progress,
                      mininterval=0) as stages:
        return _run_demo(cfg, Path(output_dir), keep_audio=keep_audio, plots=plots, images_dir=images_dir,
                         progress=progress, stages=stages)


def _stage(bar, desc: str) -> None:
    """The stage bar: the last stage done, the next one named."""
    bar.update(1)
    bar.set_description_str(desc)


def _run_demo(cfg: DemoConfig, out: Path, *, keep_audio: bool, plots: bool, images_dir, progress, stages
              ) -> DemoResult:
    """:func:`run_demo`'s work, its stages on the bar ``stages``."""
    from ..receive import write_measurements

    out.mkdir(parents=True, exist_ok=True)
    clock = {"start": time.perf_counter()}
    rng_imu, rng_emul = (np.random.default_rng(s) for s in np.random.SeedSequence(cfg.seed).spawn(2))
    count = cfg.frame_count()
    # the vehicle must be simulated past the last frame's reception (a frame, plus the travel time, plus margin)
    t_end = count * cfg.tcom_s + cfg.emission_s + 2.0
    vehicle = simulate_vehicle(cfg, t_end_s=t_end, rng=rng_imu)

    with tempfile.TemporaryDirectory(prefix="seamodem-demo-") as tmp:
        audio = out if keep_audio else Path(tmp)
        sidecar = emit_and_propagate(cfg, vehicle, audio, progress=progress)
        clock["channel"] = time.perf_counter()
        _stage(stages, f"demo: receiver and decoder ({count} frames)")
        grab_at = count // 2
        records, grabbed = receive(audio / "received.wav", sidecar, grab_frame=grab_at)
        clock["receiver"] = time.perf_counter()
        psd = _psd(audio / "received.wav", sidecar) if plots and cfg.waveform == "frame" else None
        array_records, array_summary = array_mission(cfg, vehicle, audio, sidecar) if cfg.array else (None, None)
        clock["array"] = time.perf_counter()
    _stage(stages, "demo: filters (about a minute on a first run, while numba compiles them)")
    truth = sidecar["truth"]
    errs = measurement_errors(records, truth)
    sigma_r, sigma_v = rms(errs["range_error_m"]), rms(errs["v_r_error_mps"])
    meas = records_to_columns(records)
    emulated = emulate_measurements(truth, errs["frame_index"], sigma_range_m=sigma_r, sigma_v_r_mps=sigma_v,
                                    rng=rng_emul)
    tracks = {}
    for f in FILTERS:
        tracks[("waveform", f)] = navigate(meas, vehicle, cfg, filter=f)
        tracks[("emulated", f)] = navigate(emulated, vehicle, cfg, filter=f)
    clock["navigation"] = time.perf_counter()
    _stage(stages, "demo: files and figures")

    summary = mission_summary(cfg, vehicle, sidecar, records, errs, tracks, clock, array_summary)

    files = []
    config_json = {"demo": asdict(cfg), "frame": cfg.frame_config.to_dict(),
                   "scenario": sidecar["channel"]["scenario"], "channel_noise": sidecar["channel"]["noise"]}
    header = {"created_by": "seamodem demo", "recording": "received.wav",
              "sample_rate_hz": sidecar["recording"]["sample_rate_hz"],
              "sound_speed_mps": sidecar["channel"]["sound_speed_mps"], "clock_offset_s": 0.0, "turnaround_s": None,
              "decode": True, "config": cfg.frame_config.to_dict()}
    config_json, header, columns = _waveform_outputs(cfg, config_json, header, sidecar)
    (out / "demo_config.json").write_text(json.dumps(config_json, indent=1) + "\n", encoding="utf-8")
    write_measurements(out / "measurements.csv", records, header, **columns)
    _write_csv(out / "imu.csv", vehicle.imu)
    _write_csv(out / "truth.csv", {"t_s": vehicle.t_s, "x_m": vehicle.xy_m[:, 0], "y_m": vehicle.xy_m[:, 1]})
    for f in FILTERS:
        tr = tracks[("waveform", f)]
        _write_csv(out / f"track_{f}.csv", {"t_s": tr["t_s"], "x_m": tr["xy_m"][:, 0], "y_m": tr["xy_m"][:, 1],
                                             "error_m": tr["error_m"]})
    files += ["demo_config.json", "measurements.csv", "measurements.csv.json", "imu.csv", "truth.csv"]
    if array_records is not None:
        from ..channel.array import load_array

        write_measurements(out / "measurements_array.csv", array_records,
                           header | {"array": {"spec": cfg.array, **load_array(cfg.array).to_dict()}})
        files += ["measurements_array.csv", "measurements_array.csv.json"]
    files += [f"track_{f}.csv" for f in FILTERS]
    if plots:
        plot_map(out / "map.png", cfg, vehicle, tracks, summary)
        plot_errors(out / "errors.png", tracks, errs)
        if psd is not None:  # frames only, as the constellation
            plot_psd(out / "psd.png", psd, cfg.frame_config)
        if grabbed is not None:
            plot_constellation(out / "constellation.png", grabbed, cfg.frame_config, sidecar)
        files += ["map.png", "errors.png"] + ["psd.png", "constellation.png"] * (cfg.waveform == "frame")
        if images_dir is not None:
            import shutil

            Path(images_dir).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(out / "map.png", Path(images_dir) / "demo_map.png")
    summary["wall_time_s"]["total"] = time.perf_counter() - clock["start"]
    stages.update(1)
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    files.append("summary.json")
    if keep_audio:
        files += ["beacon.wav", "beacon.json", "received.wav", "received.json", "vehicle_track.csv"]
    return DemoResult(cfg, summary, vehicle, errs, tracks, files)


def _waveform_outputs(cfg: DemoConfig, config_json: dict, header: dict, sidecar: dict):
    """demo_config.json, the measurement header and its extra columns for ``cfg.waveform`` (:mod:`.janus`)."""
    if cfg.waveform == "janus":
        from .janus import janus_outputs

        return janus_outputs(config_json, header, sidecar)
    del config_json["demo"]["waveform"]  # the frame demo's files as before the option
    return config_json, header, {}


def _write_csv(path: Path, columns: dict) -> None:
    data = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()])
    np.savetxt(path, data, delimiter=",", header=",".join(columns), comments="", fmt="%.9g")


def _psd(recording: Path, sidecar: dict):
    """Welch PSD of the received recording over the first frame's reception window."""
    import soundfile
    from scipy.signal import welch

    fs = sidecar["recording"]["sample_rate_hz"]
    first = sidecar["truth"][0]
    start = int(first["t_arrival_s"] * fs)
    x, _ = soundfile.read(str(recording), start=start, frames=int(first["reception_duration_s"] * fs),
                          dtype="float64")
    f, pxx = welch(x, fs=fs, nperseg=4096)
    return f, pxx
