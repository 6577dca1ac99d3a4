"""The mission demo: one vehicle positioned from the very frames it decodes (``seamodem demo``).

The whole chain, offline, in well under a minute:

1. **vehicle** — a short boustrophedon survey (:mod:`seamodem.navigation.trajectories`),
   followed by the unicycle of paper 000 eq 3–4 under the controller of eq 2
   (:mod:`seamodem.navigation.vehicle`), at Δt = 0.25 s, with its IMU/AHRS
   (heading with white noise and a drifting bias, gyro, accelerometer);
2. **beacon** — a fixed beacon emits a jmse2024 frame every T_com
   (:func:`seamodem.transmit.write_beacon`);
3. **channel** — the simulator (:func:`seamodem.channel.simulate_file`) makes the
   hydrophone recording along the vehicle's true track: geometry-driven Doppler
   on every path, surface and bottom echoes, spreading and absorption, white
   noise at a stated in-band SNR, and the truth of every frame;
4. **receiver** — :func:`seamodem.receive.receive_file` detects every frame,
   measures range and closing speed, and decodes the payload;
5. **navigation** — the inertial filter (IMU as input, heading bias as a state) and
   its batch smoother, beside the 6-state EKF of paper 000 ("proposed": range + v_r)
   and its range-only baseline ("rosb"), position the vehicle from those records
   plus the IMU (:func:`seamodem.navigation.track.run_track`);
6. **emulated twin** — the same mission, the same IMU samples, but range and v_r
   emulated from the geometry with the noise levels the receiver actually
   showed (its RMS errors against the truth): what a simulation without the
   waveform would predict.
7. **hydrophone array** (``array``, ``seamodem demo --array SPEC``) — the same
   beacon recorded by a small array on the vehicle (:func:`seamodem.channel.array.simulate_array`,
   the same SNR per element), received with :func:`seamodem.receive.array.receive_array`
   (detection and decoding on all channels, direction of arrival per frame)
   beside one of its hydrophones alone: frames found and decoded, range, the
   beacon's body azimuth against the truth, and the position of a one-frame
   fix (range + body azimuth + the AHRS heading + depth) with no filter.

Every step is a function here, so ``examples/mission_demo.py`` can run them one
by one. :func:`run_demo` chains them and writes the outputs.
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._version import __version__
from .config import FrameConfig, get_preset
from .errors import ConfigError
from .plots import save_figure

__all__ = [
    "DemoConfig",
    "VehicleRun",
    "DemoResult",
    "simulate_vehicle",
    "make_scenario",
    "emit_and_propagate",
    "receive",
    "measurement_errors",
    "navigate",
    "emulate_measurements",
    "run_demo",
    "array_mission",
    "format_summary",
]

#: Positioning filters compared by the demo: the inertial filter and its batch smoother (docs/navigation.md),
#: and paper 000's EKF (proposed = range + v_r) and ROSB (range only).
FILTERS = ("inertial", "batch", "proposed", "rosb")

#: Their names in the summary and the figures, and their line colours.
FILTER_LABELS = {"inertial": "inertial filter", "batch": "batch smoother", "proposed": "paper 000 EKF",
                 "rosb": "paper 000 ROSB"}
FILTER_COLOURS = {"inertial": "C0", "batch": "C2", "proposed": "C3", "rosb": "C1"}


@dataclass(frozen=True, kw_only=True)
class DemoConfig:
    """Everything the demo mission depends on (written to ``demo_config.json``).

    Parameters
    ----------
    preset : str
        Frame preset (paper 000 Table 5: jmse2024).
    tcom_s : float
        Time between two frames [s] (paper 000 at sea: 3 s).
    n_lanes, lane_length_m, width_m : int, float, float
        The survey: ``n_lanes`` lanes along y, ``lane_length_m`` long, spread
        over ``width_m`` in x and joined by half circles.
    speed_mps : float
        Survey speed [m/s].
    duration_s : float or None
        Mission length [s]; None: the time to run the whole survey.
    beacon_xy_m : (float, float)
        Beacon position, east and north [m].
    depth_m : float
        Depth of both beacon and vehicle [m] (equal depths: the slant range of
        the direct path is the horizontal range the EKF models).
    water_depth_m : float
        Flat bottom [m].
    sound_speed_mps : float
        c [m/s].
    surface_reflection, bottom_reflection : float
        Reflection coefficients of the two echoes.
    snr_db : float
        In-band SNR (SPEC §1) of the white noise, mean over frames [dB].
    dt_s : float
        Vehicle, IMU and filter step [s] (paper 000 Table 2: 0.25 s).
    sigma_heading_deg, heading_drift_deg_per_h, sigma_omega_rad_s, sigma_accel_mps2 : float
        AHRS/IMU noise (as :class:`seamodem.navigation.NoiseModel`).
    seed : int
        Seeds the IMU noise, the channel's noise and the emulated measurements.
    array : str or None
        A hydrophone array (a preset such as ``tetra:0.08`` or a TOML/JSON file,
        as ``seamodem channel --array``): also run the mission's recording
        through it (step 7). None: one hydrophone only.
    """

    preset: str = "jmse2024"
    tcom_s: float = 3.0
    n_lanes: int = 3
    lane_length_m: float = 40.0
    width_m: float = 20.0
    speed_mps: float = 1.0
    duration_s: float | None = None
    beacon_xy_m: tuple[float, float] = (45.0, -25.0)
    depth_m: float = 5.0
    water_depth_m: float = 20.0
    sound_speed_mps: float = 1500.0
    surface_reflection: float = -0.9
    bottom_reflection: float = 0.5
    snr_db: float = 12.0
    dt_s: float = 0.25
    sigma_heading_deg: float = 1.0
    heading_drift_deg_per_h: float = 5.0
    sigma_omega_rad_s: float = math.sqrt(0.005)
    sigma_accel_mps2: float = math.sqrt(0.005)
    seed: int = 1
    array: str | None = None

    def __post_init__(self):
        get_preset(self.preset)  # raises ConfigError naming the preset
        if self.array is not None:
            from .channel.array import load_array
            from .receive.array import array_geometry

            a = load_array(self.array)  # raises naming the array
            array_geometry(a.element_positions_m, a.assume)
        for name in ("tcom_s", "lane_length_m", "width_m", "speed_mps", "depth_m", "water_depth_m",
                     "sound_speed_mps", "dt_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(name, f"must be a positive number, got {value!r}")
        if self.duration_s is not None and not (math.isfinite(self.duration_s) and self.duration_s >= self.tcom_s):
            raise ConfigError("duration_s", f"must be at least tcom_s = {self.tcom_s:g} s, got {self.duration_s!r}")
        if isinstance(self.n_lanes, bool) or not isinstance(self.n_lanes, int) or self.n_lanes < 2:
            raise ConfigError("n_lanes", f"must be an integer >= 2, got {self.n_lanes!r}")
        if self.depth_m >= self.water_depth_m:
            raise ConfigError("depth_m", f"must be above the bottom (water_depth_m = {self.water_depth_m:g}), got {self.depth_m!r}")
        if len(self.beacon_xy_m) != 2:
            raise ConfigError("beacon_xy_m", f"must be two numbers (east, north), got {self.beacon_xy_m!r}")
        object.__setattr__(self, "beacon_xy_m", tuple(float(v) for v in self.beacon_xy_m))
        for name in ("sigma_heading_deg", "heading_drift_deg_per_h", "sigma_omega_rad_s", "sigma_accel_mps2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(name, f"must be finite and >= 0, got {value!r}")

    @property
    def frame_config(self) -> FrameConfig:
        return get_preset(self.preset)

    def path(self):
        """The desired survey path (:class:`seamodem.navigation.trajectories.SegmentPath`)."""
        from .navigation.trajectories import boustrophedon

        return boustrophedon(width_m=self.width_m, lane_length_m=self.lane_length_m, n_lanes=self.n_lanes,
                             y0_m=0.0, speed_mps=self.speed_mps)

    def mission_s(self) -> float:
        return self.path().duration_s if self.duration_s is None else float(self.duration_s)

    def frame_count(self) -> int:
        """Frames emitted at 0, T_com, … strictly before the mission's end."""
        return max(1, math.ceil(self.mission_s() / self.tcom_s - 1e-9))


