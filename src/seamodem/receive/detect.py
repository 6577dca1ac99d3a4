"""Frame detection: a bank of Doppler-shifted pilot matched filters on the data baseband.

Statistic and threshold
-----------------------
For each lag j and Doppler bin b, c_b[j] = Σ_i r[j + i] p_b*[i], with p_b the
pilot's baseband waveform shifted by the bin's carrier offset f_b (the Doppler
f0·v/c would otherwise turn the pilot's phase by several cycles at a few m/s).

* z = |c|² / σ_c², σ_c² = median(|c|²)/ln 2 over a few seconds of lags and
  all bins. In white Gaussian noise |c|²/σ_c² is Exp(1), so P(z > η) = e^{−η}
  per test. With n = (bins)·fs·3600 tests per hour (an over-count: neighbouring
  lags are correlated) the threshold η = ln(n / rate) gives at most ``rate``
  false alarms per hour. The median ignores the sparse pilot peaks and
  impulses.
* ρ = |c|² / (E_p · Σ_window |r|²) ∈ [0, 1] (Cauchy–Schwarz), the normalised
  correlation: it is near 1/Np for an impulse, however loud, ≈ S/(S+N) for a
  frame, and stays below ≈ 0.06 on random data symbols (the maximum over
  thousands of lags and all bins of a Beta(1, ~200) variable). Requiring
  ρ ≥ ρ_min = 0.1 rejects impulsive noise and a frame's own data, which pass
  z easily; it also limits detection to in-band SNR ≳ −7 dB.

First arrival
-------------
After the first lag that passes both tests, the strongest peak within
``multipath_window_s`` is found; the frame's arrival is the earliest local
maximum before it whose amplitude is at least ``first_path_fraction`` of the
strongest (a weaker direct path ahead of a stronger surface echo). The next
frame is sought only ``holdoff_s`` later, so each frame is found once.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.fft
from numba import njit

from ..config import FrameConfig
from ..transmit.pilot import pilot_symbols
from ..transmit.pulse import srrc_matrix

__all__ = [
    "Detection",
    "PilotDetector",
    "doppler_bin_spacing_hz",
    "pilot_template",
    "z_threshold",
    "DETECTION_CONTEXT_S",
    "cluster_crossings",
    "first_distinct_peak",
]

#: the detector's noise context: correlation lags before the scan position whose median sets the noise level [s]
DETECTION_CONTEXT_S = 0.5


@dataclass(frozen=True)
class Detection:
    """A coarse frame detection.

    Attributes
    ----------
    t_start_s : float
        Coarse reception time of the frame start [s] (± half a baseband sample).
    doppler_hz : float
        Doppler bin: carrier offset f0·v/c of the best replica [Hz].
    z : float
        Detection statistic |c|²/σ_c² (Exp(1) in noise).
    rho : float
        Normalised correlation in [0, 1].
    """

    t_start_s: float
    doppler_hz: float
    z: float
    rho: float


def pilot_template(config: FrameConfig, fs: float, pilot: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Baseband pilot Σ a_k √T g(τ − (Ng + k)T) sampled at τ = τ_a + i/fs.

    Returns
    -------
    template : numpy.ndarray, complex
    tau_a_s : float
        Time of the template's first sample after the frame start [s].
    """
    if pilot is None:
        pilot = pilot_symbols(config.n_pilot, config.pilot_seed)
    T = config.symbol_period_s
    half = config.srrc_span_symbols // 2
    tk = (config.n_guard + np.arange(config.n_pilot)) * T
    tau_a = tk[0] - half * T
    n = int(math.floor((tk[-1] + half * T - tau_a) * fs)) + 1
    tau = tau_a + np.arange(n) / fs
    g = srrc_matrix(tau, tk, symbol_period_s=T, rolloff=config.rolloff, span_symbols=config.srrc_span_symbols)
    return g @ np.asarray(pilot, dtype=complex), float(tau_a)


def doppler_bin_spacing_hz(config: FrameConfig) -> float:
    """Spacing of the Doppler bins, 1/(2 T_p) [Hz]: worst-case loss sinc²(1/4) = −0.9 dB."""
    return 1.0 / (2 * config.n_pilot * config.symbol_period_s)


def z_threshold(false_alarms_per_hour: float, n_bins: int, fs: float) -> float:
    """η with (tests per hour)·e^{−η} = false_alarms_per_hour."""
    return float(math.log(n_bins * fs * 3600.0 / false_alarms_per_hour))


