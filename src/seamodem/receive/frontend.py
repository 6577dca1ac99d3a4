"""Receiver front end: passband → decimated complex baseband of the data band and of the tone.

One real FFT per block does band-pass filtering, down-conversion and decimation
for both branches at once (frequency-domain overlap-save):

1. a block of N input samples, overlapping its neighbours by ``2·margin``, is
   transformed once (``rfft``);
2. for each branch, the M = N/D bins around its centre frequency are kept,
   multiplied by the frequency response of a zero-phase Kaiser low-pass FIR
   (``dsp.lowpass_taps``), and inverse-transformed at size M: this is the
   low-passed, down-converted signal decimated by D, exactly as a linear
   convolution would give it on the ``hop`` samples in the block's middle;
3. the centre frequency's offset from the nearest FFT bin and the block's
   start time are removed by a phase ramp, so that the output follows the
   convention of :func:`seamodem.dsp.pb2bb`: x_pb = Re[x_bb e^{+j2π fc t}],
   t = 0 at the first input sample.

The input sample rate is whatever the recording has: it only has to hold the
data band (fs > 2·(f0 + B/2)); the decimated rates follow from it. A recording
at another rate than the configuration's is therefore resampled here, not
rejected. Memory is a few blocks, whatever the recording's length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ..config import FrameConfig
from ..dsp import lowpass_taps
from ..errors import ConfigError

__all__ = ["Branch", "FrontEndPlan", "FrontEnd", "plan_front_end"]

#: Target input block length [samples]; the actual N is a nearby multiple of the decimations. 2¹⁶
#: (N = 66150 at 96 kHz): the real FFT costs 18–22 ns per sample there against 37 at 2¹⁸ (a 2 MB
#: transform out of cache), and the overlap of 2 × margin (1120 samples) costs 1.7 %: the front end
#: 11.4 → 4.8 ms CPU per 3 s of recording
_BLOCK_TARGET = 1 << 16
#: Extra width of the tone branch beyond ±f_max [Hz]: a wide transition keeps the
#: filter short (≈ 11 ms at 96 kHz), so the tone's ends are hardly smeared.
_TONE_TRANSITION_HZ = 500.0


def _smooth5_at_most(n: int) -> int:
    """Largest 2^a·3^b·5^c ≤ n (n ≥ 1): block sizes that FFT fast."""
    best = 1
    p2 = 1
    while p2 <= n:
        p3 = p2
        while p3 <= n:
            p5 = p3
            while p5 <= n:
                best = max(best, p5)
                p5 *= 5
            p3 *= 3
        p2 *= 2
    return best


@dataclass(frozen=True)
class Branch:
    """One output band of the front end: its centre, filter edges, decimation and low-pass FIR.

    The frame receiver has two (data and tone, :func:`plan_front_end`); the reference
    receiver one, on the references' band (:func:`~seamodem.receive.reference.plan_band`).

    Parameters
    ----------
    centre_hz : float
        Mixing frequency [Hz].
    passband_hz : float
        Half-width kept around the centre [Hz].
    stopband_hz : float
        Stop edge of the low-pass filter [Hz].
    decimation : int
        D: input samples per output sample.
    taps : numpy.ndarray
        Zero-phase low-pass FIR at the input rate (odd length; :func:`~seamodem.dsp.lowpass_taps`).
    """

    centre_hz: float
    passband_hz: float
    stopband_hz: float
    decimation: int
    taps: np.ndarray

    @property
    def half_length(self) -> int:
        """Half the FIR's length [input samples]: (len(taps) − 1)/2."""
        return (len(self.taps) - 1) // 2


@dataclass(frozen=True)
class FrontEndPlan:
    """Rates, filters and block sizes of the front end for one input rate.

    Attributes
    ----------
    fs : float
        Input sample rate [Hz].
    data, tone : Branch
        Centre, pass and stop edges [Hz], decimation and FIR of each branch.
    block_size : int
        N, input samples per FFT.
    hop : int
        New input samples per block (N − 2·margin).
    margin : int
        Overlap on each side [samples], ≥ the longer filter's half length.
    """

    fs: float
    data: Branch
    tone: Branch
    block_size: int
    hop: int
    margin: int

    @property
    def fs_data(self) -> float:
        """Sample rate of the data-band baseband [Hz]."""
        return self.fs / self.data.decimation

    @property
    def fs_tone(self) -> float:
        """Sample rate of the tone baseband [Hz]."""
        return self.fs / self.tone.decimation

    def noise_bandwidth_hz(self, branch: str) -> float:
        """Equivalent noise bandwidth ∫|H(f)|² df of a branch's filter [Hz]."""
        taps = getattr(self, branch).taps
        return float(self.fs * np.sum(taps**2))