@dataclass(frozen=True, eq=False)
class VehicleRun:
    """The true vehicle and its IMU/AHRS, sampled every Δt.

    Attributes
    ----------
    t_s : numpy.ndarray, shape (n,)
    xy_m : numpy.ndarray, shape (n, 2)
        True position [m].
    heading_rad, speed_mps : numpy.ndarray, shape (n,)
        True heading (counter-clockwise from east) and speed.
    imu : dict of numpy.ndarray
        ``t_s, heading_rad, omega_rad_s, accel_mps2``: the measured AHRS/IMU
        (the columns of ``seamodem nav track --imu``).
    """

    t_s: np.ndarray
    xy_m: np.ndarray
    heading_rad: np.ndarray
    speed_mps: np.ndarray
    imu: dict


def simulate_vehicle(cfg: DemoConfig, *, t_end_s: float, rng: np.random.Generator) -> VehicleRun:
    """Run the vehicle along the survey from t = 0 to ``t_end_s`` [s] (controller on the truth).

    The vehicle starts on the path with its heading and speed; the controller
    (paper 000 eq 2, limits |Ω| ≤ 0.5 rad/s, |a| ≤ 0.5 m/s²) steers on the true
    state — the recording must exist before the filters run, so they cannot
    close the loop. IMU: :mod:`seamodem.navigation.imu` (the Monte Carlo's model),
    its bias random walk starting from one step's draw rather than from 0 (the
    sensor ran before the mission began).
    """
    from .navigation.imu import imu_sigmas, simulate_imu
    from .navigation.vehicle import feedback_command, vehicle_step

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
    """The channel scenario (the TOML tables as a dict) for the vehicle track in ``track_csv``."""
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
    """The true track as the channel reads it: ``t_s,x_m,y_m,z_m`` (z up)."""
    rows = np.column_stack([vehicle.t_s, vehicle.xy_m, np.full(vehicle.t_s.size, -depth_m)])
    np.savetxt(path, rows, delimiter=",", header="t_s,x_m,y_m,z_m", comments="", fmt="%.6f")