@njit(cache=True, nogil=True)
def _bank_update(c, n_out, b, offset, sample, best, peak):
    """One bin's |c|² over the first ``n_out`` lags into the running best bin and peak, and its every 4th lag
    from ``offset`` on into ``sample``, in one pass (the numpy form's float32 operations, bit for bit)."""
    for j in range(n_out):
        power = c[j].real * c[j].real + c[j].imag * c[j].imag
        if j % 4 == offset and j >= offset:
            sample[(j - offset) // 4] = power
        if power > peak[j]:
            best[j] = b
            peak[j] = power


def cluster_crossings(hit: np.ndarray, amp: np.ndarray, *, lo: int, scan_from: int, window: int, holdoff: int,
                      final: bool, first_arrival: Callable[[int, int], int]) -> tuple[list[tuple[int, int]], int]:
    """Group a scan's threshold crossings into arrivals (one per transmission), from ``scan_from`` on.

    After the first crossing at or after the scan position, the strongest crossing within ``window``
    lags is found; ``first_arrival(j0, strongest)`` picks the arrival (the direct path may be weaker
    than an echo); the next arrival is sought ``holdoff`` lags after it. Shared by the frame detector
    (:class:`PilotDetector`) and the reference detector
    (:class:`~seamodem.receive.reference.ReferenceDetector`).

    Parameters
    ----------
    hit : numpy.ndarray, bool, shape (n_lags,)
        Lags that pass the detection tests; lag j is global index ``lo + j``.
    amp : numpy.ndarray, shape (n_lags,)
        Correlation amplitude at each lag (the strongest crossing is its maximum).
    lo, scan_from : int
        Global index of lag 0 and of the first lag to scan.
    window, holdoff : int
        Lags after the first crossing where a stronger path is sought; lags after an arrival skipped.
    final : bool
        No more lags will come: decide a window cut by the end.
    first_arrival : callable
        (first crossing, strongest crossing) → the arrival's lag.

    Returns
    -------
    picks : list of (int, int)
        Each arrival's lag and its cluster's strongest lag (indices into ``hit``).
    scan_from : int
        Global index where the next scan resumes.
    """
    n_lags = len(hit)
    picks = []
    pos = max(scan_from - lo, 0)
    while True:
        hits = np.flatnonzero(hit[pos:])
        if hits.size == 0:
            return picks, lo + n_lags if n_lags > pos else scan_from
        j0 = pos + int(hits[0])
        end = j0 + window
        if end >= n_lags and not final:
            return picks, lo + j0
        end = min(end, n_lags - 1)
        strongest = j0 + int(np.argmax(np.where(hit[j0 : end + 1], amp[j0 : end + 1], 0.0)))
        j = first_arrival(j0, strongest)
        picks.append((j, strongest))
        pos = j + holdoff
        if pos >= n_lags:
            return picks, lo + pos


def first_distinct_peak(amp: np.ndarray, hit: np.ndarray, j0: int, strongest: int, *, fraction: float,
                        half_lobe: int, gap: int) -> int:
    """Earliest distinct peak in [j0, strongest − gap] strong enough to be the direct path, else ``strongest``.

    A distinct peak is a crossing that is the maximum of ``amp`` over ±``half_lobe`` lags, with an
    amplitude of at least ``fraction`` of the strongest; paths closer than ``gap`` lags to the
    strongest are not resolved (noise on the main lobe's flank must not pass for an earlier path).
    Shared by the frame detector (:class:`PilotDetector`) and the reference detector
    (:class:`~seamodem.receive.reference.ReferenceDetector`).

    Parameters
    ----------
    amp : numpy.ndarray, shape (n_lags,)
        Correlation amplitude at each lag.
    hit : numpy.ndarray, bool, shape (n_lags,)
        Lags that pass the detection tests.
    j0, strongest : int
        First crossing and strongest crossing of the cluster [lags, indices into ``amp``].
    fraction : float
        Smallest amplitude of the direct path, as a fraction of the strongest's.
    half_lobe : int
        Half-width of the main lobe [lags]: a peak is the maximum over ±``half_lobe``.
    gap : int
        Paths closer than this to the strongest are not resolved [lags].

    Returns
    -------
    int
        The arrival's lag (``strongest`` when no earlier distinct peak qualifies).
    """
    floor = fraction * amp[strongest]
    w = half_lobe
    for j in range(j0, strongest - gap + 1):
        if hit[j] and amp[j] >= floor and amp[j] >= np.max(amp[max(0, j - w) : j + w + 1]):
            return j
    return strongest


class PilotDetector:
    """Find frame starts in a stream of data-band baseband samples.

    Parameters
    ----------
    config : FrameConfig
    fs : float
        Baseband sample rate [Hz].
    v_max_mps : float
        Doppler bins cover ±v_max [m/s].
    sound_speed_mps : float
    false_alarms_per_hour : float
        Design false-alarm rate in white Gaussian noise; sets η.
    min_rho : float
        Smallest normalised correlation of a frame.
    first_path_fraction : float
        A peak before the strongest one counts as the first arrival when its
        amplitude is at least this fraction of the strongest.
    multipath_window_s : float
        How far after the first crossing later, stronger paths are sought [s].
    pilot : numpy.ndarray, optional
        Pilot symbols (default from the config's seed).
    """

    def __init__(
        self,
        config: FrameConfig,
        fs: float,
        *,
        v_max_mps: float,
        sound_speed_mps: float,
        false_alarms_per_hour: float = 0.01,
        min_rho: float = 0.1,
        first_path_fraction: float = 0.3,
        multipath_window_s: float = 0.03,
        pilot: np.ndarray | None = None,
    ):
        self.config = config
        self.fs = float(fs)
        template, self.tau_a_s = pilot_template(config, fs, pilot)
        spacing = doppler_bin_spacing_hz(config)
        f_max = config.carrier_hz * v_max_mps / sound_speed_mps
        n_side = int(math.ceil(f_max / spacing))
        self.doppler_hz = spacing * np.arange(-n_side, n_side + 1)
        self.template = template
        self.template_energy = float(np.sum(np.abs(template) ** 2))
        self.length = len(template)
        self.eta = z_threshold(false_alarms_per_hour, len(self.doppler_hz), fs)
        self.min_rho = float(min_rho)
        self.first_path_fraction = float(first_path_fraction)
        self.window = max(1, int(round(multipath_window_s * fs)))
        self.half_lobe = max(1, int(math.ceil(0.5 * config.symbol_period_s * fs)))
        # frames do not overlap (BeaconSchedule.check): after a frame, skip its length,
        # less what the largest Doppler compression (twice, for margin) could take off
        self.holdoff = int(config.frame_duration_s * (1 - 2 * v_max_mps / sound_speed_mps) * fs)
        #: lags of context before the scan position for the noise median
        self.context = int(DETECTION_CONTEXT_S * fs)
        self._pilot_spectra: dict[int, np.ndarray] = {}
        # sampled |c|² of the lags correlated by earlier calls (the noise median's context), and their lags
        self._context_power = np.zeros((len(self.doppler_hz), 0), np.float32)
        self._context_lags = np.zeros(0, np.int64)

    def _pilot_spectrum(self, n: int) -> np.ndarray:
        """conj(FFT_n(template)) in single precision, kept for the last few sizes (blocks of a stream repeat them)."""
        cache = self._pilot_spectra
        if n not in cache:
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            cache[n] = np.conj(scipy.fft.fft(self.template.astype(np.complex64), n))
        return cache[n]

    def _bank_power(self, r: np.ndarray, offset: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """|c_b[j]|² at every 4th lag (j ≡ ``offset`` mod 4) of every bin b; each full-overlap lag's best bin
        and its power.

        One FFT of r and one inverse per bin.
        The replica of bin b is p[i]·e^{j2π m_b i/N}, whose transform is P rolled by
        m_b bins: the bins are snapped to multiples of fs/N (≤ fs/(2N) ≈ 0.05 Hz off).
        """
        n_out = len(r) - self.length + 1
        n = scipy.fft.next_fast_len(len(r))
        # single precision: a detection statistic needs no more, and the FFTs run twice as fast
        spectrum = scipy.fft.fft(r.astype(np.complex64), n)
        pilot = self._pilot_spectrum(n)
        shifts = np.round(self.doppler_hz * n / self.fs).astype(np.int64)
        # every 4th lag, for the median
        sample = np.empty((len(shifts), max(0, -(-(n_out - offset) // 4))), dtype=np.float32)
        best = np.zeros(n_out, dtype=np.int64)
        peak = np.zeros(n_out, dtype=np.float32)
        product = np.empty(n, dtype=np.complex64)
        for b, m in enumerate(shifts):
            m = int(m) % n  # product = spectrum · roll(pilot, m), without the roll's copy
            np.multiply(spectrum[m:], pilot[: n - m], out=product[m:])
            np.multiply(spectrum[:m], pilot[n - m :], out=product[:m])
            c = scipy.fft.ifft(product, overwrite_x=True)
            _bank_update(c, n_out, b, offset, sample[b], best, peak)
        return sample, best, peak.astype(np.float64)

    def statistics(self, r: np.ndarray, *, first_lag: int | None = None,
                   context_from: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """z, ρ, best bin and |c| for every full-overlap lag of ``r``.

        Returns arrays of length len(r) − L + 1 (L the template length), lag j
        meaning the template starts at r[j].

        With ``first_lag`` (the global index of r[0]), the noise median also
        takes in the lags sampled by earlier calls from ``context_from`` on,
        kept rather than computed again (the stream's context of
        ``DETECTION_CONTEXT_S`` before the scan position, which the previous
        call already correlated), and this call's sampled lags are kept for
        the next; lags are sampled at global multiples of 4 either way.
        """
        offset = 0 if first_lag is None else (-first_lag) % 4
        sample, best, peak = self._bank_power(r, offset)
        if first_lag is not None:
            keep = (self._context_lags >= context_from) & (self._context_lags < first_lag)
            sample = np.concatenate([self._context_power[:, keep], sample], axis=1)
            self._context_lags = np.concatenate(
                [self._context_lags[keep], first_lag + offset + 4 * np.arange(sample.shape[1] - np.count_nonzero(keep))])
            self._context_power = sample
        # the floor (60 dB under the block's peak) keeps z finite in a noiseless recording
        noise = max(np.median(sample) / math.log(2), 1e-6 * float(np.max(peak)))
        energy = np.cumsum(np.concatenate([[0.0], np.abs(r) ** 2]))
        window = energy[self.length :] - energy[: -self.length]
        rho = peak / (self.template_energy * np.maximum(window, np.finfo(float).tiny))
        return peak / max(noise, np.finfo(float).tiny), rho, best, np.sqrt(peak)

    def find(self, r: np.ndarray, r_start: int, scan_from: int, *, final: bool) -> tuple[list[Detection], int]:
        """Detections whose lag is ≥ ``scan_from`` in the buffer ``r``.

        Parameters
        ----------
        r : numpy.ndarray, complex
            Baseband buffer; r[0] is global sample ``r_start``.
        r_start, scan_from : int
            Global sample indices.
        final : bool
            No more samples will come: decide clusters cut by the buffer's end.

        Returns
        -------
        detections : list of Detection
        scan_from : int
            Where the next call should resume.
        """
        lo = max(r_start, scan_from - self.context)
        if "statistics" in self.__dict__:  # replaced (ArrayDetector): it is given the context's lags, as before
            seg = r[lo - r_start :]
            if len(seg) < self.length:
                return [], scan_from
            z, rho, best, amp = self.statistics(seg)
        else:
            # the lags before the scan position serve the noise median only, and the previous call
            # correlated them: from half a lobe before it on (a peak's neighbours, for the first arrival)
            first = max(lo, scan_from - self.half_lobe)
            seg = r[first - r_start :]
            if len(seg) - self.length < scan_from - first:  # no lag at or after the scan position yet
                return [], scan_from
            z, rho, best, amp = self.statistics(seg, first_lag=first, context_from=lo)
            lo = first
        hit = (z >= self.eta) & (rho >= self.min_rho)

        def first_arrival(j0: int, strongest: int) -> int:
            return first_distinct_peak(amp, hit, j0, strongest, fraction=self.first_path_fraction,
                                       half_lobe=self.half_lobe, gap=2 * self.half_lobe)

        picks, resume = cluster_crossings(hit, amp, lo=lo, scan_from=scan_from, window=self.window,
                                          holdoff=self.holdoff, final=final, first_arrival=first_arrival)
        return [Detection(t_start_s=(lo + j) / self.fs - self.tau_a_s, doppler_hz=float(self.doppler_hz[best[j]]),
                          z=float(z[j]), rho=float(rho[j])) for j, _ in picks], resume
