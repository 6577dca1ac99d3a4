"""Receiver arrays: a few hydrophones on the vehicle, each with its own paths (issue 17).

Frames and angles
-----------------
World frame: the channel's east-north-up axes (x east, y north, z up).
Body frame: x forward, y to port (left), z up. The vehicle's attitude maps
body to world, r_world = R(ψ, θ, φ) r_body with

    R = Rz(ψ) · Ry(−θ) · Rx(φ),

ψ the heading (counter-clockwise from east, the navigation filters' ψ, paper
000 eq 1), θ the pitch (positive nose up) and φ the roll (positive starboard
down). Without a given heading the vehicle points along its horizontal
velocity.

A path arrives *from* the direction u (unit vector from the vehicle towards
the beacon's image of that path). Its azimuth is atan2(u_y, u_x) and its
elevation asin(u_z), in either frame. In the body frame a beacon dead ahead
has azimuth 0, one to port +π/2.

Element k sits at r(t) + R(t) e_k; its path p has the delay
τ_kp(t) = |r(t) + R(t) e_k − b_p| / c, so every element and every path gets
its own delay and Doppler from the geometry (no plane-wave approximation in
the simulator). Optional imperfections: element position errors (the true
positions differ from the nominal ones a receiver assumes) and per-channel
gain and phase mismatch (a complex gain on the analytic signal).
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import ConfigError, InputFileError
from .geometry import Trajectory

__all__ = [
    "ReceiverArray",
    "ElementTrajectory",
    "rotation_body_to_world",
    "direction_angles",
    "load_array",
    "array_preset",
    "ARRAY_PRESETS",
    "ArraySimulation",
    "simulate_array",
    "simulate_array_file",
]


def rotation_body_to_world(heading_rad, pitch_rad=0.0, roll_rad=0.0) -> np.ndarray:
    """R = Rz(ψ) Ry(−θ) Rx(φ) (module docstring), shape (n, 3, 3) for n headings.

    Examples
    --------
    >>> R = rotation_body_to_world(np.pi / 2)[0]
    >>> np.round(R @ [1.0, 0.0, 0.0], 12)  # forward points north
    array([0., 1., 0.])
    """
    psi, theta, phi = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, dtype=float)) for a in (heading_rad, pitch_rad, roll_rad)))
    cps, sps = np.cos(psi), np.sin(psi)
    cth, sth = np.cos(-theta), np.sin(-theta)
    cph, sph = np.cos(phi), np.sin(phi)
    one, zero = np.ones_like(psi), np.zeros_like(psi)
    rz = np.stack([np.stack([cps, -sps, zero], -1), np.stack([sps, cps, zero], -1), np.stack([zero, zero, one], -1)], -2)
    ry = np.stack([np.stack([cth, zero, sth], -1), np.stack([zero, one, zero], -1), np.stack([-sth, zero, cth], -1)], -2)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cph, -sph], -1), np.stack([zero, sph, cph], -1)], -2)
    return rz @ ry @ rx


def direction_angles(u) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth atan2(u_y, u_x) and elevation asin(u_z) [rad] of direction vectors ``u`` (..., 3)."""
    u = np.asarray(u, dtype=float)
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    return np.arctan2(u[..., 1], u[..., 0]), np.arcsin(np.clip(u[..., 2], -1.0, 1.0))


