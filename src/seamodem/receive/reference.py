"""Ranging on any known waveform: LFM/HFM chirps, m-sequence pings, templates (issue 16).

The same steps as the frame receiver, with the frame's pilot replaced by a
:class:`~seamodem.transmit.reference.ReferenceWaveform`:

1. **Front end** (:class:`BandDecimator`): the frame receiver's
   frequency-domain front end (:mod:`.frontend`: one real FFT per block, the
   band's bins filtered and inverse-transformed at the decimated size) on the
   union of the references' bands: decimation costs the same at 384 kHz as
   at 96 kHz per input sample, memory stays a few blocks. DC and anything
   outside the band are removed here.
2. **Detection** (:class:`ReferenceDetector`): a bank of time-scaled replicas
   s_a((1 + ε_b) t) over |ε| ≤ v_max/c (wideband Doppler is a scale, not a
   frequency shift), spaced so that the loss between bins is at most 1 dB,
   correlated by FFT. As :mod:`.detect`: z = |c|²/σ_c² (Exp(1) in noise,
   σ_c² from the median), threshold η = ln(n_tests/rate) for a stated
   false-alarm rate per hour (:func:`~seamodem.receive.detect.z_threshold`),
   and ρ ≥ ρ_min (normalised correlation) against impulses; the first arrival
   is the earliest distinct peak within ``multipath_window_s`` that reaches
   ``first_path_fraction`` of the strongest.
3. **Fine fit** (:func:`fit_reference`): maximum likelihood of (t_a, ε) for
   r(t) = A e^{jθ} s_a((1 + ε)(t − t_a)) + w, |C(t_a, ε)| = |Σ r q*| with
   the replica evaluated at arbitrary times: ε by dichotomy
   (:func:`~seamodem.receive.doppler.dichotomy_max`, paper 002's bank +
   dichotomy), t_a by Gauss–Newton along the delay–Doppler ridge for each ε.
   Echoes: the replica's distinct correlation peaks, fitted jointly, the first
   arrival the earliest of 0.3× the strongest (a merged earlier path by a GLRT).
   A chirp (a ridge longer than its main lobe) takes ε from the joint
   multi-path likelihood over all of ±v_max/c (:meth:`_PathFitter.scan_paths`).
4. **σ's**: the joint CRLB of the reference (:func:`~seamodem.transmit.reference.reference_crlb`)
   at the measured E/N0, inflated by √χ² of the fit's residual when echoes or
   a varying Doppler leave more than noise.
5. **Pairs** (:func:`pair_up`, :func:`pair_doppler`): a preamble and a postamble
   of known spacing T_sp give ε = T_sp/Δ − 1 from their measured spacing Δ, using
   each ping's ridge coordinate so that the delay–Doppler coupling cancels, and
   allowing for a Doppler change over the packet.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ..dsp import lowpass_taps
from ..errors import ConfigError
from ..transmit.reference import ReferenceBound, ReferenceWaveform, Replica, reference_crlb
from .detect import cluster_crossings, first_distinct_peak, z_threshold
from .doppler import dichotomy_max
from .frontend import FrontEnd, FrontEndPlan, Branch
from .records import MeasurementRecord

__all__ = [
    "BandPlan",
    "plan_band",
    "BandDecimator",
    "ReferenceDetector",
    "ReferenceDetection",
    "ReferenceFit",
    "fit_reference",
    "ReferenceRecord",
    "REFERENCE_FIELDS",
    "pair_doppler",
    "ReferenceReceiver",
    "best_per_detection",
    "keep_matching_reference",
    "pair_up",
    "to_record",
]

#: a Doppler CRLB above this fraction of v_max/c means the ping cannot measure its Doppler (σ_ε is then v_max/c)
DOPPLER_THRESHOLD = 0.1
#: a fit whose residual exceeds this many times the noise has its Doppler (and place on the ridge) untrusted
MISFIT_LIMIT = 4.0
#: smallest normalised correlation of a detection: ≈ S/(S + N) in the baseband's band, so detection reaches
#: in-band SNRs near −10 dB, while an impulse of k samples in a ping of N gives ρ ≈ k/N (≈ 0.02 for a 1 ms
#: snap in a 50 ms ping); unlike the frame detector, a ping has no data of its own to reject
MIN_RHO = 0.05
#: noise level window before the arrival, after a gap [s]
_NOISE_GAP_S, _NOISE_WINDOW_S = 0.005, 0.05


@dataclass(frozen=True)
class BandPlan:
    """Mixing frequency, filter and rates of the front end.

    Attributes
    ----------
    centre_hz : float
        Mixing frequency [Hz].
    passband_hz : float
        Half-width kept around the centre [Hz].
    front_end : FrontEndPlan
        The frame receiver's frequency-domain front end (:mod:`.frontend`) set
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
        return self._fe.push(x_pb)[0]

    def flush(self) -> np.ndarray:
        return self._fe.flush()[0]