def emit_and_propagate(cfg: DemoConfig, vehicle: VehicleRun, folder: Path, *, progress: bool | None = False) -> dict:
    """Write ``beacon.wav`` (the frames) and ``received.wav`` (the hydrophone) in ``folder``.

    Returns the received recording's sidecar (with the channel's ``truth`` per frame).
    """
    from .channel import parse_scenario, simulate_file
    from .transmit import BeaconSchedule, payloads_from_text, write_beacon

    folder = Path(folder)
    count = cfg.frame_count()
    schedule = BeaconSchedule(count=count, period_s=cfg.tcom_s)
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


def receiver_settings(sidecar: dict):
    """How the demo's receiver works: the channel's sound speed, payloads decoded."""
    from .receive import ReceiverSettings

    return ReceiverSettings(sound_speed_mps=float(sidecar["channel"]["sound_speed_mps"]), decode=True)


def receive(recording: Path, sidecar: dict, *, grab_frame: int | None = None):
    """Measure and decode every frame of ``recording``: (records, grabbed frame or None)."""
    from .io.sidecar import sidecar_payloads
    from .receive import Emissions, receive_file

    config = FrameConfig.from_dict(sidecar["config"])
    times = np.array([f["t_emit_s"] for f in sidecar["frames"]])
    grab = _FrameGrab(grab_frame) if grab_frame is not None else None
    records = list(receive_file(recording, config, emissions=Emissions(times_s=times), settings=receiver_settings(sidecar),
                                payloads=sidecar_payloads(sidecar), on_frame=grab, progress=False))
    return records, (grab.frame if grab else None)


