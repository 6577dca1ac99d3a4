"""Replay through measured channels: the uwa-channels / UnderwaterAcoustics.jl file format.

A channel file (MATLAB .mat) holds, in MATLAB's axis order:

- ``h_hat``: complex baseband impulse responses, n_delay × n_rx × n_time; tap
  l is the delay l/fs_delay (forward order), snapshot j the time j/fs_time;
- ``params``: a struct with ``fs_delay`` [Hz], ``fs_time`` [Hz], ``fc`` [Hz];
- ``version``: ≥ 1.0;
- optionally ``theta_hat`` (n_rx × n_samples at fs_delay): a phase re-imposed
  as exp(jθ) ("phase tracking"; the delay drift is already in h_hat), or
  ``phi_hat`` (same shape): phase and delay drift φ/(2π fc) ("delay tracking");
  ``phi_hat`` wins when both are present;
- optionally ``f_resamp``: a passband resampling factor applied at the end.

Applying it to a passband signal x at fs: shift to baseband at fc and resample
to fs_delay; y[n] = Σ_l h(t_n)[l] x[n − l] with h interpolated in time by a
cubic spline between snapshots (zero outside them); impose θ or φ; resample
back to fs; y_pb = 2 Re[y e^{j2π fc t}] (a unit tap at delay 0 returns x);
then resample by f_resamp if given.

MATLAB v5/v7 files are read with scipy. The published channels are MATLAB
v7.3 (HDF5) files, whose reading needs the optional ``h5py`` package (not a
dependency of seamodem); h5py presents every array with its axes reversed,
which the reader undoes.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io
import scipy.signal
from scipy.interpolate import CubicSpline

from ..errors import ConfigError, InputFileError
from ..io.files import check_writable
from .scenario import Scenario
from .files import read_input, write_outputs
from .render import ArrayScratch, noise_pass

__all__ = ["ReplayChannel", "read_replay_channel", "replay", "replay_file"]


@dataclass(frozen=True, eq=False)
class ReplayChannel:
    """A measured time-varying channel.

    Attributes
    ----------
    h_hat : numpy.ndarray, shape (n_time, n_rx, n_delay), complex
        Impulse responses; ``h_hat[j, m, l]`` is receiver m's tap at delay
        l/fs_delay at time j/fs_time.
    fs_delay, fs_time, fc : float
        Delay-axis rate, snapshot rate, carrier [Hz].
    theta_hat, phi_hat : numpy.ndarray or None, shape (n_samples, n_rx)
        Phase [rad] at fs_delay (see the module docstring).
    f_resamp : float or None
    version : float
    """

    h_hat: np.ndarray
    fs_delay: float
    fs_time: float
    fc: float
    theta_hat: np.ndarray | None = None
    phi_hat: np.ndarray | None = None
    f_resamp: float | None = None
    version: float = 1.0

    @property
    def n_rx(self) -> int:
        return self.h_hat.shape[1]

    @property
    def duration_s(self) -> float:
        """Time span covered by the snapshots [s]."""
        return (self.h_hat.shape[0] - 1) / self.fs_time


def _scalar(path, name, value) -> float:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size != 1 or not np.isfinite(arr[0]):
        raise InputFileError(f"{path}: {name} must be one finite number, got {value!r}")
    return float(arr[0])


def _load_v5(path: Path) -> dict[str, Any]:
    m = scipy.io.loadmat(str(path))
    out: dict[str, Any] = {k: v for k, v in m.items() if not k.startswith("__")}
    if "params" in out:
        p = out["params"]
        if p.dtype.names is None:
            raise InputFileError(f"{path}: params must be a struct with fs_delay, fs_time, fc")
        out["params"] = {name: p[0, 0][name] for name in p.dtype.names}
    for key in ("theta_hat", "phi_hat"):
        if key in out:
            out[key] = np.asarray(out[key], dtype=float).T  # MATLAB n_rx × n_samples → (n_samples, n_rx)
    if "h_hat" in out:
        h = np.asarray(out["h_hat"])
        if h.ndim == 2:  # MATLAB drops a trailing singleton axis only when n_time = 1
            h = h[:, :, None]
        out["h_hat"] = np.transpose(h, (2, 1, 0)).astype(complex)  # (n_time, n_rx, n_delay)
    return out


def _load_v73(path: Path) -> dict[str, Any]:
    try:
        import h5py
    except ImportError:
        raise InputFileError(
            f"{path} is a MATLAB v7.3 (HDF5) file: reading it needs the optional package h5py (pip install h5py)"
        ) from None
    out: dict[str, Any] = {}
    with h5py.File(path, "r") as f:
        for key in ("h_hat", "theta_hat", "phi_hat", "version", "f_resamp"):
            if key in f:
                data = f[key][()]
                if data.dtype.names and {"real", "imag"} <= set(data.dtype.names):
                    data = data["real"] + 1j * data["imag"]
                out[key] = data
        if "params" in f:
            out["params"] = {k: f["params"][k][()] for k in f["params"]}
    return out  # h5py already shows MATLAB's axes reversed: (n_time, n_rx, n_delay), (n_samples, n_rx)


def read_replay_channel(path: str | Path) -> ReplayChannel:
    """Read a channel file in the uwa-channels format (module docstring).

    Parameters
    ----------
    path : str or Path
        The MATLAB .mat channel file (v5/v7, or v7.3 with h5py installed).

    Returns
    -------
    ReplayChannel
        The impulse responses and their rates, axes in the order
        ``(n_time, n_rx, n_delay)``.

    Raises
    ------
    InputFileError
        Missing file, not a MAT file, missing fields, inconsistent shapes, or a
        v7.3 file without h5py installed.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"replay.file: channel file not found: {path}")
    try:
        data = _load_v5(path)
    except NotImplementedError:  # scipy's word for a v7.3 (HDF5) file
        data = _load_v73(path)
    except (ValueError, TypeError, OSError) as exc:
        raise InputFileError(f"replay.file: {path} is not a readable MATLAB file: {exc}") from None
    for key in ("h_hat", "params", "version"):
        if key not in data:
            raise InputFileError(f"replay.file: {path} lacks {key!r} (uwa-channels format)")
    params = data["params"]
    for key in ("fs_delay", "fs_time", "fc"):
        if key not in params:
            raise InputFileError(f"replay.file: {path} lacks params.{key}")
    version = _scalar(path, "version", data["version"])
    if version < 1.0:
        raise InputFileError(f"replay.file: {path} has version {version:g}; 1.0 or later is needed")
    h = np.asarray(data["h_hat"], dtype=complex)
    if h.ndim != 3 or h.shape[0] < 4:
        raise InputFileError(f"replay.file: {path}: h_hat must be 3-D with ≥ 4 snapshots, got shape {h.shape}")
    fs_delay, fs_time, fc = (_scalar(path, f"params.{k}", params[k]) for k in ("fs_delay", "fs_time", "fc"))
    phases = {}
    for key in ("theta_hat", "phi_hat"):
        if key in data:
            arr = np.asarray(data[key], dtype=float)
            if arr.ndim != 2 or arr.shape[1] != h.shape[1]:
                raise InputFileError(f"replay.file: {path}: {key} must have one column per receiver ({h.shape[1]}), got shape {arr.shape}")
            phases[key] = arr
    f_resamp = _scalar(path, "f_resamp", data["f_resamp"]) if "f_resamp" in data else None
    return ReplayChannel(h, fs_delay, fs_time, fc, phases.get("theta_hat"), phases.get("phi_hat"), f_resamp, version)


