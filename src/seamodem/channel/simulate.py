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

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .._version import __version__
from ..errors import ConfigError
from ..io.files import check_writable
from .files import (  # noqa: F401  (re-exported: defined here before the split)
    OUTPUT_PEAK,
    OUTPUT_PEAK_LIMIT,
    read_input,
    read_janus_input,
    read_reference_input,
    write_outputs,
)
from .model import build_model
from .render import (  # noqa: F401  (re-exported: defined here before the split)
    BLOCK,
    ArrayInput,
    ArrayScratch,
    WavInput,
    frame_powers,
    make_noise_source,
    noise_pass,
    render_channel,
)
from .resample import HILBERT_LOW_FRACTION, PASSBAND_FRACTION
from .scenario import Scenario
from .truth import frame_truth
from .two_way import RetimedInput, reply_schedule, two_way_truth

__all__ = ["SimulationResult", "simulate", "simulate_file", "make_noise_source"]


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

    powers = frame_powers(scratch, truth, fs, n_out, band_hz) if truth else None
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

    Parameters
    ----------
    in_wav : str or Path
        The transmitted recording (``seamodem tx``: frames, reference pings or JANUS packets) with its sidecar.
    scenario : Scenario
        The channel.
    out_wav : str or Path
        The received recording to write (its sidecar beside it).
    command : str
        The command line, recorded in the sidecar.
    progress : bool, optional
        Progress bar (None: on a terminal).

    Returns
    -------
    dict
        The output sidecar as written.

    Raises
    ------
    InputFileError
        See :func:`read_input`.
    ConfigError
        An invalid scenario for this recording.
    """
    out_wav = check_writable(out_wav)
    reference = read_reference_input(in_wav)  # a schedule of reference pings (seamodem tx --reference)
    janus = read_janus_input(in_wav)  # JANUS packets (seamodem tx --janus)
    if reference is not None:
        info, side_in, frame_duration_s, band_hz = reference
        centre_hz = 0.5 * (band_hz[0] + band_hz[1])
    elif janus is not None:
        info, side_in, frame_duration_s, band_hz, centre_hz = janus
    else:
        info, side_in, config = read_input(in_wav)
        frame_duration_s, band_hz, centre_hz = config.frame_duration_s, config.data_band_hz, config.carrier_hz
    fs = float(info.samplerate)
    t_emit = [float(f["t_emit_s"]) for f in side_in["frames"]]

    def produce(fin, sink, make_scratch):
        return _run(
            WavInput(fin), fs, scenario, t_emit_s=t_emit, frame_duration_s=frame_duration_s,
            band_hz=band_hz, reference_frequency_hz=centre_hz,
            make_scratch=make_scratch, sink=sink, progress=progress,
        )

    return write_outputs(in_wav, out_wav, side_in, produce, command=command)
