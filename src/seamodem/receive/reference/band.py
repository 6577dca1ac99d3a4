"""The reference receiver's band plan and front end: passband → complex baseband on the references' band."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ...dsp import lowpass_taps
from ...errors import ConfigError
from ...transmit.reference import ReferenceWaveform
from ..frontend import Branch, FrontEnd, FrontEndPlan

__all__ = ["BandPlan", "plan_band", "BandDecimator"]


@dataclass(frozen=True)
class BandPlan:
    """Mixing frequency, filter and rates of the front end (built by :func:`plan_band`).

    Parameters
    ----------
    centre_hz : float
        Mixing frequency [Hz].
    passband_hz : float
        Half-width kept around the centre [Hz].
    front_end : FrontEndPlan
        The frame receiver's frequency-domain front end (:mod:`~seamodem.receive.frontend`) set
        to this band (its tone branch is the same band, unused).
    """

    centre_hz: float
    passband_hz: float
    front_end: FrontEndPlan

    @property
    def fs(self) -> float:
        """Input rate [Hz]."""
        return self.front_end.fs

    @property
    def decimation(self) -> int:
        """Input samples per baseband sample."""
        return self.front_end.data.decimation

    @property
    def fs_bb(self) -> float:
        """Baseband rate [Hz]."""
        return self.front_end.fs_data

    @property
    def noise_bandwidth_hz(self) -> float:
        """∫|H|² df of the front end [Hz]: baseband noise variance = 2 N0 × this."""
        return self.front_end.noise_bandwidth_hz("data")


def plan_band(references: Iterable[ReferenceWaveform], fs: float, *, v_max_mps: float, sound_speed_mps: float) -> BandPlan:
    """Front end for the union of the references' bands at input rate ``fs``.

    The stop edge is fs_bb − passband: what aliases on decimation lands in the
    transition band only, never on the references' band; the filter costs
    nothing more for being long (it is applied in the frequency domain).

    Parameters
    ----------
    references : iterable of ReferenceWaveform
        The pings to receive: the band is the union of theirs.
    fs : float
        Input (recording) sample rate [Hz].
    v_max_mps : float
        Largest |v_r| searched [m/s]: the band is widened by its Doppler scale.
    sound_speed_mps : float
        c [m/s].

    Returns
    -------
    BandPlan
        Centre, half-width, decimation, filter and block sizes.

    Raises
    ------
    ConfigError
        A band (widened by the largest Doppler) at or above fs/2.
    """
    refs = list(references)
    eps = v_max_mps / sound_speed_mps
    lo = min(r.f_low_hz for r in refs) * (1 - eps)
    hi = max(r.f_high_hz for r in refs) * (1 + eps)
    if hi >= fs / 2:
        raise ConfigError(
            "sample_rate_hz", f"the reference band reaches {hi:g} Hz (with Doppler), above the recording's Nyquist {fs / 2:g} Hz"
        )
    # the passband keeps the pings' spectral tails (window sidelobes) beyond the nominal band: a filtered
    # ping would no longer match its replica, and an HFM's flat delay–Doppler ridge tilts at the slightest mismatch
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo) + max(50.0, 0.1 * (hi - lo))
    transition = max(0.3 * half, 300.0)
    d = max(1, int(fs // (2 * half + transition)))
    stop = min(fs / d - half, 0.5 * fs * 0.999)
    branch = Branch(centre, half, stop, d, lowpass_taps(float(fs), half, stop, 80.0))
    margin = d * math.ceil(branch.half_length / d)
    block = d * scipy.fft.next_fast_len(max(4 * margin // d + 1, (1 << 18) // d))
    if round(centre * block / fs) + (block // d + 1) // 2 > block // 2 or round(centre * block / fs) - block // d // 2 < 0:
        raise ConfigError("sample_rate_hz", f"the reference band does not fit between 0 and fs/2 = {fs / 2:g} Hz")
    plan = FrontEndPlan(fs=float(fs), data=branch, tone=branch, block_size=block, hop=block - 2 * margin, margin=margin)
    return BandPlan(centre_hz=centre, passband_hz=half, front_end=plan)


class BandDecimator:
    """Streaming passband → complex baseband: x_pb = Re[y e^{j2π f_c t}], y[k] at t = k/fs_bb.

    The frame receiver's :class:`~seamodem.receive.frontend.FrontEnd` (one
    real FFT per block, the band's bins kept and filtered), on the references' band.

    Parameters
    ----------
    plan : BandPlan
        The band, rates and filter (:func:`plan_band`).

    Examples
    --------
    >>> from seamodem.transmit.reference import parse_reference
    >>> plan = plan_band([parse_reference("lfm:19000-29000:0.05")], 96000, v_max_mps=5, sound_speed_mps=1500)
    >>> dec = BandDecimator(plan)
    >>> n = len(dec.push(np.zeros(50_000))) + len(dec.flush())
    >>> n == -(-50_000 // plan.decimation)
    True
    """

    def __init__(self, plan: BandPlan):
        self.plan = plan
        self._fe = FrontEnd(plan.front_end)

    def push(self, x_pb: np.ndarray) -> np.ndarray:
        """Baseband of the next input samples, as far as the filter allows.

        Parameters
        ----------
        x_pb : numpy.ndarray, shape (n,)
            The next passband samples (any block length).

        Returns
        -------
        numpy.ndarray, complex
            The baseband samples now complete, at ``plan.fs_bb``, continuing the previous output.
        """
        return self._fe.push(x_pb)[0]

    def flush(self) -> np.ndarray:
        """The rest of the baseband once the input has ended.

        Returns
        -------
        numpy.ndarray, complex
            The last baseband samples (the input padded with zeros).
        """
        return self._fe.flush()[0]
