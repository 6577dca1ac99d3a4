"""Maximum-likelihood delay, Doppler scale and gains of a reference's paths in a baseband segment (:class:`PathFitter`)."""

from __future__ import annotations

import math

import numpy as np
import scipy.fft

from ...transmit.reference import Replica
from ..doppler import dichotomy_max
from .detect import replica_samples

__all__ = [
    "PathFitter",
    "ECHO_WINDOW_S",
    "EARLY_WINDOW_S",
    "FIRST_PATH_FRACTION",
    "MAX_ECHOES",
    "ECHO_Z",
    "SCAN_POINTS",
    "SCAN_STEPS",
    "EARLY_Z",
]

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
        p = replica_samples(replica, fs, carrier_hz, 0.0)
        n = scipy.fft.next_fast_len(2 * len(p))
        a = np.abs(scipy.fft.ifft(np.abs(scipy.fft.fft(p, n)) ** 2)) ** 2
        lag = np.minimum(np.arange(n), n - np.arange(n)) / fs
        replica.memo[key] = float(np.max(a[lag > 1.0 / replica.reference.bandwidth_hz]) / a[0])
    return replica.memo[key]


class PathFitter:
    """Maximum-likelihood (t_a, ε) of one path of a reference in a baseband segment (x[n] at t[n]).

    Also the joint fit of several paths at one scale, the search for echoes and an earlier path, and the
    echoes' inflation of the direct path's bounds (:func:`~seamodem.receive.reference.fit_reference` chains them).

    Parameters
    ----------
    replica : Replica
        The reference's replica.
    t : numpy.ndarray
        Time of each sample of the segments to fit [s] (uniform at ``fs``).
    carrier_hz : float
        Mixing frequency of the baseband [Hz].
    fs : float
        Baseband sample rate [Hz].
    ridge_slope_s : float
        g, the slope of the reference's delay–Doppler ridge [s per unit ε]
        (:class:`~seamodem.transmit.reference.ReferenceBound`).
    limit : float
        Largest |ε| searched.
    """

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
        """|⟨q, x⟩|/‖q‖: the likelihood with A unknown (‖q‖ varies as 1/√(1 + ε); left out, it biases ε along the ridge).

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        ta : float
            Arrival of the replica's first sample [s].
        eps : float
            Doppler scale ε.

        Returns
        -------
        float
            The normalised correlation magnitude (baseband units).
        """
        k = self._support(ta, eps)
        q = self.replica.scaled(self.t[k], t_arrival_s=ta, eps=eps, carrier_hz=self.carrier_hz)
        return abs(np.vdot(q, x[k])) / math.sqrt(max(np.real(np.vdot(q, q)), np.finfo(float).tiny))

    def gauss_newton(self, x, ta, eps, *, free_eps: bool):
        """One Gauss–Newton step of the fit x ≈ A q(t_a, ε) (A complex, t_a and ε real).

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        ta : float
            Current arrival [s].
        eps : float
            Current Doppler scale ε.
        free_eps : bool
            Step ε too (else ε stays).

        Returns
        -------
        ta : float
            The next arrival [s] (the step shrunk to half a sample at most).
        eps : float
            The next ε.
        """
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

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        ta0 : float
            Starting arrival [s].
        eps0 : float
            Starting Doppler scale ε.
        search_eps : float
            Half-width of the dichotomy around ``eps0`` (0: the polish alone).
        grid : bool
            Start from the best of 9 arrivals over ±1 sample around ``ta0``.
        scan : bool
            Search the profile over all of ±limit first.

        Returns
        -------
        ta : float
            Arrival [s].
        eps : float
            Doppler scale ε.
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

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        times : numpy.ndarray
            Starting arrival of each path [s].
        eps : float
            The paths' common Doppler scale ε.
        steps : int
            Joint Gauss–Newton steps on the arrivals.

        Returns
        -------
        times : numpy.ndarray
            Each path's arrival [s].
        gains : numpy.ndarray, complex
            Each path's complex amplitude (zeros when the paths cannot be told apart).
        explained : float
            ‖P_Q x‖², the energy the paths explain (baseband units²).
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

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        ta : float
            Arrival around which peaks are sought [s].
        eps : float
            Doppler scale ε of the replica correlated.
        noise : float
            Baseband noise variance (baseband units²).
        split : bool
            Also start a second path at the far end of a broad hump.

        Returns
        -------
        numpy.ndarray
            Each peak's lag [s], strongest first, on the sample grid.
        """
        # the scan asks for the same few scales (its grid) on the same segment: both spectra are kept
        n = scipy.fft.next_fast_len(len(x) + int(math.ceil(self.replica.duration_s * self.fs / (1 - self.limit))) + 2)
        memo, key = self.replica.memo, ("spectrum", self.fs, self.carrier_hz, float(eps), n)
        if key not in memo:
            if len(memo) > 256:  # FFT sizes follow the segment's length: keep the memo bounded
                memo.clear()
            p = replica_samples(self.replica, self.fs, self.carrier_hz, eps)
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

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        times : numpy.ndarray
            Arrivals of the paths already found [s].
        eps : float
            The paths' common Doppler scale ε.
        noise : float
            Baseband noise variance (baseband units²).

        Returns
        -------
        tuple of numpy.ndarray, or None
            (times [s], complex gains) of τ and the paths, τ first; None when the earlier path fails the test.
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

        Parameters
        ----------
        x : numpy.ndarray, complex
            Baseband segment, x[n] at ``t[n]`` (the fitter's time axis).
        ta0 : float
            The detector's arrival [s].
        eps0 : float
            The detector's scale bin ε.
        noise : float
            Baseband noise variance (baseband units²).

        Returns
        -------
        times : numpy.ndarray
            Each path's arrival at the best scale [s].
        gains : numpy.ndarray, complex
            Each path's complex amplitude.
        eps : float
            The best Doppler scale ε.
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

        Parameters
        ----------
        ta : float
            The direct path's arrival [s].
        eps : float
            Its Doppler scale ε.
        gain : complex
            Its complex amplitude.
        echoes : list of (float, float, complex)
            Each echo's arrival [s], ε and complex amplitude.

        Returns
        -------
        k_eps : float
            σ_ε with the echoes over σ_ε alone (≥ 1; inf when the Fisher matrix is singular).
        k_ridge : float
            The same for the ridge coordinate t_a + g·ε.
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
