"""The simulator: input recording + scenario → received recording + truth.

Two passes over the output, block by block (bounded memory):

1. the noiseless received signal, r(t) = Σ_p g_p(t) s(t − τ_p(t)) sampled on
   the receiver's clock, into a scratch buffer (a temporary file for
   :func:`simulate_file`); then the in-band signal power of every frame;
2. noise scaled to the requested in-band SNR, added block by block to the output.

Length: the output lasts until every path has delivered the input's last
sample (input duration + the largest path delay at the end + the interpolator's
half-length, on the receiver's clock), so the last frame is never cut.

SNR (SPEC §1): the signal power of frame k, P_k, is the in-band power
(:func:`seamodem.channel.truth.in_band_power`, band [f0 − B/2, f0 + B/2]) of the
noiseless received signal over the frame's direct-path reception window
[t_arrival, t_arrival + D_rx]. The noise level is constant over the recording,
set so that mean_k(P_k) / N_band = 10^(snr_db/10), with N_band the noise's
expected power in the same band. Each frame's own SNR, P_k / N_band, is in the truth.
"""

from __future__ import annotations

import copy
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import soundfile

from .._version import __version__
from .._progress import progress_bar
from ..config import FrameConfig
from ..errors import ConfigError, InputFileError
from ..io.files import atomic_outputs, check_writable
from ..io.sidecar import read_sidecar, sidecar_path, write_json
from ..io.wav import wav_info
from .model import ChannelModel, build_model
from .noise import AlphaStableNoise, AmbientNoise, GaussianMixtureNoise, NoiseSource, WhiteNoise
from .resample import HILBERT_LOW_FRACTION, PASSBAND_FRACTION, input_span, render_paths
from .scenario import Scenario
from .truth import frame_truth, in_band_power
from .two_way import RetimedInput, reply_schedule, two_way_truth

__all__ = ["SimulationResult", "simulate", "simulate_file", "make_noise_source"]

BLOCK = 1 << 16


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Output of :func:`simulate`.

    Attributes
    ----------
    output : numpy.ndarray, shape (n_out,)
        The received recording, sampled at fs on the receiver's clock.
    truth : list of dict
        One record per frame (see :mod:`seamodem.channel.truth`).
    channel : dict
        What the sidecar's "channel" section holds: scenario, seeds, paths, noise.
    """

    output: np.ndarray
    truth: list[dict]
    channel: dict


def make_noise_source(scenario: Scenario, fs: float, rng: np.random.Generator) -> NoiseSource | None:
    """The [noise] table's source, or None for kind = "none"."""
    n = scenario.noise
    if n.kind == "none":
        return None
    if n.kind == "white":
        return WhiteNoise(fs, rng)
    if n.kind == "ambient":
        return AmbientNoise(fs, rng, shipping=n.shipping, wind_mps=n.wind_mps)
    if n.kind == "gaussian_mixture":
        return GaussianMixtureNoise(fs, rng, impulse_probability=n.impulse_probability,
                                    impulse_power_ratio=n.impulse_power_ratio)
    return AlphaStableNoise(fs, rng, alpha=n.alpha)


class ArrayInput:
    """The channel's input from samples in memory (the file input reads a WAV instead).

    Parameters
    ----------
    x : numpy.ndarray, shape (n,)
        Transmitted real passband samples.

    Attributes
    ----------
    n : int
        Number of samples.
    """

    def __init__(self, x: np.ndarray):
        self.x = np.asarray(x, dtype=np.float64)
        self.n = self.x.size

    def read(self, lo: int, hi: int) -> np.ndarray:
        """Samples [lo, hi) (0 <= lo <= hi <= n).

        Parameters
        ----------
        lo, hi : int
            Sample range [samples].

        Returns
        -------
        numpy.ndarray
            A view of those samples.
        """
        return self.x[lo:hi]


class _WavInput:
    def __init__(self, f: soundfile.SoundFile):
        self.f = f
        self.n = f.frames

    def read(self, lo: int, hi: int) -> np.ndarray:
        self.f.seek(lo)
        return self.f.read(hi - lo, dtype="float64", always_2d=True)[:, 0]