def measurement_errors(records, truth: list[dict]) -> dict[str, np.ndarray]:
    """Per detected frame: arrival time, range and v_r errors against the channel's truth (direct path)."""
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
    """Measurement records as the column dict :func:`~seamodem.navigation.track.run_track` reads."""
    names = ("frame_index", "t_emit_s", "t_arrival_s", "tof_s", "range_m", "v_r_mps", "snr_db")
    return {n: np.array([getattr(r, n) for r in records], dtype=float) for n in names}


def emulate_measurements(truth: list[dict], frame_index, *, sigma_range_m: float, sigma_v_r_mps: float,
                         rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Range and v_r from the geometry (the channel's truth) plus white Gaussian noise, for the given frames."""
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
    }


def navigate(meas: dict, vehicle: VehicleRun, cfg: DemoConfig, *, filter: str) -> dict[str, np.ndarray]:
    """Run one filter; return its estimate and position error at the IMU instants.

    The filter starts at the true position and speed (a GNSS fix before
    diving), as in paper 000's Monte Carlo.
    """
    from .navigation.track import run_track

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

    from .channel import parse_scenario
    from .channel.array import load_array, simulate_array
    from .io.sidecar import sidecar_payloads
    from .navigation.bearing import single_frame_fix
    from .receive import Emissions, Receiver
    from .receive.array import receive_array

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
                "range_rmse_m": _rms([r.range_m - t["range_m"] - d for (r, t), d in zip(matched, lever)])}

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
        "azimuth_rmse_deg": math.degrees(_rms(az_err)),
        "azimuth_sigma_median_deg": math.degrees(float(np.median([r.sigma_azimuth_body_rad for r in records])))
        if records else math.nan,
        "azimuth_within_3_sigma": float(np.mean(np.array(z_az) <= 3)) if z_az else math.nan,
        "one_frame_fix_median_error_m": float(np.median(fix_err)) if fix_err else math.nan,
        "one_frame_fix_rms_error_m": _rms(fix_err),
        "definition": "same beacon, scenario and SNR per element; one hydrophone = element 0 of the array recording "
                      "(its range against the range to that element, the array's against the body origin's); "
                      "one-frame fix = range + body azimuth + AHRS heading + true depth, no filter",
    }
    return records, summary


