"""The channel's block rendering: inputs, scratch buffers, the two passes over the output.

:func:`render_channel` is the first pass (the noiseless received signal, block
by block, into a scratch buffer), :func:`frame_powers` the in-band power of
each frame in it, :func:`noise_pass` the second pass (noise at the in-band SNR,
:mod:`.simulate`'s docstring). :mod:`.simulate` and :mod:`.replay` drive them;
:mod:`.files` holds the file-level input and output.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import soundfile

from .._progress import progress_bar
from ..errors import ConfigError
from .model import ChannelModel
from .noise import AlphaStableNoise, AmbientNoise, GaussianMixtureNoise, NoiseSource, WhiteNoise
from .resample import input_span, render_paths
from .scenario import Scenario
from .truth import in_band_power

__all__ = [
    "BLOCK",
    "make_noise_source",
    "ArrayInput",
    "WavInput",
    "ArrayScratch",
    "render_channel",
    "frame_powers",
    "noise_pass",
]


#: output samples per block of either pass
BLOCK = 1 << 16


def make_noise_source(scenario: Scenario, fs: float, rng: np.random.Generator) -> NoiseSource | None:
    """The [noise] table's source, or None for kind = "none".

    Parameters
    ----------
    scenario : Scenario
        Its [noise] table.
    fs : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        The noise's generator.

    Returns
    -------
    NoiseSource or None
        The source.
    """
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


class WavInput:
    """The channel's input from an open mono sound file, read where asked.

    Parameters
    ----------
    f : soundfile.SoundFile
        The open input.
    """

    def __init__(self, f: soundfile.SoundFile):
        self.f = f
        self.n = f.frames

    def read(self, lo: int, hi: int) -> np.ndarray:
        """Samples [lo, hi) (0 <= lo <= hi <= n).

        Parameters
        ----------
        lo, hi : int
            Sample range [samples].

        Returns
        -------
        numpy.ndarray
            The samples, float64.
        """
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


def frame_powers(scratch, truth: list[dict], fs: float, n_out: int, band: tuple[float, float]) -> list[float]:
    """In-band power of the noiseless output over each frame's direct-path reception window.

    Parameters
    ----------
    scratch : ArrayScratch or a file scratch
        The noise-free output (``read(n0, n1)``).
    truth : list of dict
        Per-frame truth rows (``t_arrival_s``, ``reception_duration_s``).
    fs : float
        Sample rate [Hz].
    n_out : int
        Output length [samples].
    band : (float, float)
        The data band [Hz].

    Returns
    -------
    list of float
        One power per frame (0 for a window outside the output).
    """
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