def _segment(source, lo: int, hi: int) -> np.ndarray:
    """Input samples [lo, hi), zero outside the recording."""
    out = np.zeros(hi - lo)
    a, b = max(lo, 0), min(hi, source.n)
    if b > a:
        out[a - lo : b - lo] = source.read(a, b)
    return out


class ArrayScratch:
    """The rendered (noise-free) output held in memory between the channel's two passes.

    Parameters
    ----------
    n : int
        Output length [samples].
    data : numpy.ndarray, optional
        Samples to start from (used in place; default zeros).
    """

    def __init__(self, n: int, data: np.ndarray | None = None):
        self.data = np.zeros(n) if data is None else data

    def write(self, n0: int, block: np.ndarray) -> None:
        """Store ``block`` from sample ``n0`` on.

        Parameters
        ----------
        n0 : int
            First output sample written.
        block : numpy.ndarray
            The samples.
        """
        self.data[n0 : n0 + block.size] = block

    def read(self, n0: int, n1: int) -> np.ndarray:
        """Output samples [n0, n1), a copy.

        Parameters
        ----------
        n0, n1 : int
            Sample range.

        Returns
        -------
        numpy.ndarray
            The samples.
        """
        return self.data[n0:n1].copy()


class _FileScratch:
    """Float64 samples in a temporary file beside the output (deleted on close)."""

    def __init__(self, folder: Path):
        fd, name = tempfile.mkstemp(prefix=".seamodem-channel.", suffix=".f64", dir=folder)
        self.path = Path(name)
        self.f = os.fdopen(fd, "w+b")

    def write(self, n0: int, block: np.ndarray) -> None:
        self.f.seek(8 * n0)
        self.f.write(np.ascontiguousarray(block, dtype=np.float64).tobytes())

    def read(self, n0: int, n1: int) -> np.ndarray:
        self.f.flush()
        self.f.seek(8 * n0)
        return np.fromfile(self.f, dtype=np.float64, count=n1 - n0)

    def close(self) -> None:
        self.f.close()
        self.path.unlink(missing_ok=True)


def render_channel(model: ChannelModel, source, fs: float, n_out: int, scratch, progress: bool | None) -> None:
    """First pass: the input through the channel model's paths (delays, gains, clock), block by block, into scratch.

    Parameters
    ----------
    model : ChannelModel
        Paths, their delays and gains, and the receiver's clock.
    source : ArrayInput or a file input
        The transmitted samples (``n`` and ``read(lo, hi)``).
    fs : float
        Sample rate of input and output [Hz].
    n_out : int
        Output length [samples].
    scratch : ArrayScratch or a file scratch
        Where the output is written (``write(n0, block)``).
    progress : bool or None
        Progress bar (None: on a terminal).

    Returns
    -------
    None
        The output is in ``scratch``.
    """
    clock = model.clock
    with progress_bar(total=n_out, unit="sample", unit_scale=True, desc="channel", enabled=progress) as bar:
        for n0 in range(0, n_out, BLOCK):
            n1 = min(n0 + BLOCK, n_out)
            t = clock.to_true(np.arange(n0, n1) / fs)
            tau = model.delays(t)
            pos = (t[None, :] - tau) * fs
            lo, hi = input_span(pos)
            if hi <= 0 or lo >= source.n:  # the input is silent there
                scratch.write(n0, np.zeros(n1 - n0))
            else:
                gi, gq = model.gains(t, tau)
                scratch.write(n0, render_paths(_segment(source, lo, hi), lo, pos, gi, gq))
            bar.update(n1 - n0)


def _frame_powers(scratch, truth: list[dict], fs: float, n_out: int, band: tuple[float, float]) -> list[float]:
    powers = []
    for row in truth:
        i0 = max(0, round(row["t_arrival_s"] * fs))
        i1 = min(n_out, round((row["t_arrival_s"] + row["reception_duration_s"]) * fs))
        powers.append(in_band_power(scratch.read(i0, i1), fs, band) if i1 > i0 else 0.0)
    return powers