def plan_front_end(config: FrameConfig, fs: float, *, v_max_mps: float, sound_speed_mps: float,
                   block_target: int | None = None) -> FrontEndPlan:
    """Choose the filters, decimations and block size for input rate ``fs``.

    Parameters
    ----------
    config : FrameConfig
        Carrier, symbol rate, roll-off and tone frequency.
    fs : float
        Sample rate of the recording [Hz] (not necessarily the config's).
    v_max_mps : float
        Largest |v_r| to receive [m/s]; the tone branch passes ±v_max·f_pt/c.
    sound_speed_mps : float
        c [m/s].
    block_target : int, optional
        Input samples per FFT block, roughly (default :data:`_BLOCK_TARGET`, 2¹⁶: the cheapest per sample).
        A live receiver asks for less: a frame's baseband is ready only when its block is complete, so
        the block's length adds up to one block of latency.

    Raises
    ------
    ConfigError
        When fs cannot hold the data band or the tone.
    """
    fs = float(fs)
    half_band = config.bandwidth_hz / 2
    top = max(config.carrier_hz + half_band, config.tone_hz)
    if fs <= 2 * top:
        raise ConfigError(
            "sample_rate_hz",
            f"the recording's rate {fs:g} Hz cannot hold the signal up to {top:g} Hz (need > {2 * top:g} Hz)",
        )
    gap = abs(config.tone_hz - config.carrier_hz) - half_band  # tone to data-band edge
    f_max = v_max_mps * config.tone_hz / sound_speed_mps
    data_stop = half_band + min(0.35 * half_band, gap / 2)
    tone_pass = f_max + 20.0
    tone_stop = tone_pass + min(_TONE_TRANSITION_HZ, max(gap - tone_pass, 50.0) / 2)
    d_data = max(1, int(fs // (2 * data_stop)))
    d_tone = d_data * max(1, _smooth5_at_most(int(fs // (2 * tone_stop)) // d_data))
    data = Branch(config.carrier_hz, half_band, data_stop, d_data, lowpass_taps(fs, half_band, data_stop))
    tone = Branch(config.tone_hz, tone_pass, tone_stop, d_tone, lowpass_taps(fs, tone_pass, tone_stop))
    longest = max(data.half_length, tone.half_length)
    margin = d_tone * math.ceil(longest / d_tone)
    target = _BLOCK_TARGET if block_target is None else int(block_target)
    n_blocks_of_tone = max(4 * margin // d_tone + 1, target // d_tone)
    block = d_tone * scipy.fft.next_fast_len(n_blocks_of_tone)
    for br in (data, tone):
        m = block // br.decimation
        k0 = round(br.centre_hz * block / fs)
        if k0 - m // 2 < 0 or k0 + (m + 1) // 2 > block // 2:
            raise ConfigError(
                "sample_rate_hz",
                f"the band around {br.centre_hz:g} Hz does not fit between 0 and fs/2 = {fs / 2:g} Hz",
            )
    return FrontEndPlan(fs=fs, data=data, tone=tone, block_size=block, hop=block - 2 * margin, margin=margin)


def _frequency_response(taps: np.ndarray, n: int) -> np.ndarray:
    """Real DFT response of a zero-phase symmetric FIR on an n-point grid (bin k ↔ k·fs/n)."""
    half = (len(taps) - 1) // 2
    circular = np.zeros(n)
    circular[: half + 1] = taps[half:]
    circular[n - half :] = taps[:half]
    return scipy.fft.rfft(circular).real


class _BranchExtractor:
    """Bins, mask and phase ramp of one branch for blocks of the plan's size."""

    def __init__(self, branch: Branch, plan: FrontEndPlan):
        n = plan.block_size
        self.m = n // branch.decimation
        self.decimation = branch.decimation
        self.k0 = round(branch.centre_hz * n / plan.fs)
        offsets = np.arange(-(self.m // 2), self.m - self.m // 2)
        self.bins = self.k0 + offsets
        # pb2bb's factor 2 (complex envelope) and the inverse FFT's 1/M → N scaling
        response = _frequency_response(branch.taps, n)[np.abs(offsets)]  # real and even in f
        mask = response * 2.0 * self.m / n
        self.mask = np.fft.ifftshift(mask)
        self.order = np.fft.ifftshift(np.arange(self.m))
        residual = branch.centre_hz - self.k0 * plan.fs / n
        self.ramp = np.exp(-2j * np.pi * residual * np.arange(self.m) * branch.decimation / plan.fs)
        self.centre_hz = branch.centre_hz
        self.fs = plan.fs
        self.keep = slice(plan.margin // branch.decimation, (plan.margin + plan.hop) // branch.decimation)

    def __call__(self, spectrum: np.ndarray, block_start: int) -> np.ndarray:
        sel = spectrum[self.bins][self.order] * self.mask
        y = scipy.fft.ifft(sel)
        # carrier phase at the block's first sample, computed modulo one cycle for precision
        cycles = math.fmod(self.centre_hz * block_start, self.fs) / self.fs
        y *= self.ramp * np.exp(-2j * np.pi * cycles)
        return y[self.keep]


class FrontEnd:
    """Streaming front end: push passband blocks, get both basebands in order.

    Output sample i of the data branch is at t = i / fs_data, of the tone branch
    at t = i / fs_tone (t = 0 at the first input sample).

    Parameters
    ----------
    plan : FrontEndPlan

    Examples
    --------
    >>> from seamodem import get_preset
    >>> cfg = get_preset("jmse2024")
    >>> fe = FrontEnd(plan_front_end(cfg, 96153, v_max_mps=5, sound_speed_mps=1500))
    >>> bb, tone = fe.push(np.zeros(300_000))
    >>> more_bb, more_tone = fe.flush()
    >>> len(bb) + len(more_bb) == -(-300_000 // fe.plan.data.decimation)
    True
    """

    def __init__(self, plan: FrontEndPlan):
        self.plan = plan
        self._data = _BranchExtractor(plan.data, plan)
        self._tone = _BranchExtractor(plan.tone, plan)
        self._pending = np.zeros(plan.margin)  # leading zeros: the first output is at t = 0
        self._block_start = -plan.margin  # input index of _pending[0]
        self._n_in = 0
        self._emitted = [0, 0]

    def _blocks(self, final: bool):
        p = self.plan
        out_d, out_t = [], []
        while len(self._pending) >= p.block_size or (final and len(self._pending) > 2 * p.margin):
            block = self._pending[: p.block_size]
            if len(block) < p.block_size:
                block = np.concatenate([block, np.zeros(p.block_size - len(block))])
            spectrum = scipy.fft.rfft(block)
            out_d.append(self._data(spectrum, self._block_start))
            out_t.append(self._tone(spectrum, self._block_start))
            self._pending = self._pending[p.hop :]
            self._block_start += p.hop
        return out_d, out_t

    def push(self, x_pb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Add real passband samples; return the new (data, tone) baseband samples."""
        self._n_in += len(x_pb)
        self._pending = np.concatenate([self._pending, np.asarray(x_pb, dtype=np.float64)])
        return self._emit(*self._blocks(final=False))

    def flush(self) -> tuple[np.ndarray, np.ndarray]:
        """End of input: the remaining samples, up to the last input sample's time."""
        self._pending = np.concatenate([self._pending, np.zeros(self.plan.margin)])
        return self._emit(*self._blocks(final=True), final=True)

    def _emit(self, out_d, out_t, final: bool = False):
        bb = np.concatenate(out_d) if out_d else np.zeros(0, complex)
        tone = np.concatenate(out_t) if out_t else np.zeros(0, complex)
        if final:
            # the zero-padded last block runs past the input: keep outputs at t < n_in / fs
            bb = bb[: max(0, -(-self._n_in // self.plan.data.decimation) - self._emitted[0])]
            tone = tone[: max(0, -(-self._n_in // self.plan.tone.decimation) - self._emitted[1])]
        self._emitted[0] += len(bb)
        self._emitted[1] += len(tone)
        return bb, tone
