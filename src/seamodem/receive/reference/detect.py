"""The reference receiver's detector: a bank of time-scaled replicas correlated by FFT (:class:`ReferenceDetector`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ...transmit.reference import Replica
from ..detect import cluster_crossings, first_distinct_peak, z_threshold
from ..settings import MIN_RHO
from .band import BandPlan

__all__ = ["ReferenceDetection", "ReferenceDetector", "replica_samples", "MIN_RHO"]


@dataclass(frozen=True)
class ReferenceDetection:
    """A coarse detection: lag, scale bin and statistics.

    Parameters
    ----------
    t_start_s : float
        Coarse arrival (±½ baseband sample) [s].
    eps : float
        Scale bin ε_b.
    z, rho : float
        Detection statistic and normalised correlation.
    """

    t_start_s: float
    eps: float
    z: float
    rho: float


def replica_samples(replica: Replica, fs_bb: float, carrier_hz: float, eps: float) -> np.ndarray:
    """The replica at baseband, time-scaled by 1 + ε, sampled from its first sample on.

    Parameters
    ----------
    replica : Replica
        The reference's replica (:func:`~seamodem.transmit.reference.reference_replica`).
    fs_bb : float
        Baseband sample rate [Hz].
    carrier_hz : float
        Mixing frequency of the baseband [Hz].
    eps : float
        Doppler scale ε (the received ping lasts duration/(1 + ε)).

    Returns
    -------
    numpy.ndarray, complex
        q[n] = s_a((1 + ε) n/fs_bb) mixed to baseband, n = 0 … ⌈duration/(1 + ε)·fs_bb⌉.
    """
    n = int(math.ceil(replica.duration_s / (1 + eps) * fs_bb)) + 1
    return replica.scaled(np.arange(n) / fs_bb, t_arrival_s=0.0, eps=eps, carrier_hz=carrier_hz)


def _scale_spacing(replica: Replica, fs_bb: float, carrier_hz: float, eps_max: float) -> float:
    """Largest scale step with ≤ 1 dB correlation loss (max over lags) between neighbouring bins, measured."""
    q0 = replica_samples(replica, fs_bb, carrier_hz, 0.0)
    e0 = np.sum(np.abs(q0) ** 2)
    n = scipy.fft.next_fast_len(2 * len(q0) + 8)
    f0 = np.conj(scipy.fft.fft(q0, n))

    def loss(step):
        q = replica_samples(replica, fs_bb, carrier_hz, step / 2)
        c = scipy.fft.ifft(scipy.fft.fft(q, n) * f0)
        return np.max(np.abs(c)) / math.sqrt(e0 * np.sum(np.abs(q) ** 2))

    step = max(2 * eps_max, 1e-5)
    while step > 1e-7 and loss(step) < 10 ** (-1 / 20):
        step /= 1.5
    return step


class ReferenceDetector:
    """Find one reference's arrivals in a stream of baseband samples (the bank of time-scaled replicas).

    Parameters
    ----------
    replica : Replica
        The reference's replica.
    plan : BandPlan
        The front end whose baseband is searched (rate, mixing frequency).
    v_max_mps : float
        Largest |v_r| searched [m/s]: the scale bins cover ±v_max/c.
    sound_speed_mps : float
        c [m/s].
    false_alarms_per_hour : float
        Design rate in white Gaussian noise [1/h].
    min_rho : float
        Smallest normalised correlation of a detection.
    first_path_fraction : float
        An earlier peak is the first arrival from this fraction of the strongest's amplitude.
    multipath_window_s : float
        How far after the first crossing stronger paths are sought [s] (with the ping's length).
    """

    def __init__(
        self,
        replica: Replica,
        plan: BandPlan,
        *,
        v_max_mps: float,
        sound_speed_mps: float,
        false_alarms_per_hour: float = 0.01,
        min_rho: float = MIN_RHO,
        first_path_fraction: float = 0.3,
        multipath_window_s: float = 0.03,
    ):
        self.replica, self.fs = replica, plan.fs_bb
        self.carrier_hz = plan.centre_hz
        eps_max = v_max_mps / sound_speed_mps
        step = _scale_spacing(replica, self.fs, self.carrier_hz, eps_max)
        n_side = max(0, int(math.ceil(eps_max / step - 0.5)))  # bins k·step, |k| ≤ n_side, cover ±ε_max within ±step/2
        self.eps = step * np.arange(-n_side, n_side + 1) if n_side else np.zeros(1)
        self.replicas = [replica_samples(replica, self.fs, self.carrier_hz, e) for e in self.eps]
        self.length = max(len(q) for q in self.replicas)
        self.energy = np.array([np.sum(np.abs(q) ** 2) for q in self.replicas])
        self.eta = z_threshold(false_alarms_per_hour, len(self.eps), self.fs)
        self.min_rho = float(min_rho)
        self.first_path_fraction = float(first_path_fraction)
        # the strongest path is sought over a ping's length too: a ping's own correlation sidelobes (a periodic
        # template) can cross the threshold before its main peak, and must not pass for the first arrival
        self.window = max(1, int(round((multipath_window_s + replica.duration_s) * self.fs)))
        self.half_lobe = max(1, int(math.ceil(self.fs / replica.reference.bandwidth_hz)))
        self.holdoff = max(1, int(replica.duration_s * (1 - 2 * eps_max) * self.fs))
        self.context = int(0.5 * self.fs)
        self._spectra: dict[int, np.ndarray] = {}

    def _bank(self, r: np.ndarray) -> np.ndarray:
        """|c_b[j]|² of every bin b at every full-overlap lag j of ``r``: one FFT of r, one inverse per bin."""
        n_out = len(r) - self.length + 1
        n = scipy.fft.next_fast_len(len(r))
        if n not in self._spectra:
            self._spectra = {n: np.conj(np.stack([scipy.fft.fft(q.astype(np.complex64), n) for q in self.replicas]))}
        spectrum = scipy.fft.fft(r.astype(np.complex64), n)
        power = np.empty((len(self.replicas), n_out), dtype=np.float32)
        for b, bank in enumerate(self._spectra[n]):
            c = scipy.fft.ifft(spectrum * bank)[:n_out]
            power[b] = c.real**2 + c.imag**2
        return power

    def find(self, r: np.ndarray, r_start: int, scan_from: int, *, final: bool) -> tuple[list[ReferenceDetection], int]:
        """Detections at lags ≥ ``scan_from`` (global baseband indices; r[0] is index ``r_start``).

        Parameters
        ----------
        r : numpy.ndarray, complex
            Baseband buffer (:class:`~seamodem.receive.reference.BandDecimator`'s output).
        r_start : int
            Global baseband index of ``r[0]`` [samples].
        scan_from : int
            First lag to search [global baseband index]; up to half a second before it is the noise context.
        final : bool
            No more samples will come: decide arrivals whose window is cut by the end.

        Returns
        -------
        detections : list of ReferenceDetection
            Each arrival found, its scale bin and statistics.
        resume : int
            Global baseband index where the next call resumes.
        """
        lo = max(r_start, scan_from - self.context)
        seg = r[lo - r_start :]
        if len(seg) < self.length:
            return [], scan_from
        power = self._bank(seg)
        # the best bin per lag, row by row (numpy's argmax along a short first axis strides through memory)
        best = np.zeros(power.shape[1], dtype=np.intp)
        peak32 = power[0].copy()
        for k in range(1, len(power)):
            better = power[k] > peak32
            best[better] = k
            np.maximum(peak32, power[k], out=peak32)
        peak = peak32.astype(np.float64)
        noise = max(np.median(power[:, ::4]) / math.log(2), 1e-12 * float(np.max(peak)), np.finfo(float).tiny)
        z = peak / noise
        energy = np.cumsum(np.concatenate([[0.0], np.abs(seg) ** 2]))
        window = (energy[self.length :] - energy[: len(energy) - self.length])[: len(z)]
        rho = peak / (self.energy[best] * np.maximum(window, np.finfo(float).tiny))
        amp = np.sqrt(peak)
        hit = (z >= self.eta) & (rho >= self.min_rho)

        def first_arrival(j0: int, strongest: int) -> int:
            # earlier paths are sought in the strongest path's own bin: another bin peaks earlier on the
            # delay–Doppler ridge of a chirp, which must not pass for an earlier arrival
            b = int(best[strongest])
            own_hit = hit & (power[b] / noise >= self.eta)
            return first_distinct_peak(np.sqrt(power[b].astype(np.float64)), own_hit, j0, strongest,
                                       fraction=self.first_path_fraction, half_lobe=self.half_lobe,
                                       gap=self.half_lobe + 1)

        picks, resume = cluster_crossings(hit, amp, lo=lo, scan_from=scan_from, window=self.window,
                                          holdoff=self.holdoff, final=final, first_arrival=first_arrival)
        out = []
        for j, strongest in picks:
            b = int(best[strongest])
            out.append(ReferenceDetection((lo + j) / self.fs, float(self.eps[b]), float(power[b, j] / noise), float(rho[j])))
        return out, resume