def noise_pass(scratch, n_out: int, fs: float, scenario: Scenario, band_hz, truth: list[dict],
               powers: list[float] | None, seed: np.random.SeedSequence, sink, progress) -> dict:
    """Second pass: add [noise] at the in-band SNR (module docstring); fill each frame's SNR.

    Parameters
    ----------
    scratch : ArrayScratch or a file scratch
        The noise-free output (``read(n0, n1)``).
    n_out : int
        Output length [samples].
    fs : float
        Sample rate [Hz].
    scenario : Scenario
        Its ``[noise]`` table (kind, SNR [dB]).
    band_hz : (float, float)
        The data band the SNR is measured in [Hz].
    truth : list of dict
        Per-frame truth rows, given ``signal_power_in_band`` and ``snr_db`` [dB] here.
    powers : list of float or None
        In-band signal power of each frame (None: of the whole output).
    seed : numpy.random.SeedSequence
        The noise's seed.
    sink : callable
        Called with each noisy output block, in order.
    progress : bool or None
        Progress bar (None: on a terminal).

    Returns
    -------
    dict
        The noise as applied: kind, SNR [dB], band [Hz], powers and σ.
    """
    noise_src = make_noise_source(scenario, fs, np.random.default_rng(seed))
    if powers is None:
        powers = [in_band_power(scratch.read(0, n_out), fs, band_hz)] if noise_src is not None else []
    info: dict[str, Any] = {"kind": scenario.noise.kind}
    sigma = 0.0
    n_band = None
    if noise_src is not None:
        p_ref = float(np.mean(powers))
        if p_ref <= 0:
            raise ConfigError("noise.snr_db", "the received signal has no power in the data band to set an SNR against")
        n_band = p_ref / 10.0 ** (scenario.noise.snr_db / 10.0)
        sigma = math.sqrt(n_band / noise_src.in_band_fraction(band_hz))
        info.update(snr_db=scenario.noise.snr_db, band_hz=list(band_hz), signal_power_in_band=p_ref,
                    noise_power_in_band=n_band, noise_sigma=sigma,
                    definition="mean over frames of the in-band received signal power / expected in-band noise power")
    for row, p in zip(truth, powers):
        row["signal_power_in_band"] = p
        row["snr_db"] = 10.0 * math.log10(p / n_band) if n_band and p > 0 else None
    with progress_bar(total=n_out, unit="sample", unit_scale=True, desc="noise", enabled=progress) as bar:
        for n0 in range(0, n_out, BLOCK):
            n1 = min(n0 + BLOCK, n_out)
            y = scratch.read(n0, n1)
            if noise_src is not None:
                y += sigma * noise_src.block(n1 - n0)
            sink(y)
            bar.update(n1 - n0)
    return info