def _matrix(name: str, value, shape_tail: tuple[int, ...]) -> np.ndarray:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(name, f"must be numbers, got {value!r}") from None
    if a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        raise ConfigError(name, f"must have shape (n{''.join(f', {s}' for s in shape_tail)}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(name, "must be finite")
    return a


@dataclass(frozen=True, kw_only=True, eq=False)
class ReceiverArray:
    """Hydrophones fixed on the vehicle and the vehicle's attitude.

    Parameters
    ----------
    element_positions_m : array_like, shape (n_elements, 3)
        Nominal element positions in the body frame [m] (x forward, y port, z up).
    position_errors_m : array_like, shape (n_elements, 3), optional
        True minus nominal positions [m]: the simulator uses the true ones, a
        receiver the nominal ones.
    gain_db, phase_rad : array_like, shape (n_elements,), optional
        Channel gain [dB] and phase [rad] mismatch, a complex gain
        10^(g/20)·e^{jφ} on each channel's analytic signal.
    heading_rad : float, optional
        Constant heading ψ [rad]; default: the direction of the horizontal velocity.
    pitch_rad, roll_rad : float
        Constant pitch θ and roll φ [rad].
    position_sigma_m : float
        What a receiver assumes of its nominal positions' error, per axis [m]
        (widens its σ; the simulator ignores it).
    assume : str, optional
        What a receiver assumes to resolve a flat array's mirror ambiguity
        ("below" by default, or "above" its plane) or a horizontal linear
        array's cone ("port" by default, or "starboard", elevation 0)
        (:func:`seamodem.receive.array.array_geometry`); none for a volume array.
    """

    element_positions_m: Any
    position_errors_m: Any = None
    gain_db: Any = None
    phase_rad: Any = None
    heading_rad: float | None = None
    pitch_rad: float = 0.0
    roll_rad: float = 0.0
    position_sigma_m: float = 0.0
    assume: str | None = None

    def __post_init__(self):
        pos = _matrix("array.element_positions_m", self.element_positions_m, (3,))
        n = pos.shape[0]
        if n < 2:
            raise ConfigError("array.element_positions_m", f"needs at least 2 elements, got {n}")
        object.__setattr__(self, "element_positions_m", pos)
        err = np.zeros((n, 3)) if self.position_errors_m is None else _matrix("array.position_errors_m", self.position_errors_m, (3,))
        if err.shape[0] != n:
            raise ConfigError("array.position_errors_m", f"needs {n} rows (one per element), got {err.shape[0]}")
        object.__setattr__(self, "position_errors_m", err)
        for name in ("gain_db", "phase_rad"):
            value = getattr(self, name)
            v = np.zeros(n) if value is None else _matrix(f"array.{name}", value, ())
            if v.shape[0] != n:
                raise ConfigError(f"array.{name}", f"needs {n} values (one per element), got {v.shape[0]}")
            object.__setattr__(self, name, v)
        if not (isinstance(self.position_sigma_m, (int, float)) and math.isfinite(self.position_sigma_m)
                and self.position_sigma_m >= 0):
            raise ConfigError("array.position_sigma_m", f"must be a number >= 0, got {self.position_sigma_m!r}")
        object.__setattr__(self, "position_sigma_m", float(self.position_sigma_m))
        if self.assume is not None and self.assume not in ("below", "above", "port", "starboard"):
            raise ConfigError("array.assume", f"must be below, above (flat array), port or starboard (linear array), "
                                              f"got {self.assume!r}")
        for name in ("heading_rad", "pitch_rad", "roll_rad"):
            value = getattr(self, name)
            if value is None and name == "heading_rad":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"array.{name}", f"must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))

    @property
    def n_elements(self) -> int:
        return self.element_positions_m.shape[0]

    @property
    def true_positions_m(self) -> np.ndarray:
        """Element positions the simulator uses (nominal + errors), shape (n_elements, 3) [m]."""
        return self.element_positions_m + self.position_errors_m

    @property
    def complex_gains(self) -> np.ndarray:
        """Channel mismatch 10^(g/20)·e^{jφ}, shape (n_elements,)."""
        return 10.0 ** (self.gain_db / 20.0) * np.exp(1j * self.phase_rad)

    @property
    def aperture_m(self) -> float:
        """Largest distance between two elements [m]."""
        d = self.element_positions_m[:, None, :] - self.element_positions_m[None, :, :]
        return float(np.max(np.linalg.norm(d, axis=-1)))

    def nominal(self) -> ReceiverArray:
        """The array as a receiver assumes it: nominal positions, no mismatch."""
        return replace(self, position_errors_m=None, gain_db=None, phase_rad=None)

    def with_errors(self, rng: np.random.Generator, *, position_max_m: float = 0.0,
                    gain_sigma_db: float = 0.0, phase_sigma_rad: float = 0.0) -> ReceiverArray:
        """A copy with random imperfections: positions uniform in ±``position_max_m`` per axis,
        gains and phases Gaussian (element 0 is the reference: no gain or phase error)."""
        n = self.n_elements
        gain = rng.normal(0.0, gain_sigma_db, n)
        phase = rng.normal(0.0, phase_sigma_rad, n)
        gain[0] = phase[0] = 0.0
        return replace(self, position_errors_m=rng.uniform(-position_max_m, position_max_m, (n, 3)),
                       gain_db=gain, phase_rad=phase)

    def attitude(self, trajectory: Trajectory, t_s) -> np.ndarray:
        """R(t) body → world along ``trajectory``, shape (n, 3, 3)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        if self.heading_rad is not None:
            psi = np.full(t.shape, self.heading_rad)
        else:
            dt = 1e-3
            v = (trajectory.position(t + dt) - trajectory.position(t - dt)) / (2 * dt)
            psi = np.arctan2(v[1], v[0])
        return rotation_body_to_world(psi, self.pitch_rad, self.roll_rad)

    def to_dict(self) -> dict[str, Any]:
        return {
            "element_positions_m": self.element_positions_m.tolist(),
            "position_errors_m": self.position_errors_m.tolist(),
            "gain_db": self.gain_db.tolist(),
            "phase_rad": self.phase_rad.tolist(),
            "heading_rad": self.heading_rad,
            "pitch_rad": self.pitch_rad,
            "roll_rad": self.roll_rad,
            "position_sigma_m": self.position_sigma_m,
            "assume": self.assume,
            "axes": "body frame: x forward, y port, z up; R = Rz(heading) Ry(-pitch) Rx(roll)",
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ReceiverArray:
        if not isinstance(d, dict):
            raise ConfigError("array", f"must be a table, got {d!r}")
        known = ("element_positions_m", "position_errors_m", "gain_db", "phase_rad", "heading_rad", "pitch_rad", "roll_rad",
                 "position_sigma_m", "assume")
        for key in d:
            if key not in known and key != "axes":
                raise ConfigError(f"array.{key}", f"unknown key (known: {', '.join(known)})")
        if "element_positions_m" not in d:
            raise ConfigError("array.element_positions_m", "is required")
        return cls(**{k: v for k, v in d.items() if k in known})


def _tetrahedron(aperture_m: float) -> np.ndarray:
    """Regular tetrahedron of edge ``aperture_m``, centred on the body origin."""
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    return v * aperture_m / (2.0 * math.sqrt(2.0))


def _circle(n: int, aperture_m: float) -> np.ndarray:
    a = 2 * np.pi * np.arange(n) / n
    r = 0.5 * aperture_m
    return np.stack([r * np.cos(a), r * np.sin(a), np.zeros(n)], axis=1)


#: preset name → (description, builder(aperture_m))
ARRAY_PRESETS = {
    "tetra": "4 elements on a regular tetrahedron (azimuth and elevation unambiguous)",
    "circle": "n elements on a horizontal circle (azimuth; elevation up to its sign: beacon assumed below)",
    "line": "n elements on a fore-aft line (angle to the line only: beacon assumed to port at elevation 0)",
}


def array_preset(spec: str) -> ReceiverArray:
    """An array from a short spec: ``tetra``, ``circleN`` or ``lineN``, then ``[:APERTURE_M]`` (default 0.08 m).

    Examples
    --------
    >>> round(array_preset("tetra:0.08").aperture_m, 6)
    0.08
    >>> array_preset("circle6").n_elements
    6
    """
    name, _, ap = spec.partition(":")
    try:
        aperture = float(ap) if ap else 0.08
    except ValueError:
        raise ConfigError("array", f"aperture in {spec!r} must be a number of metres") from None
    if not (math.isfinite(aperture) and aperture > 0):
        raise ConfigError("array", f"aperture must be > 0 m, got {aperture!r}")
    if name == "tetra":
        return ReceiverArray(element_positions_m=_tetrahedron(aperture))
    if name.startswith("circle") and name[6:].isdigit() and int(name[6:]) >= 3:
        return ReceiverArray(element_positions_m=_circle(int(name[6:]), aperture))
    if name.startswith("line") and name[4:].isdigit() and int(name[4:]) >= 2:
        n = int(name[4:])
        x = np.linspace(-0.5 * aperture, 0.5 * aperture, n)
        return ReceiverArray(element_positions_m=np.stack([x, np.zeros(n), np.zeros(n)], axis=1))
    raise ConfigError("array", f"unknown array {spec!r}: a TOML/JSON file, or tetra[:APERTURE_M], "
                               "circleN[:APERTURE_M] (N >= 3) or lineN[:APERTURE_M] (N >= 2)")


def load_array(spec: str | Path) -> ReceiverArray:
    """An array from a file (TOML with an [array] table, or JSON with an "array" object) or a preset spec."""
    path = Path(spec)
    if path.suffix.lower() in (".toml", ".json"):
        if not path.is_file():
            raise InputFileError(f"array: {path} not found")
        try:
            text = path.read_text(encoding="utf-8")
            data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
        except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputFileError(f"array: {path} is not valid {path.suffix[1:].upper()} ({exc})") from None
        if "array" not in data:
            raise InputFileError(f"array: {path} has no 'array' table")
        return ReceiverArray.from_dict(data["array"])
    return array_preset(str(spec))


@dataclass(frozen=True, eq=False)
class ElementTrajectory(Trajectory):
    """Element k's position r(t) + R(t) e_k [m] for a vehicle on ``base``."""

    base: Trajectory
    array: ReceiverArray
    offset_body_m: np.ndarray
    parameter = "vehicle"

    def position(self, t_s):
        t = np.atleast_1d(np.asarray(t_s, dtype=float)).reshape(-1)
        rot = self.array.attitude(self.base, t)
        return self.base.position(t) + np.einsum("nij,j->in", rot, self.offset_body_m)

    def max_speed(self, t0_s, t1_s):
        return self.base.max_speed(t0_s, t1_s)

    def z_range(self, t0_s, t1_s):
        lo, hi = self.base.z_range(t0_s, t1_s)
        reach = float(np.max(np.linalg.norm(self.array.true_positions_m, axis=1)))
        return lo - reach, hi + reach


@dataclass(frozen=True, eq=False)
class ArraySimulation:
    """Output of :func:`simulate_array`.

    Attributes
    ----------
    output : numpy.ndarray, shape (n_out, n_elements)
        One column per hydrophone, sampled at fs on the receiver's clock.
    truth : list of dict
        One per frame: the single-hydrophone truth at the body origin, plus
        ``heading_rad``, each path's ``azimuth_body_rad``, ``elevation_body_rad``,
        ``azimuth_world_rad``, ``elevation_world_rad``, and each element's
        direct-path arrival ``element_t_arrival_s``.
    channel : dict
        The sidecar's "channel" section, with the array.
    """

    output: np.ndarray
    truth: list[dict]
    channel: dict = field(default_factory=dict)


def _path_directions(model, array: ReceiverArray, truth: list[dict]) -> None:
    """Add each path's arrival direction (body and world) at its arrival time to ``truth``."""
    traj = model.trajectory
    for row in truth:
        t_true = np.array([model.clock.to_true(p["t_arrival_s"]) for p in row["paths"]], dtype=float)
        r = traj.position(t_true)  # (3, P)
        u_world = model.images.T - r  # towards each path's image
        rot = array.attitude(traj, t_true)  # (P, 3, 3)
        u_body = np.einsum("pji,jp->pi", rot, u_world)  # R^T u
        az_w, el_w = direction_angles(u_world.T)
        az_b, el_b = direction_angles(u_body)
        row["heading_rad"] = float(np.arctan2(rot[0, 1, 0], rot[0, 0, 0]))
        for p, path in enumerate(row["paths"]):
            path.update(azimuth_body_rad=float(az_b[p]), elevation_body_rad=float(el_b[p]),
                        azimuth_world_rad=float(az_w[p]), elevation_world_rad=float(el_w[p]))


def _mismatch(y: np.ndarray, gain: complex) -> np.ndarray:
    """Re[g · analytic(y)]: a complex channel gain applied to a real passband signal."""
    if gain == 1:
        return y
    from scipy.signal import hilbert

    return (gain * hilbert(y)).real


def simulate_array(
    x: np.ndarray,
    fs: float,
    scenario,
    array: ReceiverArray,
    *,
    t_emit_s: Sequence[float] = (),
    frame_duration_s: float | None = None,
    band_hz: tuple[float, float],
    reference_frequency_hz: float | None = None,
) -> ArraySimulation:
    """Pass a recording through a geometry scenario to every hydrophone of ``array``.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,)
        Transmitted recording at ``fs`` [Hz].
    scenario : Scenario
        A geometry scenario (a profile has no directions).
    array : ReceiverArray
    t_emit_s, frame_duration_s, band_hz, reference_frequency_hz
        As :func:`seamodem.channel.simulate.simulate`.

    Returns
    -------
    ArraySimulation

    Notes
    -----
    The SNR is per element: the noise (independent between channels, the
    same level on each) is set against the in-band signal power averaged over
    frames and elements (SPEC §1). Fluctuations, when the scenario has
    them, are common to all elements (they are centimetres apart).
    """
    from .model import build_model
    from .render import ArrayInput, ArrayScratch, make_noise_source, render_channel
    from .truth import frame_truth, in_band_power

    if scenario.mode != "geometry":
        raise ConfigError("mode", f"a receiver array needs a geometry scenario (paths with directions), got {scenario.mode!r}")
    if scenario.two_way is not None:
        raise ConfigError("two_way", "is not simulated with a receiver array")
    if len(t_emit_s) and frame_duration_s is None:
        raise ConfigError("frame_duration_s", "is required with t_emit_s")
    fs = float(fs)
    band_hz = tuple(band_hz)
    model = build_model(scenario, reference_frequency_hz=reference_frequency_hz or 0.5 * sum(band_hz))
    source = ArrayInput(x)
    t_start = float(model.clock.to_true(0.0))
    seeds = np.random.SeedSequence(scenario.seed).spawn(2 + array.n_elements)
    base = model.trajectory
    elements = []
    for k in range(array.n_elements):
        m = copy.copy(model)
        m.trajectory = ElementTrajectory(base, array, array.true_positions_m[k])
        elements.append(m)
    t_end = max(m.end_time(source.n / fs, fs) for m in elements)
    n_out = math.ceil(float(model.clock.to_receiver(t_end)) * fs)
    for m in [model, *elements]:
        m.check_span(t_start, t_end)
    model.add_fluctuations(t_start - 1.0, t_end + 1.0, np.random.default_rng(seeds[0]))
    truth = frame_truth(model, list(t_emit_s), frame_duration_s) if len(t_emit_s) else []
    _path_directions(model, array, truth)
    out = np.zeros((n_out, array.n_elements))
    for k, m in enumerate(elements):
        m.fluctuations = model.fluctuations
        scratch = ArrayScratch(n_out)
        render_channel(m, source, fs, n_out, scratch, False)
        out[:, k] = _mismatch(scratch.data, array.complex_gains[k])
        if truth:
            ta = frame_truth(m, list(t_emit_s), frame_duration_s)
            for row, rk in zip(truth, ta):
                row.setdefault("element_t_arrival_s", []).append(rk["t_arrival_s"])
    powers = []
    for row in truth:
        i0 = max(0, round(row["t_arrival_s"] * fs))
        i1 = min(n_out, round((row["t_arrival_s"] + row["reception_duration_s"]) * fs))
        p = [in_band_power(out[i0:i1, k], fs, band_hz) for k in range(array.n_elements)] if i1 > i0 else [0.0]
        row["signal_power_in_band"] = float(np.mean(p))
        powers.append(row["signal_power_in_band"])
    noise_info: dict[str, Any] = {"kind": scenario.noise.kind}
    probe = make_noise_source(scenario, fs, np.random.default_rng(seeds[1]))
    if probe is not None:
        p_ref = float(np.mean(powers)) if powers else float(np.mean([in_band_power(out[:, k], fs, band_hz) for k in range(array.n_elements)]))
        if p_ref <= 0:
            raise ConfigError("noise.snr_db", "the received signal has no power in the data band to set an SNR against")
        n_band = p_ref / 10.0 ** (scenario.noise.snr_db / 10.0)
        sigma = math.sqrt(n_band / probe.in_band_fraction(band_hz))
        for k in range(array.n_elements):
            src = make_noise_source(scenario, fs, np.random.default_rng(seeds[2 + k]))
            out[:, k] += sigma * src.block(n_out)
        for row in truth:
            row["snr_db"] = 10.0 * math.log10(row["signal_power_in_band"] / n_band) if row["signal_power_in_band"] > 0 else None
        noise_info.update(snr_db=scenario.noise.snr_db, band_hz=list(band_hz), signal_power_in_band=p_ref,
                          noise_power_in_band=n_band, noise_sigma=sigma,
                          definition="per element: mean over frames and elements of the in-band received power / "
                                     "expected in-band noise power; noise independent between elements")
    channel = {
        "scenario": scenario.to_dict(),
        "seed": scenario.seed,
        "sound_speed_mps": model.c,
        "sample_rate_hz": fs,
        "array": array.to_dict(),
        "paths": [p.to_dict() for p in model.paths],
        "model": model.describe(),
        "noise": noise_info,
        "output": {"n_samples": n_out, "duration_s": n_out / fs, "n_channels": array.n_elements},
        "truth_columns": ("body-origin truth as the mono simulator's; per path azimuth/elevation in body and world "
                          "frames (rad, from the vehicle towards the path's image); element_t_arrival_s per element"),
    }
    return ArraySimulation(out, truth, channel)


def simulate_array_file(in_wav, scenario, array: ReceiverArray, out_wav, *, command: str = "") -> dict[str, Any]:
    """``seamodem channel --array``: a multichannel OUT.wav (one channel per element) and OUT.json.

    The whole recording is held in memory (n_samples × n_elements floats).
    OUT.json is the input sidecar carried forward with ``recording``,
    ``channel`` (with ``array``) and ``truth``, as :func:`~seamodem.channel.simulate.simulate_file`.
    """
    import soundfile

    from ..io.files import atomic_outputs, check_writable
    from ..io.sidecar import sidecar_path, write_json
    from .files import OUTPUT_PEAK, OUTPUT_PEAK_LIMIT, read_input

    out_wav = check_writable(out_wav)
    info, side_in, config = read_input(in_wav)
    fs = int(info.samplerate)
    x = soundfile.read(str(in_wav), dtype="float64", always_2d=True)[0][:, 0]
    t_emit = [float(f["t_emit_s"]) for f in side_in["frames"]]
    sim = simulate_array(x, fs, scenario, array, t_emit_s=t_emit, frame_duration_s=config.frame_duration_s,
                         band_hz=config.data_band_hz, reference_frequency_hz=config.carrier_hz)
    y = sim.output
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    gain = OUTPUT_PEAK / peak if peak > OUTPUT_PEAK_LIMIT else 1.0
    side = copy.deepcopy(side_in)
    channel = dict(sim.channel, command=command, input=Path(in_wav).name, input_recording=side_in["recording"])
    channel["output"]["gain"] = gain
    side.update(channel=channel, truth=sim.truth)
    side["recording"] = {"file": Path(out_wav).name, "sample_rate_hz": fs, "n_samples": y.shape[0],
                         "duration_s": y.shape[0] / fs, "n_channels": y.shape[1], "subtype": "FLOAT",
                         "scale": side_in["recording"].get("scale"), "peak": peak * gain}
    with atomic_outputs(out_wav, sidecar_path(out_wav)) as (tmp_wav, tmp_json):
        soundfile.write(str(tmp_wav), gain * y, fs, subtype="FLOAT", format="WAV")
        write_json(tmp_json, side)
    return side