@dataclass(frozen=True)
class ReferenceDetection:
    """A coarse detection: lag, scale bin and statistics.

    Attributes
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


def _replica_samples(replica: Replica, fs_bb: float, carrier_hz: float, eps: float) -> np.ndarray:
    n = int(math.ceil(replica.duration_s / (1 + eps) * fs_bb)) + 1
    return replica.scaled(np.arange(n) / fs_bb, t_arrival_s=0.0, eps=eps, carrier_hz=carrier_hz)


def _scale_spacing(replica: Replica, fs_bb: float, carrier_hz: float, eps_max: float) -> float:
    """Largest scale step with ≤ 1 dB correlation loss (max over lags) between neighbouring bins, measured."""
    q0 = _replica_samples(replica, fs_bb, carrier_hz, 0.0)
    e0 = np.sum(np.abs(q0) ** 2)
    n = scipy.fft.next_fast_len(2 * len(q0) + 8)
    f0 = np.conj(scipy.fft.fft(q0, n))

    def loss(step):
        q = _replica_samples(replica, fs_bb, carrier_hz, step / 2)
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
    plan : BandPlan
    v_max_mps, sound_speed_mps : float
    false_alarms_per_hour : float
        Design rate in white Gaussian noise.
    min_rho : float
    first_path_fraction, multipath_window_s : float
        First-arrival rule (as :class:`~seamodem.receive.detect.PilotDetector`).
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
        self.replicas = [_replica_samples(replica, self.fs, self.carrier_hz, e) for e in self.eps]
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
        """Detections at lags ≥ ``scan_from`` (global baseband indices; r[0] is index ``r_start``)."""
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


@dataclass(frozen=True)
class ReferenceFit:
    """Fine arrival time, Doppler scale and their bounds for one detection.

    Attributes
    ----------
    t_arrival_s : float
        Reception time of the reference's first sample, first path [s].
    eps : float
        Doppler scale ε = v_r/c.
    gain : complex
        Complex amplitude A (baseband units).
    e_n0 : float
        Measured E/N0 (linear).
    snr_db : float
        In-band SNR over [f_low, f_high] during the reference [dB].
    sigma_t_s, sigma_eps : float
        CRLB at the measured E/N0 × the misfit inflation √χ² × the fitted echoes' inflation (the
        multi-path Fisher matrix over the direct path's alone); σ_ε is v_max/c when that exceeds
        :data:`DOPPLER_THRESHOLD`·v_max/c; σ_t = √(σ_ridge² + g²σ_ε²) (the joint CRLB when σ_ε is).
    ridge_t_s, sigma_ridge_s : float
        The delay–Doppler ridge coordinate t_a + g·ε (g the reference's ridge slope) and its σ (the known-ε bound):
        what two pings' spacing is measured with.
    misfit : float
        χ² of the residual per sample over the noise level (≈ 1: noise only).
    ridge_slope_s : float
        g of the reference (:class:`~seamodem.transmit.reference.ReferenceBound`).
    n_paths : int
        Paths fitted: the direct one and the echoes found beside it.
    """

    t_arrival_s: float
    eps: float
    gain: complex
    e_n0: float
    snr_db: float
    sigma_t_s: float
    sigma_eps: float
    ridge_t_s: float
    sigma_ridge_s: float
    misfit: float
    ridge_slope_s: float = 0.0
    n_paths: int = 1


#: echoes are sought this long after the direct path's end [s]
ECHO_WINDOW_S = 0.03
#: an earlier path is sought this long before the detected one [s] (within the detector's resolution)
EARLY_WINDOW_S = 0.001
#: an earlier path counts as the first arrival from this fraction of the detected path's amplitude
FIRST_PATH_FRACTION = 0.3
#: most echoes fitted beside the direct path
MAX_ECHOES = 2
#: an echo is fitted when its residual correlation exceeds this many times the noise (|c|²/(σ² E_q))
ECHO_Z = 30.0
#: scales across ±v_max/c at which a chirp's paths are sought before its Doppler is refined
SCAN_POINTS = 5
#: Gauss–Newton steps of the scan's joint multi-path fit at each scale: without one, a direct path and an
#: equal, inverted surface echo 1.5 main lobes behind (merged into one peak) are fitted badly at the true scale
#: and a wrong scale can win (an LFM 19–29 kHz at 1.5 dB, 298 s into bench_reference's pairs: 7.1 m/s, 734 µs
#: off; with the step 0.10 m/s, 11 µs); costs 5–8 % of the receiver's CPU
SCAN_STEPS = 1
#: the same for a path before the fitted one (a handful of lags are searched there: a lower threshold)
EARLY_Z = 12.0


def _real_normal_equations(m: np.ndarray, resid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Re(M Mᴴ) and Re(M* r): the normal equations of real parameters of a complex model, M (k, n).

    As real products of [Re M, Im M] (k, 2n): a complex matrix product of these shapes goes to a threaded
    BLAS kernel that takes milliseconds on a loaded machine, a hundred times the real one.
    """
    mm = np.concatenate([m.real, m.imag], axis=1)
    return mm @ mm.T, mm @ np.concatenate([resid.real, resid.imag])


def _peak_sidelobe(replica: Replica, fs: float, carrier_hz: float) -> float:
    """Largest |autocorrelation|² of the sampled replica beyond ±1/B, over its peak (once per replica, in its memo)."""
    key = ("sidelobe", fs, carrier_hz)
    if key not in replica.memo:
        p = _replica_samples(replica, fs, carrier_hz, 0.0)
        n = scipy.fft.next_fast_len(2 * len(p))
        a = np.abs(scipy.fft.ifft(np.abs(scipy.fft.fft(p, n)) ** 2)) ** 2
        lag = np.minimum(np.arange(n), n - np.arange(n)) / fs
        replica.memo[key] = float(np.max(a[lag > 1.0 / replica.reference.bandwidth_hz]) / a[0])
    return replica.memo[key]


class _PathFitter:
    """Maximum-likelihood (t_a, ε) of one path of a reference in a baseband segment (x[n] at t[n])."""

    def __init__(self, replica: Replica, t: np.ndarray, carrier_hz: float, fs: float, ridge_slope_s: float, limit: float):
        self.replica, self.t, self.carrier_hz, self.fs = replica, t, carrier_hz, fs
        self.g, self.limit = ridge_slope_s, limit
        self._x_spectrum: tuple | None = None  # (segment, its FFT) of the last peaks() call

    def _support(self, ta, eps) -> slice:
        """Samples where the replica starting at t_a is non-zero (the rest adds nothing to any sum)."""
        lo = int(math.floor((ta - self.t[0]) * self.fs)) - 1
        hi = int(math.ceil((ta + self.replica.duration_s / (1 + eps) - self.t[0]) * self.fs)) + 2
        return slice(max(lo, 0), max(min(hi, len(self.t)), 0))

    def corr(self, x, ta, eps) -> float:
        """|⟨q, x⟩|/‖q‖: the likelihood with A unknown (‖q‖ varies as 1/√(1 + ε); left out, it biases ε along the ridge)."""
        k = self._support(ta, eps)
        q = self.replica.scaled(self.t[k], t_arrival_s=ta, eps=eps, carrier_hz=self.carrier_hz)
        return abs(np.vdot(q, x[k])) / math.sqrt(max(np.real(np.vdot(q, q)), np.finfo(float).tiny))

    def gauss_newton(self, x, ta, eps, *, free_eps: bool):
        """One Gauss–Newton step of the fit x ≈ A q(t_a, ε) (A complex, t_a and ε real)."""
        k = self._support(ta, eps)
        t, fs, x = self.t[k], self.fs, x[k]
        q, dq = self.replica.scaled_with_derivative(t, t_arrival_s=ta, eps=eps, carrier_hz=self.carrier_hz)
        a = np.vdot(q, x) / max(np.real(np.vdot(q, q)), np.finfo(float).tiny)
        cols = [-(1 + eps) * a * dq] + ([(t - ta) * a * dq] if free_eps else []) + [q, 1j * q]
        m = np.stack(cols)
        resid = x - a * q
        # real least squares on (Re, Im) by its normal equations: Re(M Mᴴ) step = Re(M residual*)
        step = np.linalg.solve(*_real_normal_equations(m, resid))
        # never jump beyond the main lobe, where the linearisation holds; shrink (t_a, ε) together so that a
        # joint step stays on the delay–Doppler ridge
        shrink = min(1.0, 0.5 / fs / max(abs(step[0]), 1e-300))
        return ta + shrink * step[0], eps + (shrink * step[1] if free_eps else 0.0)

    def fit(self, x, ta0: float, eps0: float, search_eps: float, *, grid: bool, scan: bool = False) -> tuple[float, float]:
        """ε by dichotomy on the profile likelihood (t_a by Gauss–Newton for each ε), then a joint polish.

        ``search_eps`` 0: the joint polish alone (a start already near the optimum: echoes, refits).
        ``scan``: first the profile on a grid of half the bank's spacing over all of ±limit, and the dichotomy
        around its best point. A chirp's ridge is nearly flat across the bank (an LFM loses a fraction of a dB
        between its bins): the detection's bin, picked by the noise and by an echo's ridge beside the direct
        path's, can be several bins from the truth, and a dichotomy of ±1 bin around it clips the estimate.
        """
        fs, g, limit = self.fs, self.g, self.limit
        if grid:  # a coarse lag is within half a sample: start from the best of a fine grid around it
            cand = ta0 + np.linspace(-1.0, 1.0, 9) / fs
            ta0 = float(cand[int(np.argmax([self.corr(x, tg, eps0) for tg in cand]))])

        def best_t(eps):
            ta = ta0 - g * (eps - eps0)  # along the delay–Doppler ridge
            for _ in range(2):
                ta, _ = self.gauss_newton(x, ta, eps, free_eps=False)
            return ta

        # profile likelihood over ε, by dichotomy (paper 002's bank, refined); t_a maximised for each ε
        eps = eps0
        if search_eps and scan:
            half = 0.5 * search_eps
            cand = np.arange(-limit, limit + 0.5 * half, half) if 2 * limit > half else np.array([eps0])
            eps = float(cand[int(np.argmax([self.corr(x, best_t(e), e) for e in cand]))])
            eps = dichotomy_max(
                lambda e: self.corr(x, best_t(e), e), max(eps - half, -limit), min(eps + half, limit), tol=search_eps / 8,
            )
        elif search_eps:
            eps = dichotomy_max(
                lambda e: self.corr(x, best_t(e), e),
                max(eps0 - search_eps, -limit), min(eps0 + search_eps, limit), tol=search_eps / 8,
            )
        ta = best_t(eps)
        # joint Gauss–Newton polish of what the dichotomy's tolerance left (kept only while it improves the fit)
        best = self.corr(x, ta, eps)
        for _ in range(8):
            ta1, eps1 = self.gauss_newton(x, ta, eps, free_eps=True)
            for shrink in (1.0, 0.5, 0.25, 0.125):  # backtracking: the ridge makes full steps overshoot at times
                ta2, eps2 = ta + shrink * (ta1 - ta), float(np.clip(eps + shrink * (eps1 - eps), -limit, limit))
                c2 = self.corr(x, ta2, eps2)
                if c2 > best:
                    break
            if c2 <= best:
                break
            moved = abs(ta2 - ta) * fs
            ta, eps, best = ta2, eps2, c2
            if moved < 1e-3:  # a thousandth of a sample (≈ 0.1 µs, a tenth of the best CRLB here): converged
                break
        return float(ta), float(eps)

    def paths_at(self, x, times: np.ndarray, eps: float, *, steps: int = 2) -> tuple[np.ndarray, np.ndarray, float]:
        """Several paths at one common scale ε: their arrivals by joint Gauss–Newton, gains, and the energy explained.

        x ≈ Σ_p A_p q(t_p, ε): the gains by least squares, the arrivals by Gauss–Newton steps on the joint
        model (an echo's sidelobe is then part of the model, not a pull on the direct path); the energy
        explained ‖P_Q x‖² = Re(bᴴ A), b = Qᴴx, is the likelihood of ε with every other parameter maximised.
        Sums run over the paths' joint support only.
        """
        times = np.array(times, dtype=float)
        n_p = len(times)
        for it in range(steps + 1):
            k = slice(self._support(float(np.min(times)), eps).start, self._support(float(np.max(times)), eps).stop)
            t, xk = self.t[k], x[k]
            if it == steps:
                q = [self.replica.scaled(t, t_arrival_s=tp, eps=eps, carrier_hz=self.carrier_hz) for tp in times]
            else:
                q, dq = zip(*[self.replica.scaled_with_derivative(t, t_arrival_s=tp, eps=eps, carrier_hz=self.carrier_hz)
                              for tp in times])
            b = np.array([np.vdot(qp, xk) for qp in q])
            try:
                a = np.linalg.solve(np.array([[np.vdot(qi, qj) for qj in q] for qi in q]), b)
            except np.linalg.LinAlgError:
                return times, np.zeros(n_p, complex), 0.0
            if it == steps:
                break
            resid = xk - sum(a[p] * q[p] for p in range(n_p))
            m = np.stack([-(1 + eps) * a[p] * dq[p] for p in range(n_p)] + list(q) + [1j * qp for qp in q])
            try:
                step = np.linalg.solve(*_real_normal_equations(m, resid))[:n_p]
            except np.linalg.LinAlgError:
                break
            times = times + min(1.0, 0.5 / self.fs / max(float(np.max(np.abs(step))), 1e-300)) * step
        return times, a, float(np.real(np.vdot(a, b)))

    def peaks(self, x, ta: float, eps: float, noise: float, *, split: bool = False) -> np.ndarray:
        """Arrivals of the replica's distinct correlation peaks at ε within (ta − EARLY_WINDOW_S, ta + ECHO_WINDOW_S).

        The strongest always, others when significant (|c|²/(σ² E_q) ≥ ECHO_Z after the strongest, ≥ EARLY_Z
        before it) and above the strongest's sidelobes; at most 1 + MAX_ECHOES.

        ``split``: when the strongest peak's half-power hump spans ≥ 4 samples (a single path's spans 1–2) with
        no other peak in it, a second start at its far end. Two paths 1–2 main lobes apart whose baseband phases
        nearly agree (an inverted surface echo 150 µs behind at 24 kHz is 36° from the direct path) make one
        broad hump; started from one point, the joint fit at the true scale misses the echo and explains less
        than a wrong scale does (an LFM at 3 dB, one ping in 24 taken 650 µs along its ridge).
        """
        # the scan asks for the same few scales (its grid) on the same segment: both spectra are kept
        n = scipy.fft.next_fast_len(len(x) + int(math.ceil(self.replica.duration_s * self.fs / (1 - self.limit))) + 2)
        memo, key = self.replica.memo, ("spectrum", self.fs, self.carrier_hz, float(eps), n)
        if key not in memo:
            if len(memo) > 256:  # FFT sizes follow the segment's length: keep the memo bounded
                memo.clear()
            p = _replica_samples(self.replica, self.fs, self.carrier_hz, eps)
            memo[key] = (np.conj(scipy.fft.fft(p, n)), float(np.sum(np.abs(p) ** 2)))
        spectrum, energy = memo[key]
        if self._x_spectrum is None or self._x_spectrum[0] is not x or len(self._x_spectrum[1]) != n:
            self._x_spectrum = (x, scipy.fft.fft(x, n))
        z = np.abs(scipy.fft.ifft(self._x_spectrum[1] * spectrum)[: len(x)]) ** 2
        z /= noise * energy
        lags = self.t[0] + np.arange(len(x)) / self.fs
        z = np.where((lags >= ta - EARLY_WINDOW_S) & (lags <= ta + ECHO_WINDOW_S), z, 0.0)
        # distinct: local maxima a main lobe (1/B) apart at least
        w = max(1, int(math.ceil(self.fs / self.replica.reference.bandwidth_hz)))
        # and above the strongest path's own sidelobes (twice the replica's peak sidelobe: a scale off the
        # truth raises them), which would otherwise pass for echoes at high SNR
        floor = max(ECHO_Z, 2 * _peak_sidelobe(self.replica, self.fs, self.carrier_hz) * float(np.max(z)))
        # a path before the strongest is the first arrival: sought at its own, lower threshold (few lags)
        early_floor = max(EARLY_Z, floor - ECHO_Z + EARLY_Z)
        chosen: list[int] = []
        for k in np.argsort(-z):
            if len(chosen) == 1 + MAX_ECHOES or (chosen and z[k] < early_floor) or z[k] == 0.0:
                break
            if chosen and k > chosen[0] and z[k] < floor:
                continue
            if all(abs(int(k) - j) >= w for j in chosen) and z[k] >= np.max(z[max(0, k - 1) : k + 2]):
                chosen.append(int(k))
        # on the sample grid: the joint Gauss–Newton steps of :meth:`paths_at` refine them (a parabolic vertex
        # through |c| is biased for paths merged into one peak: PN7 at 20 dB through bench_reference's channel,
        # a surface echo 1.35 chips behind, 3.53 µs RMS with it against 2.52 µs without)
        if split and chosen:  # beyond MAX_ECHOES if need be: a weak early peak must not take its place
            k0 = chosen[0]
            half = 0.5 * z[k0]
            left = right = 0
            while k0 - left - 1 >= 0 and z[k0 - left - 1] >= half:
                left += 1
            while k0 + right + 1 < len(z) and z[k0 + right + 1] >= half:
                right += 1
            if left + right + 1 >= 4 and not any(k0 - left <= j <= k0 + right for j in chosen[1:]):
                chosen.append(k0 + right if right >= left else k0 - left)
        return lags[chosen].astype(float)

    def early_path(self, x, times: np.ndarray, eps: float, noise: float):
        """A path just before the earliest of ``times``, closer than the peaks can separate (within 3/B), by a GLRT.

        For τ on a half-sample grid over [t_1 − 3/B, t_1 − 0.5/B] (t_1 the earliest of ``times``), the joint
        fit of τ and every path of ``times`` at ε (:meth:`paths_at`); the best is kept when it explains EARLY_Z
        noise variances more than the paths alone (the χ² of a complex amplitude: Exp(1) in noise, as the
        detector's z). Two paths of opposite sign a chip apart (a surface echo behind an m-sequence) merge
        into one peak between them. The later paths are in both models: left out, a path τ before the direct
        one absorbs the leak of an echo 1–2 main lobes behind it and passes the test at high SNR (PN7 at
        20 dB through bench_reference's channel: 16 µs errors against a CRLB of 1 µs).

        Returns
        -------
        (times, gains) of τ and the paths, or None.
        """
        lobe = 1.0 / self.replica.reference.bandwidth_hz
        times = np.sort(np.asarray(times, dtype=float))
        ta = float(times[0])
        alone = self.paths_at(x, times, eps)[2]
        best = None
        for tau in np.arange(ta - 0.5 * lobe, ta - 3 * lobe, -0.5 / self.fs):
            t_new, a, e = self.paths_at(x, np.concatenate([[tau], times]), eps)
            if t_new[0] < t_new[1] - 0.5 * lobe and (best is None or e > best[2]):
                best = (t_new, a, e)
        return best[:2] if best is not None and (best[2] - alone) / noise >= EARLY_Z else None

    def scan_paths(self, x, ta0: float, eps0: float, noise: float) -> tuple[np.ndarray, np.ndarray, float]:
        """ε of the joint multi-path likelihood over all of ±limit; every path's arrival and gain.

        At SCAN_POINTS scales across ±limit the significant correlation peaks near the ridge's prediction
        ta0 − g·(ε − ε0) (:meth:`peaks`) are fitted jointly (:meth:`paths_at`), each path beyond the first
        paying its threshold ECHO_Z; around the best scale, the paths slide along their delay–Doppler ridges
        and the profile's vertex is interpolated.
        On a chirp the single-path profile is nearly flat along the ridge (the detection's bin, picked by the
        noise, can be several bins from the truth), and an echo a few main lobes behind ripples it by its
        sidelobe (≈ ±10 % for a surface echo 0.23 ms behind an LFM 19–29 kHz, enough to move its maximum by
        metres per second): the joint model removes the ripple and leaves the ridge's own curvature.
        """
        best = (-math.inf, eps0, ta0)
        grid = np.linspace(-self.limit, self.limit, SCAN_POINTS)
        for e in grid:
            times = self.peaks(x, ta0 - self.g * (e - eps0), e, noise, split=True)
            times, _, energy = self.paths_at(x, times, e, steps=SCAN_STEPS)
            # each path beyond the first pays its detection threshold: otherwise the scales where a
            # mismatched replica's sidelobes pass for echoes would win by fitting them
            score = energy - ECHO_Z * noise * (len(times) - 1)
            if score > best[0]:
                best = (score, e, float(times[0]))
        # every significant path at the best scale, found again from the strongest one there
        _, e_ref, t_strong = best
        t_ref = self.peaks(x, min(t_strong, ta0 - self.g * (e_ref - eps0)), e_ref, noise, split=True)  # from the detector's first path

        def explained(e):
            return self.paths_at(x, t_ref - self.g * (e - e_ref), e)[2]

        # the profile's vertex from three points half a step apart (a parabola; the Gauss–Newton polish of
        # every path that follows finishes), kept if it beats them
        h = 0.5 * (grid[1] - grid[0])
        pts = [e_ref - h, e_ref, e_ref + h]
        vals = [explained(e) for e in pts]
        curv = vals[0] - 2 * vals[1] + vals[2]
        if curv < 0:
            e = float(np.clip(e_ref + 0.5 * h * (vals[0] - vals[2]) / curv, e_ref - 2 * h, e_ref + 2 * h))
            pts.append(e)
            vals.append(explained(e))
        e = float(np.clip(pts[int(np.argmax(vals))], -self.limit, self.limit))
        times, amps, _ = self.paths_at(x, t_ref - self.g * (e - e_ref), e)
        return times, amps, e

    def echo_inflation(self, ta: float, eps: float, gain: complex, echoes: list) -> tuple[float, float]:
        """How much the fitted echoes widen the direct path's bounds: (σ_ε, σ_ridge) with them over without.

        The Fisher matrix of every path's (t_a, ε, Re A, Im A), J ∝ Re(DᴴD) in white baseband noise,
        inverted whole and for the direct path alone: an echo closer than the main lobe makes the direct
        path's arrival uncertain however high the SNR, which a single-path CRLB does not say.
        """
        cols = []
        for t_p, e_p, a_p in [(ta, eps, gain), *echoes]:
            q, dq = self.replica.scaled_with_derivative(self.t, t_arrival_s=t_p, eps=e_p, carrier_hz=self.carrier_hz)
            cols += [-(1 + e_p) * a_p * dq, (self.t - t_p) * a_p * dq, q, 1j * q]
        d = np.stack(cols)
        fisher = _real_normal_equations(d, np.zeros(d.shape[1], complex))[0]
        try:
            cov = np.linalg.inv(fisher)
            alone = np.linalg.inv(fisher[:4, :4])
        except np.linalg.LinAlgError:
            return math.inf, math.inf
        ridge = np.array([1.0, self.g])
        k_e = math.sqrt(max(cov[1, 1] / alone[1, 1], 1.0))
        k_ridge = math.sqrt(max((ridge @ cov[:2, :2] @ ridge) / (ridge @ alone[:2, :2] @ ridge), 1.0))
        return k_e, k_ridge


def fit_reference(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    replica: Replica,
    carrier_hz: float,
    detection: ReferenceDetection,
    search_eps: float,
    noise_bandwidth_hz: float,
    eps_max: float,
    bound: ReferenceBound | None = None,
) -> ReferenceFit:
    """Maximum-likelihood (t_a, ε) around a coarse detection.

    Parameters
    ----------
    r : numpy.ndarray, complex
        Baseband at carrier ``carrier_hz``; r[n] at t0 + n/fs.
    detection : ReferenceDetection
    search_eps : float
        Half-width of the ε dichotomy (the bank spacing).
    noise_bandwidth_hz : float
        The front end's ∫|H|² df, to turn the baseband noise variance into N0.
    eps_max : float
        Largest |ε| searched (v_max/c).
    bound : ReferenceBound, optional
        :func:`~seamodem.transmit.reference.reference_crlb` of the replica (computed if not given).
    """
    bound = reference_crlb(replica) if bound is None else bound
    g = bound.ridge_slope_s
    dur = replica.duration_s
    limit = 1.05 * eps_max
    # a ridge longer than the main lobe over ±limit (a chirp): the detection may sit anywhere along it
    ridge_s = abs(g) * 2 * limit
    scan = ridge_s > 1.0 / replica.reference.bandwidth_hz
    reach = ridge_s if scan else 0.0
    lo = max(0, int(math.floor((detection.t_start_s - EARLY_WINDOW_S - reach - 2 / fs - t0_s) * fs)))
    hi = min(len(r), int(math.ceil((detection.t_start_s + dur * 1.01 + ECHO_WINDOW_S + reach + 2 / fs - t0_s) * fs)) + 1)
    x = r[lo:hi]
    t = t0_s + np.arange(lo, hi) / fs
    path = _PathFitter(replica, t, carrier_hz, fs, g, limit)
    echoes: list = []
    noise = _noise_level(r, fs, t0_s, detection.t_start_s, dur / (1 + detection.eps)) if scan else None
    if scan and noise is not None:
        # a chirp's ε from the joint likelihood of its paths (see _PathFitter.scan_paths)
        times, amps, eps = path.scan_paths(x, detection.t_start_s, detection.eps, noise)
    else:
        ta, eps = path.fit(x, detection.t_start_s, detection.eps, search_eps, grid=True)
        noise = _noise_level(r, fs, t0_s, ta, dur / (1 + eps))
        times, amps = np.array([ta]), None
        if noise is not None:
            # echoes overlapping the ping leak through the replica's sidelobes and pull the direct path: the
            # paths are the replica's significant peaks around the fit (an earlier one is the first arrival)
            times, amps, _ = path.paths_at(x, path.peaks(x, ta, eps, noise), eps)
            if len(times) == 1 or np.min(times) >= ta - 3.0 / replica.reference.bandwidth_hz:
                found = path.early_path(x, times, eps, noise)
                if found is not None:
                    times, amps = found
    if amps is None:
        q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
        gain = np.vdot(q, x) / float(np.real(np.vdot(q, q)))
    else:
        # paths too weak to matter are dropped; the first arrival is the earliest of FIRST_PATH_FRACTION of
        # the strongest; every path is then polished on the others' residual (SAGE)
        eq_s = float(np.sum(np.abs(_replica_samples(replica, fs, carrier_hz, eps)) ** 2))
        strongest = int(np.argmax(np.abs(amps)))
        keep = np.abs(amps) ** 2 * eq_s / noise >= np.where(times < times[strongest], EARLY_Z, ECHO_Z)
        keep[strongest] = True
        order = np.argsort(times[keep])
        times, amps = times[keep][order], amps[keep][order]
        first = int(np.flatnonzero(np.abs(amps) >= FIRST_PATH_FRACTION * np.max(np.abs(amps)))[0])
        paths = [[float(tp), eps, complex(ap), replica.scaled(t, t_arrival_s=float(tp), eps=eps, carrier_hz=carrier_hz)]
                 for tp, ap in zip(times, amps)]
        ta, eps, gain, q = paths.pop(first)
        echoes = paths
        if not echoes and scan:  # the joint Gauss–Newton polish of what the dichotomy's tolerance left
            ta, eps = path.fit(x, ta, eps, 0.0, grid=False)
    if echoes:
        for _ in range(3):
            others = sum(e[2] * e[3] for e in echoes)
            ta_before = ta
            ta, eps = path.fit(x - others, ta, eps, 0.0, grid=False)
            q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
            gain = np.vdot(q, x - others) / float(np.real(np.vdot(q, q)))
            for k, e in enumerate(echoes):
                rest = x - gain * q - sum(o[2] * o[3] for m, o in enumerate(echoes) if m != k)
                te, ee = path.fit(rest, e[0], e[1], 0.0, grid=False)
                qe = replica.scaled(t, t_arrival_s=te, eps=ee, carrier_hz=carrier_hz)
                echoes[k] = [te, ee, np.vdot(qe, rest) / float(np.real(np.vdot(qe, qe))), qe]
            if abs(ta - ta_before) * fs < 0.01:  # the direct path no longer moves: the paths are separated
                break
        x = x - sum(e[2] * e[3] for e in echoes)
    q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
    eq = float(np.real(np.vdot(q, q)))
    gain = np.vdot(q, x) / eq
    noise = _noise_level(r, fs, t0_s, ta, dur / (1 + eps))
    inside = np.abs(q) > 0.1 * np.max(np.abs(q))
    resid = x - gain * q
    if noise is None:
        noise = float(np.mean(np.abs(resid[inside]) ** 2))
    # a noiseless recording: keep the figures finite (E/N0 then about 120 dB)
    noise = max(noise, 1e-12 * abs(gain) ** 2 * float(np.mean(np.abs(q[inside]) ** 2)))
    misfit = float(np.mean(np.abs(resid[inside]) ** 2) / max(noise, np.finfo(float).tiny))
    # E/N0: E = ½|A|² Σ|q|²/fs (passband energy), N0 = σ²_bb / (2 ENBW)
    e_n0 = abs(gain) ** 2 * eq / fs * noise_bandwidth_hz / max(noise, np.finfo(float).tiny)
    band = replica.reference.bandwidth_hz
    snr_db = 10 * math.log10(max(e_n0 / (band * dur / (1 + eps)), 1e-30))
    _, s_e, s_ridge = bound.at(e_n0)
    inflate = math.sqrt(max(1.0, misfit))
    k_e, k_ridge = path.echo_inflation(ta, eps, gain, [(e[0], e[1], e[2]) for e in echoes]) if echoes else (1.0, 1.0)
    s_e, s_ridge = s_e * inflate * k_e, s_ridge * inflate * k_ridge
    if s_e > DOPPLER_THRESHOLD * eps_max or misfit > MISFIT_LIMIT:
        # below the Doppler threshold (an HFM at moderate SNR), the likelihood hardly varies along the ridge
        # within ±v_max: the ML lands anywhere in the search range and the CRLB no longer describes its error;
        # likewise when the fitted paths leave much more than noise (unresolved echoes), the ping's place on its
        # ridge is not to be trusted
        s_e = max(s_e, eps_max)
    return ReferenceFit(
        t_arrival_s=float(ta),
        eps=float(eps),
        gain=complex(gain),
        e_n0=float(e_n0),
        snr_db=snr_db,
        sigma_t_s=math.hypot(s_ridge, g * s_e),
        sigma_eps=s_e,
        ridge_t_s=float(ta + g * eps),
        sigma_ridge_s=s_ridge,
        misfit=misfit,
        ridge_slope_s=g,
        n_paths=1 + len(echoes),
    )


def _noise_level(r, fs, t0_s, ta, duration_s) -> float | None:
    """Median-based baseband noise variance just before the arrival, else just after the reference."""
    for a, b in (
        (ta - _NOISE_GAP_S - _NOISE_WINDOW_S, ta - _NOISE_GAP_S),
        (ta + duration_s + 0.03, ta + duration_s + 0.03 + _NOISE_WINDOW_S),
    ):
        lo, hi = int(math.ceil((a - t0_s) * fs)), int(math.floor((b - t0_s) * fs))
        if lo >= 0 and hi <= len(r) and hi - lo >= 0.8 * _NOISE_WINDOW_S * fs:
            return float(np.median(np.abs(r[lo:hi]) ** 2) / math.log(2))
    return None


@dataclass(frozen=True)
class ReferenceRecord(MeasurementRecord):
    """A :class:`MeasurementRecord` (same columns, same meanings) plus what a reference detection adds.

    The tone columns (``v_r_tone_eq9_mps``, ``tone_c_n0_dbhz``) are NaN; ``v_r_mps``
    and ``v_r_bank_mps`` are both the bank + dichotomy estimate.

    Attributes
    ----------
    reference : str
        Name of the reference that matched.
    channel : int
        Recording channel the measurement comes from (the best one when all are searched).
    e_n0_db : float
        Measured E/N0 of the ping [dB].
    misfit : float
        Residual χ² per sample over the noise (≈ 1 when only noise is left); σ's are inflated by √misfit.
    role : str
        "ping", "preamble" or "postamble". For a pair, ``t_arrival_s`` (and so ``tof_s``, ``range_m`` and
        ``sigma_range_m``) uses the pair's Doppler to place the arrival on the ping's delay–Doppler
        ridge when that is the more accurate (always for an HFM); ``v_r_mps`` stays the ping's own.
    v_r_pair_mps, sigma_v_r_pair_mps : float
        Doppler from the measured pre/postamble spacing and its σ [m/s] (NaN for lone pings).
    clipped_samples : int
        Clipped input samples within the ping.
    """

    reference: str = ""
    channel: int = 0
    e_n0_db: float = math.nan
    misfit: float = math.nan
    role: str = "ping"
    v_r_pair_mps: float = math.nan
    sigma_v_r_pair_mps: float = math.nan
    clipped_samples: int = 0


REFERENCE_FIELDS = tuple(f.name for f in dataclasses.fields(ReferenceRecord))


@dataclass
class _Found:
    """One fitted detection, before it is tied to an emission."""

    reference: ReferenceWaveform
    detection: ReferenceDetection
    fit: ReferenceFit
    channel: int
    clipped: int = 0
    role: str = "ping"
    eps_pair: float = math.nan
    sigma_eps_pair: float = math.nan
    t_pair_s: float = math.nan
    sigma_t_pair_s: float = math.nan


def pair_doppler(
    t1_s: float, t2_s: float, sigma1_s: float, sigma2_s: float, *, spacing_s: float
) -> tuple[float, float]:
    """Doppler scale from the measured spacing of two pings emitted ``spacing_s`` apart.

    The received pair is compressed by 1 + ε (SPEC §1): Δ = T_sp/(1 + ε), so
    ε = T_sp/Δ − 1, σ_ε = (T_sp/Δ²)·√(σ1² + σ2²) (mean closing speed over the
    packet).

    Examples
    --------
    >>> eps, s = pair_doppler(1.0, 9.0 / (1 + 1e-3) + 1.0, 1e-6, 1e-6, spacing_s=9.0)
    >>> round(eps * 1e3, 9)
    1.0
    """
    delta = t2_s - t1_s
    eps = spacing_s / delta - 1
    return float(eps), float(spacing_s / delta**2 * math.hypot(sigma1_s, sigma2_s))


class _Channel:
    """One channel's front end, baseband buffer and one detector per reference."""

    def __init__(self, plan: BandPlan, detectors: list[ReferenceDetector]):
        self.decimator = BandDecimator(plan)
        self.detectors = detectors
        self.buf = np.zeros(0, complex)
        self.buf_start = 0
        self.scan = [0] * len(detectors)


class ReferenceReceiver:
    """Streaming receiver of several references on one or all channels of a recording.

    Parameters
    ----------
    references : list of ReferenceWaveform
    fs : float
        Input rate [Hz].
    n_channels : int
        Channels fed to :meth:`run` (the best per detection is kept).
    sound_speed_mps, v_max_mps, false_alarms_per_hour : float
        As :class:`~seamodem.receive.settings.ReceiverSettings`; the false-alarm
        rate is shared among references and channels.
    replicas : list of Replica, optional
        Built from the references when not given (templates read their file).
    """

    def __init__(
        self,
        references: list[ReferenceWaveform],
        fs: float,
        *,
        n_channels: int = 1,
        sound_speed_mps: float = 1500.0,
        v_max_mps: float = 5.0,
        false_alarms_per_hour: float = 0.01,
        replicas: list[Replica] | None = None,
        min_rho: float = MIN_RHO,
    ):
        from ..transmit.reference import reference_replica

        if not references:
            raise ConfigError("reference", "give at least one reference waveform")
        names = [r.name for r in references]
        if len(set(names)) != len(names):
            raise ConfigError("reference", f"names must be distinct, got {names}")
        self.replicas = replicas or [reference_replica(r) for r in references]
        self.references = [rep.reference for rep in self.replicas]
        self.fs, self.c, self.v_max = float(fs), float(sound_speed_mps), float(v_max_mps)
        self.plan = plan_band(self.references, fs, v_max_mps=v_max_mps, sound_speed_mps=sound_speed_mps)
        rate = false_alarms_per_hour / (len(self.references) * n_channels)
        self.bounds = [reference_crlb(rep) for rep in self.replicas]
        proto = [
            ReferenceDetector(rep, self.plan, v_max_mps=v_max_mps, sound_speed_mps=sound_speed_mps,
                              false_alarms_per_hour=rate, min_rho=min_rho)
            for rep in self.replicas
        ]
        self.channels = [_Channel(self.plan, proto) for _ in range(n_channels)]
        # scan in chunks of several seconds: each scan also re-reads the noise context and a ping's length
        self.chunk = int(4 * max(d.length for d in proto) + 8 * self.plan.fs_bb)
        self.keep = int(max(d.length + d.window + d.context for d in proto) + 1.2 * (_NOISE_GAP_S + _NOISE_WINDOW_S) * self.plan.fs_bb)

    def _process(self, ch: _Channel, index: int, *, final: bool) -> list[_Found]:
        found = []
        fs = self.plan.fs_bb
        for i, det in enumerate(ch.detectors):
            if not final and ch.buf_start + len(ch.buf) - ch.scan[i] < self.chunk:
                continue
            dets, ch.scan[i] = det.find(ch.buf, ch.buf_start, ch.scan[i], final=final)
            for d in dets:
                fit = fit_reference(
                    ch.buf, fs, ch.buf_start / fs, replica=det.replica, carrier_hz=self.plan.centre_hz, detection=d,
                    search_eps=det.eps[1] - det.eps[0] if len(det.eps) > 1 else self.v_max / self.c,
                    noise_bandwidth_hz=self.plan.noise_bandwidth_hz, eps_max=self.v_max / self.c, bound=self.bounds[i],
                )
                found.append(_Found(self.references[i], d, fit, index))
        # the fine fit and the next scan need the tail: keep what the slowest detector still needs
        oldest = min(ch.scan) - self.keep
        cut = max(0, min(oldest - ch.buf_start, len(ch.buf)))
        ch.buf = ch.buf[cut:]
        ch.buf_start += cut
        return found

    def run(self, blocks: Iterable[np.ndarray]) -> Iterator[_Found]:
        """Fitted detections of every reference, channel by channel, as blocks (n, n_channels) arrive."""
        for block in blocks:
            block = np.asarray(block, dtype=float).reshape(len(block), -1)
            for j, ch in enumerate(self.channels):
                y = ch.decimator.push(block[:, j])
                ch.buf = np.concatenate([ch.buf, y])
                yield from self._process(ch, j, final=False)
        for j, ch in enumerate(self.channels):
            ch.buf = np.concatenate([ch.buf, ch.decimator.flush()])
            yield from self._process(ch, j, final=True)


def best_per_detection(found: list[_Found], *, tolerance_s: float) -> list[_Found]:
    """Of detections of one reference within ``tolerance_s`` on different channels, the one with the highest E/N0."""
    out: list[_Found] = []
    for f in sorted(found, key=lambda f: (f.reference.name, f.fit.t_arrival_s)):
        last = out[-1] if out else None
        if last is not None and last.reference.name == f.reference.name and abs(f.fit.t_arrival_s - last.fit.t_arrival_s) < tolerance_s:
            if f.fit.e_n0 > last.fit.e_n0:
                out[-1] = f
            continue
        out.append(f)
    return sorted(out, key=lambda f: f.fit.t_arrival_s)


def keep_matching_reference(found: list[_Found]) -> list[_Found]:
    """Of overlapping detections of different references (similar pings), the one with the best normalised correlation.

    Two references that share a band (an LFM and an HFM of the same sweep)
    correlate partly with each other's pings; the reference that was sent
    matches with ρ ≈ S/(S + N), the other with less.
    """
    out: list[_Found] = []
    for f in sorted(found, key=lambda f: f.fit.t_arrival_s):
        last = out[-1] if out else None
        if last is not None and last.reference.name != f.reference.name:
            if f.fit.t_arrival_s - last.fit.t_arrival_s < 0.5 * max(f.reference.duration_s, last.reference.duration_s):
                if f.detection.rho > last.detection.rho:
                    out[-1] = f
                continue
        out.append(f)
    return out


#: largest radial acceleration assumed over a pre/postamble packet [m/s²] (:func:`pair_up`)
MAX_ACCEL_MPS2 = 0.3


def pair_up(found: list[_Found], *, eps_max: float, max_accel_mps2: float = MAX_ACCEL_MPS2,
            sound_speed_mps: float = 1500.0) -> None:
    """Mark pre/postamble pairs of references with ``postamble_s`` and set their pair Doppler (in place).

    Each ping's ridge coordinate r = t_a + g·ε is measured to its known-ε bound (≈ 1 µs), far better than
    t_a (its Doppler error slides it along the ridge). With the Doppler changing over the packet,
    ε_pre = ε̄ − δ, ε_post = ε̄ + δ (δ = a·T_sp/(2c)), the ridge spacing is Δ + 2gδ, Δ = T_sp/(1 + ε̄) the
    arrivals' spacing. δ is estimated from the pings' own ε's, (ε̂_post − ε̂_pre)/2, shrunk towards 0 by a
    uniform prior |a| ≤ ``max_accel_mps2`` (best linear estimate; the pings' own ε's dominate when they
    are precise, the prior when they are not, as an HFM's). Then ε̄ = T_sp/(r_post − r_pre − 2gδ̃) − 1 with
    σ_ε̄ = (T_sp/Δ²)·√(σ_r,pre² + σ_r,post² + 4g²·var δ̃) (:func:`pair_doppler` for the spacing alone).
    Each ping's arrival on its ridge at its own ε̄ ∓ δ̃: t = r − g·(ε̄ ∓ δ̃).
    """
    by_ref: dict[str, list[_Found]] = {}
    for f in found:
        if f.reference.postamble_s:
            by_ref.setdefault(f.reference.name, []).append(f)
    for items in by_ref.values():
        items.sort(key=lambda f: f.fit.t_arrival_s)
        i = 0
        while i < len(items) - 1:
            a, b = items[i], items[i + 1]
            sp = a.reference.postamble_s
            delta = b.fit.ridge_t_s - a.fit.ridge_t_s
            if abs(delta - sp) <= 2 * eps_max * sp + 0.01 * a.reference.duration_s:
                g = a.fit.ridge_slope_s
                var_prior = (max_accel_mps2 * sp / (2 * sound_speed_mps)) ** 2 / 3
                var_own = (a.fit.sigma_eps**2 + b.fit.sigma_eps**2) / 4
                gain = var_prior / (var_prior + var_own) if var_prior + var_own > 0 else 0.0
                half_change = gain * (b.fit.eps - a.fit.eps) / 2
                var_half = var_prior * var_own / (var_prior + var_own) if var_prior + var_own > 0 else 0.0
                spacing = delta - 2 * g * half_change
                eps, sigma = pair_doppler(
                    a.fit.ridge_t_s, a.fit.ridge_t_s + spacing,
                    a.fit.sigma_ridge_s, math.hypot(b.fit.sigma_ridge_s, 2 * g * math.sqrt(var_half)), spacing_s=sp,
                )
                a.role, b.role = "preamble", "postamble"
                for f, sign in ((a, -1.0), (b, 1.0)):
                    f.eps_pair, f.sigma_eps_pair = eps, sigma
                    # the ping's own ε moves its arrival along the ridge; the pair's ε puts it back (HFM coupling)
                    f.t_pair_s = f.fit.ridge_t_s - g * (eps + sign * half_change)
                    f.sigma_t_pair_s = math.hypot(f.fit.sigma_ridge_s, g * math.hypot(sigma, math.sqrt(var_half)))
                i += 2
            else:
                i += 1


def to_record(f: _Found, emissions, *, sound_speed_mps: float, clock_offset_s: float = 0.0, source: str = "") -> ReferenceRecord:
    """The measurement record of one fitted detection (``emissions``: a :class:`~seamodem.receive.settings.Emissions` or None)."""
    c = sound_speed_mps
    fit = f.fit
    if math.isfinite(f.t_pair_s) and f.sigma_t_pair_s < fit.sigma_t_s:
        fit = dataclasses.replace(fit, t_arrival_s=f.t_pair_s, sigma_t_s=f.sigma_t_pair_s)
    if emissions is None:
        k, t_emit = -1, math.nan
    else:
        t_emit_arrival = fit.t_arrival_s - (f.reference.postamble_s if f.role == "postamble" else 0.0)
        k, t_emit = emissions.frame_for(t_emit_arrival - clock_offset_s)
        if f.role == "postamble" and k >= 0:
            t_emit += f.reference.postamble_s
    tof = fit.t_arrival_s - t_emit - clock_offset_s
    return ReferenceRecord(
        frame_index=k,
        t_emit_s=t_emit,
        t_arrival_s=fit.t_arrival_s,
        tof_s=tof,
        range_m=c * tof,
        v_r_mps=fit.eps * c,
        snr_db=fit.snr_db,
        v_r_tone_eq9_mps=math.nan,
        v_r_bank_mps=fit.eps * c,
        v_r_source="bank",
        n_paths=fit.n_paths,
        detection_z=f.detection.z,
        detection_rho=f.detection.rho,
        sigma_range_m=c * fit.sigma_t_s,
        sigma_v_r_mps=c * fit.sigma_eps,
        sigma_v_r_bank_mps=c * fit.sigma_eps,
        tone_c_n0_dbhz=math.nan,
        source=source,
        reference=f.reference.name,
        channel=f.channel,
        e_n0_db=10 * math.log10(max(fit.e_n0, 1e-30)),
        misfit=fit.misfit,
        role=f.role,
        v_r_pair_mps=f.eps_pair * c,
        sigma_v_r_pair_mps=f.sigma_eps_pair * c,
        clipped_samples=f.clipped,
    )