def _resample(x: np.ndarray, ratio: float) -> np.ndarray:
    frac = Fraction(ratio).limit_denominator(1_000_000)
    return scipy.signal.resample_poly(x, frac.numerator, frac.denominator)


def replay(x: np.ndarray, fs: float, channel: ReplayChannel, *, receiver: int = 0, start_s: float = 0.0) -> np.ndarray:
    """Pass a real passband signal through a measured channel (module docstring).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,)
        Passband signal at ``fs``; its band must lie within the channel's
        (fc ± fs_delay/2).
    fs : float
        Sample rate [Hz] (> 2 fc).
    channel : ReplayChannel
    receiver : int
        Array element.
    start_s : float
        Where in the measured channel the signal starts [s].

    Returns
    -------
    numpy.ndarray
        Received passband signal at ``fs``, (len(x) + n_delay − 1 delay-axis
        samples) long, times ``f_resamp`` when the file gives one.

    Raises
    ------
    ConfigError
        A receiver that does not exist, a signal longer than the channel from
        ``start_s``, or fs ≤ 2 fc.
    """
    if not 0 <= receiver < channel.n_rx:
        raise ConfigError("replay.receiver", f"must be in [0, {channel.n_rx - 1}], got {receiver!r}")
    if fs <= 2 * channel.fc:
        raise ConfigError("sample_rate_hz", f"must exceed 2·fc = {2 * channel.fc:g} Hz, got {fs:g}")
    x = np.asarray(x, dtype=float)
    n_time, _, n_delay = channel.h_hat.shape
    xb = _resample(x * np.exp(-2j * np.pi * channel.fc * np.arange(x.size) / fs), channel.fs_delay / fs)
    n_out = xb.size + n_delay - 1
    start = round(start_s * channel.fs_delay)
    t = (start + np.arange(n_out)) / channel.fs_delay
    if t[-1] > channel.duration_s:
        raise ConfigError("replay.start_s", f"the signal needs the channel until {t[-1]:g} s, it covers {channel.duration_s:g} s")
    for key in ("theta_hat", "phi_hat"):
        phase = getattr(channel, key)
        if phase is not None and start + n_out > phase.shape[0]:
            raise ConfigError("replay.start_s", f"the signal needs {key} until sample {start + n_out}, it has {phase.shape[0]}")
    h = channel.h_hat[:, receiver, :]
    snap_t = np.arange(n_time) / channel.fs_time
    spline_re = CubicSpline(snap_t, h.real, axis=0)
    spline_im = CubicSpline(snap_t, h.imag, axis=0)
    xpad = np.concatenate([np.zeros(n_delay - 1), xb, np.zeros(n_delay - 1)])
    windows = np.lib.stride_tricks.sliding_window_view(xpad, n_delay)[:, ::-1]  # row n: x[n], x[n−1], …
    y = np.empty(n_out, dtype=complex)
    block = max(1, (1 << 22) // n_delay)
    for n0 in range(0, n_out, block):
        n1 = min(n0 + block, n_out)
        taps = spline_re(t[n0:n1]) + 1j * spline_im(t[n0:n1])
        y[n0:n1] = np.einsum("nl,nl->n", taps, windows[n0:n1])
    if channel.phi_hat is not None:
        phi = channel.phi_hat[start : start + n_out, receiver]
        y = y * np.exp(1j * phi)
        tt = np.arange(n_out) / channel.fs_delay
        drift = phi / (2 * np.pi * channel.fc)
        shifted = tt + drift
        inside = (shifted >= 0) & (shifted <= tt[-1])
        y = np.where(inside, CubicSpline(tt, y)(np.clip(shifted, 0, tt[-1])), 0.0)
    elif channel.theta_hat is not None:
        y = y * np.exp(1j * channel.theta_hat[start : start + n_out, receiver])
    yb = _resample(y, fs / channel.fs_delay)
    out = 2.0 * np.real(yb * np.exp(2j * np.pi * channel.fc * np.arange(yb.size) / fs))
    if channel.f_resamp is not None:
        out = _resample(out, channel.f_resamp)
    return out


def replay_file(in_wav, scenario: Scenario, out_wav, *, command: str = "", progress: bool | None = None) -> dict:
    """``seamodem channel`` in replay mode: the measured channel, then [noise].

    The whole input is held in memory (measured channels last seconds to
    minutes). The truth list is empty: a measured channel has no known
    absolute delay or speed. Without frames to refer to, the SNR refers to the
    in-band power of the whole noiseless output.

    Parameters
    ----------
    in_wav : str or Path
        Input recording (a ``seamodem tx`` WAV with its sidecar).
    scenario : Scenario
        A ``replay`` mode scenario (channel file, receiver, start time, noise).
    out_wav : str or Path
        Output WAV; its sidecar is written beside it.
    command : str, optional
        Command line recorded in the sidecar's ``channel.command``.
    progress : bool or None, optional
        Progress bar; None shows it on a terminal only.

    Returns
    -------
    dict
        The output sidecar as written (``channel`` section, empty ``truth``).

    Raises
    ------
    InputFileError
        Unreadable input, sidecar or channel file.
    ConfigError
        An invalid scenario for this recording.
    """
    out_wav = check_writable(out_wav)
    info, side_in, config = read_input(in_wav)
    fs = float(info.samplerate)
    rp = scenario.replay
    channel = read_replay_channel(scenario.base_dir / rp.file)

    def produce(fin, sink, make_scratch):
        x = fin.read(dtype="float64", always_2d=True)[:, 0]
        y = replay(x, fs, channel, receiver=rp.receiver, start_s=rp.start_s)
        scratch = ArrayScratch(y.size, y)
        seed = np.random.SeedSequence(scenario.seed).spawn(2)[1]
        noise = noise_pass(scratch, y.size, fs, scenario, config.data_band_hz, [], None, seed, sink, progress)
        section = {
            "scenario": scenario.to_dict(),
            "seed": scenario.seed,
            "sample_rate_hz": fs,
            "paths": [],
            "replay": {"file": str(rp.file), "fs_delay": channel.fs_delay, "fs_time": channel.fs_time,
                       "fc": channel.fc, "n_rx": channel.n_rx, "n_delay": channel.h_hat.shape[2],
                       "duration_s": channel.duration_s, "version": channel.version},
            "noise": noise,
            "output": {"n_samples": int(y.size), "duration_s": y.size / fs, "input_n_samples": int(x.size),
                       "length_rule": "input + channel impulse-response length"},
            "truth_columns": "none: a measured channel has no known absolute delay",
        }
        return [], section

    return write_outputs(in_wav, out_wav, side_in, produce, command=command)