def _run(
    source,
    fs: float,
    scenario: Scenario,
    *,
    t_emit_s: Sequence[float],
    frame_duration_s: float | None,
    band_hz: tuple[float, float],
    reference_frequency_hz: float,
    make_scratch: Callable[[int], Any],
    sink: Callable[[np.ndarray], None],
    progress: bool | None,
) -> tuple[list[dict], dict]:
    """Both passes; returns (truth, channel section)."""
    if scenario.mode == "replay":
        raise ConfigError("mode", "replay scenarios go through seamodem.channel.replay_file")
    top = max(band_hz)
    if top > PASSBAND_FRACTION * fs:
        raise ConfigError("band_hz", f"signal band reaches {top:g} Hz, above the interpolator's accurate band "
                                     f"{PASSBAND_FRACTION:g}·fs = {PASSBAND_FRACTION * fs:g} Hz")
    model = build_model(scenario, reference_frequency_hz=reference_frequency_hz)
    exchanges = None
    if scenario.two_way is not None:  # the input's frames become replies to the vehicle's polls
        if not len(t_emit_s):
            raise ConfigError("two_way", "needs the input's frames (emission times in its sidecar) to send as replies")
        polls = scenario.two_way.poll_times(len(t_emit_s))
        exchanges = reply_schedule(model, polls, turnaround_s=scenario.two_way.turnaround_s,
                                   frame_duration_s=frame_duration_s)
        source = RetimedInput(source, fs, t_emit_s, exchanges.t_reply_emit_s, frame_duration_s)
        t_emit_s = list(exchanges.t_reply_emit_s)
    seeds = np.random.SeedSequence(scenario.seed).spawn(2)
    t_start = float(model.clock.to_true(0.0))
    t_end = model.end_time(source.n / fs, fs)
    n_out = math.ceil(float(model.clock.to_receiver(t_end)) * fs)
    model.check_span(t_start, t_end)
    model.add_fluctuations(t_start - 1.0, t_end + 1.0, np.random.default_rng(seeds[0]))
    if model.scenario.fluctuation.doppler_spread_hz > 0 and min(band_hz) < HILBERT_LOW_FRACTION * fs:
        raise ConfigError("band_hz", f"path fluctuations need the signal above {HILBERT_LOW_FRACTION:g}·fs "
                                     f"= {HILBERT_LOW_FRACTION * fs:g} Hz (Hilbert interpolator), got {min(band_hz):g} Hz")
    truth = frame_truth(model, t_emit_s, frame_duration_s) if len(t_emit_s) else []
    if exchanges is not None:
        two_way_truth(truth, exchanges, model.c)
    scratch = make_scratch(n_out)
    render_channel(model, source, fs, n_out, scratch, progress)

    powers = _frame_powers(scratch, truth, fs, n_out, band_hz) if truth else None
    noise_info = noise_pass(scratch, n_out, fs, scenario, band_hz, truth, powers, seeds[1], sink, progress)

    channel = {
        "created_by": f"seamodem {__version__}",
        "scenario": scenario.to_dict(),
        "seed": scenario.seed,
        "sound_speed_mps": model.c,
        "sample_rate_hz": fs,
        "clock": {"offset_s": model.clock.offset_s, "sample_rate_offset_ppm": model.clock.sample_rate_offset_ppm},
        "paths": [p.to_dict() for p in model.paths],
        "model": model.describe(),
        "noise": noise_info,
        "output": {
            "n_samples": n_out,
            "duration_s": n_out / fs,
            "input_n_samples": source.n,
            "length_rule": "input duration + largest path delay at the end + interpolator half-length, on the receiver clock",
        },
        **({"two_way": exchanges.to_dict()} if exchanges is not None else {}),
        "truth_columns": (
            "t_arrival_s, tof_s = t_arrival_s - t_emit_s, range_m = c*tof_s, v_r_mps: what an ideal receiver measures "
            "on its own clock (clock errors included); *_true: physical values (direct path, SPEC §1)"
        ),
    }
    return truth, channel


def simulate(
    x: np.ndarray,
    fs: float,
    scenario: Scenario,
    *,
    t_emit_s: Sequence[float] = (),
    frame_duration_s: float | None = None,
    band_hz: tuple[float, float],
    reference_frequency_hz: float | None = None,
    progress: bool | None = False,
) -> SimulationResult:
    """Pass an in-memory recording through a scenario's channel.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,)
        Transmitted recording; sample k at time k/fs on the beacon's clock.
    fs : float
        Sample rate [Hz] of input and output.
    scenario : Scenario
        Geometry or profile mode.
    t_emit_s : sequence of float
        Emission times of the frames [s], for the truth and the SNR reference.
    frame_duration_s : float
        T_F [s]; required with ``t_emit_s``.
    band_hz : (float, float)
        Data band [f0 − B/2, f0 + B/2] [Hz] where the SNR is defined.
    reference_frequency_hz : float, optional
        Frequency of the absorption and rough-surface losses; default the band's centre.

    Returns
    -------
    SimulationResult

    Notes
    -----
    Without frames, the SNR refers to the in-band power of the whole noiseless output.
    """
    if len(t_emit_s) and frame_duration_s is None:
        raise ConfigError("frame_duration_s", "is required with t_emit_s")
    out: list[np.ndarray] = []
    truth, channel = _run(
        ArrayInput(x), float(fs), scenario, t_emit_s=list(t_emit_s), frame_duration_s=frame_duration_s,
        band_hz=tuple(band_hz), reference_frequency_hz=reference_frequency_hz or 0.5 * sum(band_hz),
        make_scratch=ArrayScratch, sink=out.append, progress=progress,
    )
    return SimulationResult(np.concatenate(out) if out else np.zeros(0), truth, channel)