@dataclass
class DemoResult:
    """What :func:`run_demo` measured (``summary`` is also written as ``summary.json``)."""

    config: DemoConfig
    summary: dict
    vehicle: VehicleRun
    errors: dict
    tracks: dict = field(default_factory=dict)
    files: list = field(default_factory=list)


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x**2))) if x.size else math.nan


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
    """
    from .navigation.paper import eq25_text
    from .receive import write_measurements

    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    clock = {"start": time.perf_counter()}
    rng_imu, rng_emul = (np.random.default_rng(s) for s in np.random.SeedSequence(cfg.seed).spawn(2))
    count = cfg.frame_count()
    # the vehicle must be simulated past the last frame's reception (a frame, plus the travel time, plus margin)
    t_end = count * cfg.tcom_s + cfg.frame_config.frame_duration_s + 2.0
    vehicle = simulate_vehicle(cfg, t_end_s=t_end, rng=rng_imu)

    with tempfile.TemporaryDirectory(prefix="seamodem-demo-") as tmp:
        audio = out if keep_audio else Path(tmp)
        sidecar = emit_and_propagate(cfg, vehicle, audio, progress=progress)
        clock["channel"] = time.perf_counter()
        grab_at = count // 2
        records, grabbed = receive(audio / "received.wav", sidecar, grab_frame=grab_at)
        clock["receiver"] = time.perf_counter()
        psd = _psd(audio / "received.wav", sidecar) if plots else None
        array_records, array_summary = array_mission(cfg, vehicle, audio, sidecar) if cfg.array else (None, None)
        clock["array"] = time.perf_counter()
    truth = sidecar["truth"]
    errs = measurement_errors(records, truth)
    sigma_r, sigma_v = _rms(errs["range_error_m"]), _rms(errs["v_r_error_mps"])
    meas = records_to_columns(records)
    emulated = emulate_measurements(truth, errs["frame_index"], sigma_range_m=sigma_r, sigma_v_r_mps=sigma_v,
                                    rng=rng_emul)
    tracks = {}
    for f in FILTERS:
        tracks[("waveform", f)] = navigate(meas, vehicle, cfg, filter=f)
        tracks[("emulated", f)] = navigate(emulated, vehicle, cfg, filter=f)
    clock["navigation"] = time.perf_counter()

    payloads = {f["frame_index"]: f["payload_hex"] for f in sidecar["frames"]}
    decoded = [r for r in records if r.crc_ok is not None]
    crc_ok = [r for r in decoded if r.crc_ok]
    correct = [r for r in crc_ok if r.payload_hex == payloads.get(r.frame_index)]
    mission_end = cfg.mission_s()
    summary = {
        "created_by": f"seamodem {__version__}",
        "mission_s": mission_end,
        "distance_m": float(np.sum(np.hypot(*np.diff(vehicle.xy_m[vehicle.t_s <= mission_end], axis=0).T))),
        "frames_emitted": count,
        "frames_detected": len(records),
        "frames_decoded": len(decoded),
        "crc_ok": len(crc_ok),
        "payloads_correct": len(correct),
        "true_snr_db_range": [float(np.min(errs["true_snr_db"])), float(np.max(errs["true_snr_db"]))] if records else None,
        "range_rmse_m": sigma_r,
        "range_bias_m": float(np.mean(errs["range_error_m"])) if records else math.nan,
        "v_r_rmse_mps": sigma_v,
        "v_r_bias_mps": float(np.mean(errs["v_r_error_mps"])) if records else math.nan,
        "range_crlb_median_m": float(np.median([r.sigma_range_m for r in records])) if records else math.nan,
        "v_r_crlb_median_mps": float(np.median([r.sigma_v_r_mps for r in records])) if records else math.nan,
        "positioning": {
            source: {
                f: {"mean_error_m": float(np.mean(tracks[(source, f)]["error_m"])),
                    "rms_error_m": _rms(tracks[(source, f)]["error_m"]),
                    "final_error_m": float(tracks[(source, f)]["error_m"][-1])}
                for f in FILTERS
            }
            for source in ("waveform", "emulated")
        },
        "emulated_noise": {"sigma_range_m": sigma_r, "sigma_v_r_mps": sigma_v,
                           "definition": "RMS of the receiver's errors against the channel truth, this run"},
        "filter": {"inertial": "inertial filter (navigation.inertial), R from each record's sigma with the "
                               "nav track floors; batch: its batch smoother",
                   "proposed": f"paper 000 6-state EKF, {eq25_text()}",
                   "start": "the true position and speed"},
        "wall_time_s": {
            "vehicle_beacon_channel": clock["channel"] - clock["start"],
            "receiver_decoder": clock["receiver"] - clock["channel"],
            "navigation": clock["navigation"] - clock["array"],
        },
    }
    if array_summary is not None:
        summary["array"] = array_summary
        summary["wall_time_s"]["array"] = clock["array"] - clock["receiver"]

    files = []
    (out / "demo_config.json").write_text(json.dumps(
        {"demo": asdict(cfg), "frame": cfg.frame_config.to_dict(),
         "scenario": sidecar["channel"]["scenario"], "channel_noise": sidecar["channel"]["noise"]},
        indent=1) + "\n", encoding="utf-8")
    header = {"created_by": "seamodem demo", "recording": "received.wav",
              "sample_rate_hz": sidecar["recording"]["sample_rate_hz"],
              "sound_speed_mps": sidecar["channel"]["sound_speed_mps"], "clock_offset_s": 0.0, "turnaround_s": None,
              "decode": True, "config": cfg.frame_config.to_dict()}
    write_measurements(out / "measurements.csv", records, header)
    _write_csv(out / "imu.csv", vehicle.imu)
    _write_csv(out / "truth.csv", {"t_s": vehicle.t_s, "x_m": vehicle.xy_m[:, 0], "y_m": vehicle.xy_m[:, 1]})
    for f in FILTERS:
        tr = tracks[("waveform", f)]
        _write_csv(out / f"track_{f}.csv", {"t_s": tr["t_s"], "x_m": tr["xy_m"][:, 0], "y_m": tr["xy_m"][:, 1],
                                             "error_m": tr["error_m"]})
    files += ["demo_config.json", "measurements.csv", "measurements.csv.json", "imu.csv", "truth.csv"]
    if array_records is not None:
        from .channel.array import load_array

        write_measurements(out / "measurements_array.csv", array_records,
                           header | {"array": {"spec": cfg.array, **load_array(cfg.array).to_dict()}})
        files += ["measurements_array.csv", "measurements_array.csv.json"]
    files += [f"track_{f}.csv" for f in FILTERS]
    if plots:
        plot_map(out / "map.png", cfg, vehicle, tracks, summary)
        plot_errors(out / "errors.png", tracks, errs)
        plot_psd(out / "psd.png", psd, cfg.frame_config)
        if grabbed is not None:
            plot_constellation(out / "constellation.png", grabbed, cfg.frame_config, sidecar)
        files += ["map.png", "errors.png", "psd.png", "constellation.png"]
        if images_dir is not None:
            import shutil

            Path(images_dir).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(out / "map.png", Path(images_dir) / "demo_map.png")
    summary["wall_time_s"]["total"] = time.perf_counter() - clock["start"]
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    files.append("summary.json")
    if keep_audio:
        files += ["beacon.wav", "beacon.json", "received.wav", "received.json", "vehicle_track.csv"]
    return DemoResult(cfg, summary, vehicle, errs, tracks, files)


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


def format_summary(summary: dict) -> str:
    """The demo's printed summary."""
    s = summary
    pos = s["positioning"]
    lines = [
        f"mission: {s['mission_s']:.0f} s, {s['distance_m']:.0f} m travelled, a frame every T_com",
        f"frames: {s['frames_emitted']} emitted, {s['frames_detected']} detected, {s['frames_decoded']} decoded, "
        f"{s['crc_ok']} pass the CRC, {s['payloads_correct']} payloads equal to those sent",
    ]
    if s["true_snr_db_range"]:
        lines.append(f"in-band SNR per frame (truth): {s['true_snr_db_range'][0]:.1f} to {s['true_snr_db_range'][1]:.1f} dB")
    lines += [
        f"range vs truth: RMSE {100 * s['range_rmse_m']:.2f} cm (bias {100 * s['range_bias_m']:+.2f} cm; "
        f"median CRLB {100 * s['range_crlb_median_m']:.2f} cm)",
        f"v_r vs truth:   RMSE {100 * s['v_r_rmse_mps']:.2f} cm/s (bias {100 * s['v_r_bias_mps']:+.2f} cm/s; "
        f"median CRLB {100 * s['v_r_crlb_median_mps']:.3f} cm/s)",
        "positioning error (mean / RMS / final, m):",
        f"  {'':34}" + "".join(f" {FILTER_LABELS[f]:>20}" for f in FILTERS),
    ]
    labels = {"waveform": "from the decoded frames", "emulated": "emulated (geometry + same noise)"}
    for source in ("waveform", "emulated"):
        cells = [pos[source][f] for f in FILTERS]
        lines.append(f"  {labels[source]:34}" + "".join(
            f" {c['mean_error_m']:>8.2f} / {c['rms_error_m']:.2f} / {c['final_error_m']:.2f}" for c in cells))
    if "array" in s:
        a = s["array"]
        lines += [
            f"hydrophone array {a['spec']} ({a['n_elements']} elements, {100 * a['aperture_m']:.0f} cm), same SNR per "
            "element, beside one of its hydrophones:",
            f"  frames detected {a['one_hydrophone']['frames_detected']} -> {a['array']['frames_detected']}, payloads "
            f"correct {a['one_hydrophone']['payloads_correct']} -> {a['array']['payloads_correct']} (FER "
            f"{a['one_hydrophone']['fer']:.2f} -> {a['array']['fer']:.2f}), range RMSE "
            f"{100 * a['one_hydrophone']['range_rmse_m']:.2f} -> {100 * a['array']['range_rmse_m']:.2f} cm",
            f"  beacon body azimuth vs truth: RMSE {a['azimuth_rmse_deg']:.2f} deg (median sigma "
            f"{a['azimuth_sigma_median_deg']:.2f} deg, {100 * a['azimuth_within_3_sigma']:.0f} % within 3 sigma)",
            f"  one-frame fix (range + azimuth + AHRS heading + depth, no filter): median error "
            f"{a['one_frame_fix_median_error_m']:.2f} m, RMS {a['one_frame_fix_rms_error_m']:.2f} m",
        ]
    w = s["wall_time_s"]
    lines.append(f"wall time: {w.get('total', math.nan):.1f} s (beacon + channel {w['vehicle_beacon_channel']:.1f} s, "
                 f"receiver + decoder {w['receiver_decoder']:.1f} s, "
                 + (f"array {w['array']:.1f} s, " if "array" in w else "")
                 + f"filters {w['navigation']:.1f} s)")
    return "\n".join(lines)


# --- figures (matplotlib imported lazily) -------------------------------------------------------


def _figure(*args, **kwargs):
    from .plots import pyplot

    return pyplot().subplots(*args, **kwargs)


def plot_map(path, cfg: DemoConfig, vehicle: VehicleRun, tracks: dict, summary: dict) -> None:
    """Top view: the desired survey, the true track, both filters' estimates from the decoded frames, the beacon."""
    fig, ax = _figure(figsize=(7, 6), constrained_layout=True)
    end = vehicle.t_s <= summary["mission_s"]
    plan = cfg.path().sample(np.linspace(0, cfg.path().duration_s, 600)).position
    ax.plot(plan[:, 0], plan[:, 1], color="0.75", lw=3, label="survey plan")
    ax.plot(*vehicle.xy_m[end].T, color="k", lw=1.5, label="true track")
    pos = summary["positioning"]["waveform"]
    for f in FILTERS:
        tr = tracks[("waveform", f)]
        keep = tr["t_s"] <= summary["mission_s"]
        ax.plot(*tr["xy_m"][keep].T, color=FILTER_COLOURS[f], lw=1.2, ls="-" if f in ("inertial", "batch") else "--",
                label=f"{FILTER_LABELS[f]}: mean error {pos[f]['mean_error_m']:.2f} m")
    ax.plot(*cfg.beacon_xy_m, marker="^", color="C2", ms=12, ls="none", label="beacon")
    ax.plot(*vehicle.xy_m[0], marker="o", color="k", ms=6, ls="none", label="start (GNSS fix)")
    ax.set(xlabel="east [m]", ylabel="north [m]", aspect="equal",
           title=f"seamodem demo: positioned from {summary['frames_detected']} received frames "
                 f"({summary['payloads_correct']} payloads decoded)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    save_figure(fig, path, dpi=110)


def plot_errors(path, tracks: dict, errs: dict) -> None:
    """Position error over time (both filters, decoded and emulated measurements); range and v_r errors per frame."""
    fig, axes = _figure(3, 1, figsize=(9, 9), constrained_layout=True)
    ax = axes[0]
    for f in FILTERS:
        for source, ls in (("waveform", "-"), ("emulated", ":")):
            tr = tracks[(source, f)]
            ax.plot(tr["t_s"], tr["error_m"], color=FILTER_COLOURS[f], ls=ls, lw=1.0,
                    label=f"{FILTER_LABELS[f]}, {'decoded frames' if source == 'waveform' else 'emulated measurements'}")
    ax.set(xlabel="time [s]", ylabel="position error [m]", title="positioning error")
    ax.legend(fontsize=8)
    axes[1].plot(errs["t_arrival_s"], 100 * errs["range_error_m"], "o", ms=3)
    axes[1].set(xlabel="arrival time [s]", ylabel="range error [cm]", title="receiver range − truth (direct path)")
    axes[2].plot(errs["t_arrival_s"], 100 * errs["v_r_error_mps"], "o", ms=3, color="C1")
    axes[2].set(xlabel="arrival time [s]", ylabel="v_r error [cm/s]", title="receiver v_r − truth (direct path)")
    for ax in axes:
        ax.grid(alpha=0.3)
    save_figure(fig, path, dpi=110)


def plot_psd(path, psd, config: FrameConfig) -> None:
    """PSD of the received recording over one frame, with the data band and the tone marked."""
    f, pxx = psd
    fig, ax = _figure(figsize=(8, 4), constrained_layout=True)
    ax.plot(f / 1e3, 10 * np.log10(np.maximum(pxx / np.max(pxx), 1e-20)), lw=0.8)
    lo, hi = config.data_band_hz
    ax.axvspan(lo / 1e3, hi / 1e3, color="C1", alpha=0.15, label=f"data band {lo / 1e3:g}–{hi / 1e3:g} kHz")
    ax.axvline(config.tone_hz / 1e3, color="C3", ls="--", lw=0.8, label=f"tone {config.tone_hz / 1e3:g} kHz")
    ax.set(xlabel="frequency [kHz]", ylabel="PSD [dB rel. max]", ylim=(-80, 5),
           title="received: the first frame (direct, surface and bottom paths, noise)")
    ax.grid(alpha=0.3)
    ax.legend()
    save_figure(fig, path, dpi=110)


def plot_constellation(path, grabbed, config: FrameConfig, sidecar: dict) -> None:
    """One frame's data symbols: after Doppler compensation (eq 10–11) and after the DFE.

    The frame goes once more through the receiver's own decoding step
    (:func:`seamodem.receive.demodulate.demodulate`, same settings but the
    DFE alone), so the picture is what the receiver decoded.
    """
    import dataclasses

    from .io.sidecar import sidecar_pilot_bits
    from .receive.demodulate import demodulate

    m, bb, t0_s, fs = grabbed
    pilot = (1.0 - 2.0 * sidecar_pilot_bits(sidecar)).astype(complex)
    settings = dataclasses.replace(receiver_settings(sidecar), turbo_passes=1)
    dec = demodulate(m, bb, t0_s, fs, config=config, pilot=pilot, settings=settings)
    fig, axes = _figure(1, 2, figsize=(9, 4.5), constrained_layout=True)
    data = dec.compensated.symbols[config.n_pilot:]
    for ax, z, title in ((axes[0], data, "after Doppler compensation (eq 10–11)"),
                         (axes[1], dec.equalized, f"after the DFE (output SNR {dec.eq_snr_db:.1f} dB)")):
        ax.plot(z.real, z.imag, ".", ms=2, alpha=0.5)
        ax.set(xlabel="in-phase", ylabel="quadrature", title=title, aspect="equal", xlim=(-2, 2), ylim=(-2, 2))
        ax.grid(alpha=0.3)
    fig.suptitle(f"one received frame, data symbols (t_arrival = {m.pilot.t_start_s:.2f} s)")
    save_figure(fig, path, dpi=110)