def read_input(in_wav: str | Path) -> tuple[soundfile._SoundFileInfo, dict, FrameConfig]:
    """Header, sidecar and frame configuration of an input recording, checked against each other.

    Raises
    ------
    InputFileError
        Missing or unreadable WAV or sidecar; a WAV sample rate that disagrees
        with the sidecar; a multichannel or empty WAV.
    """
    in_wav = Path(in_wav)
    info = wav_info(in_wav)
    side_in = read_sidecar(sidecar_path(in_wav))
    _check_input(in_wav, info, side_in)
    return info, side_in, FrameConfig.from_dict(side_in["config"])


def _check_input(in_wav: Path, info, side_in: dict) -> None:
    rate = side_in["recording"].get("sample_rate_hz")
    if int(info.samplerate) != rate:
        raise InputFileError(
            f"{in_wav}: WAV sample rate {info.samplerate} Hz disagrees with its sidecar's recording.sample_rate_hz = {rate}"
        )
    if info.channels != 1:
        raise InputFileError(f"{in_wav}: has {info.channels} channels; the channel simulator takes a mono recording")
    if info.frames == 0:
        raise InputFileError(f"recording {in_wav} holds no samples")


def read_reference_input(in_wav: str | Path) -> tuple[soundfile._SoundFileInfo, dict, float, tuple[float, float]] | None:
    """Header, sidecar, longest ping [s] and band [Hz] of a ``seamodem tx --reference`` schedule; None for others.

    Raises
    ------
    InputFileError
        As :func:`read_input`; a reference sidecar without references or emissions.
    """
    import json

    in_wav = Path(in_wav)
    try:
        side_in = json.loads(sidecar_path(in_wav).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None  # not there or not JSON: read_input says which
    from ..transmit.reference import REFERENCE_SIDECAR_FORMAT, ReferenceWaveform

    if not isinstance(side_in, dict) or side_in.get("format") != REFERENCE_SIDECAR_FORMAT:
        return None
    if not side_in.get("references") or not side_in.get("frames") or "recording" not in side_in:
        raise InputFileError(f"reference sidecar {sidecar_path(in_wav)} lacks its references, frames or recording")
    try:
        refs = [ReferenceWaveform.from_dict(r) for r in side_in["references"]]
    except (ConfigError, TypeError, ValueError) as exc:
        raise InputFileError(f"reference sidecar {sidecar_path(in_wav)}: {exc}") from None
    info = wav_info(in_wav)
    _check_input(in_wav, info, side_in)
    band = (min(r.f_low_hz for r in refs), max(r.f_high_hz for r in refs))
    return info, side_in, max(r.duration_s for r in refs), band


#: An output whose peak exceeds this fraction of full scale is scaled down to OUTPUT_PEAK, so that
#: no sample reaches full scale (a receiver would take it for clipping). Truth and SNR are unchanged.
OUTPUT_PEAK_LIMIT = 0.9
OUTPUT_PEAK = 0.5


def _rescale_wav(path: Path, gain: float, fs: int, block: int = 1 << 20) -> None:
    """Multiply a float WAV by ``gain`` in place (through a temporary beside it, in blocks)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{Path(path).name}.", suffix=".gain", dir=Path(path).parent)
    os.close(fd)
    try:
        with soundfile.SoundFile(str(path)) as fin, soundfile.SoundFile(
            tmp, "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
        ) as fout:
            for chunk in fin.blocks(blocksize=block, dtype="float64"):
                fout.write(gain * chunk)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _frames_as_polls(side: dict, two_way: dict) -> None:
    """Two-way: each frame's ``t_emit_s`` becomes its poll's (vehicle clock), what ``rx --turnaround`` pairs it with.

    The input's emission time is kept as ``t_emit_input_s`` and the beacon's
    reply emission (true time) as ``t_reply_emit_s``.
    """
    for frame, t_poll, t_reply in zip(side["frames"], two_way["t_poll_s"], two_way["t_reply_emit_s"]):
        frame["t_emit_input_s"] = frame["t_emit_s"]
        frame["t_emit_s"] = t_poll
        frame["t_reply_emit_s"] = t_reply


def write_outputs(in_wav: str | Path, out_wav: str | Path, side_in: dict, produce, *, command: str) -> dict[str, Any]:
    """Run ``produce(fin, sink, make_scratch) -> (truth, channel)`` and write OUT.wav + OUT.json atomically.

    ``fin`` is the open input; ``sink(block)`` appends to OUT.wav (32-bit
    float); ``make_scratch(n)`` gives a temporary float64 file of n samples.
    """
    in_wav, out_wav = Path(in_wav), Path(out_wav)
    side = copy.deepcopy(side_in)
    rec = side_in["recording"]
    fs = int(rec["sample_rate_hz"])
    scratches: list[_FileScratch] = []

    def make_scratch(n):
        scratches.append(_FileScratch(out_wav.parent))
        return scratches[-1]

    peak = 0.0
    with atomic_outputs(out_wav, sidecar_path(out_wav)) as (tmp_wav, tmp_json):
        try:
            with soundfile.SoundFile(str(in_wav)) as fin, soundfile.SoundFile(
                str(tmp_wav), "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
            ) as fout:

                def sink(block):
                    nonlocal peak
                    if block.size:
                        peak = max(peak, float(np.max(np.abs(block))))
                    fout.write(block)

                truth, channel = produce(fin, sink, make_scratch)
        finally:
            for s in scratches:
                s.close()
        gain = 1.0
        if peak > OUTPUT_PEAK_LIMIT:
            gain = OUTPUT_PEAK / peak
            _rescale_wav(tmp_wav, gain, fs)
            peak *= gain
        channel["output"]["gain"] = gain
        channel["command"] = command
        channel["input"] = in_wav.name
        channel["input_recording"] = rec
        if "two_way" in channel:
            _frames_as_polls(side, channel["two_way"])
        side["channel"] = channel
        side["truth"] = truth
        side["recording"] = {
            "file": out_wav.name,
            "sample_rate_hz": fs,
            "n_samples": channel["output"]["n_samples"],
            "duration_s": channel["output"]["duration_s"],
            "subtype": "FLOAT",
            "scale": rec.get("scale"),
            "peak": peak,
        }
        write_json(tmp_json, side)
    return side


def simulate_file(
    in_wav: str | Path,
    scenario: Scenario,
    out_wav: str | Path,
    *,
    command: str = "",
    progress: bool | None = None,
) -> dict[str, Any]:
    """``seamodem channel``: read IN.wav and its sidecar, write OUT.wav and OUT.json.

    OUT.json is the input sidecar carried forward, with ``recording`` describing
    OUT.wav (32-bit float; the input's own ``recording`` kept as
    ``channel.input_recording``), a ``channel`` section and a ``truth`` list.
    Memory stays bounded: the input is read and the output written in blocks,
    through a temporary file beside OUT.wav.

    Raises
    ------
    InputFileError
        See :func:`read_input`.
    ConfigError
        An invalid scenario for this recording.
    """
    out_wav = check_writable(out_wav)
    reference = read_reference_input(in_wav)  # a schedule of reference pings (seamodem tx --reference)
    if reference is not None:
        info, side_in, frame_duration_s, band_hz = reference
        centre_hz = 0.5 * (band_hz[0] + band_hz[1])
    else:
        info, side_in, config = read_input(in_wav)
        frame_duration_s, band_hz, centre_hz = config.frame_duration_s, config.data_band_hz, config.carrier_hz
    fs = float(info.samplerate)
    t_emit = [float(f["t_emit_s"]) for f in side_in["frames"]]

    def produce(fin, sink, make_scratch):
        return _run(
            _WavInput(fin), fs, scenario, t_emit_s=t_emit, frame_duration_s=frame_duration_s,
            band_hz=band_hz, reference_frequency_hz=centre_hz,
            make_scratch=make_scratch, sink=sink, progress=progress,
        )

    return write_outputs(in_wav, out_wav, side_in, produce, command=command)
