"""Pilot detection on every channel at once: a non-coherent sum of the channels' normalised correlations.

:class:`ArrayDetector` keeps the single detector's Doppler bank, first-arrival
rule and false-alarm rate, with the array's gain on both tests (z and ρ).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...config import FrameConfig


#: the combined detector scans the basebands in chunks of this length [s] (bounded memory)
DETECTION_CHUNK_S = 10.0


@njit(cache=True, nogil=True)
def _power_rows(c, n_out, power):
    """|c[k, j]|² of each channel's first ``n_out`` lags into power (K, n_out), float32."""
    for k in range(c.shape[0]):
        for j in range(n_out):
            power[k, j] = c[k, j].real * c[k, j].real + c[k, j].imag * c[k, j].imag


@njit(cache=True, nogil=True)
def _direct_correlation(r, q, lags, bins, out):
    """out[h, k] = Σ_i r[lags[h] + i, k] q[bins[h], i]: the bank's correlation at a few lags."""
    n_ch, n_taps = r.shape[1], q.shape[1]
    for h in range(len(lags)):
        j, b = lags[h], bins[h]
        for k in range(n_ch):
            acc = 0j
            for i in range(n_taps):
                acc += r[j + i, k] * q[b, i]
            out[h, k] = acc


@njit(cache=True, nogil=True)
def _best_bin(power, scale, z, best):
    """z[j] = max_b Σ_k scale[k] power[b, k, j] and its bin (the first of equal ones), in place."""
    n_bins, n_ch, n_out = power.shape
    acc = np.empty(n_out, np.float32)
    for b in range(n_bins):
        acc[:] = 0.0
        for k in range(n_ch):
            for j in range(n_out):
                acc[j] += scale[k] * power[b, k, j]
        for j in range(n_out):
            if b == 0 or acc[j] > z[j]:
                z[j] = acc[j]
                best[j] = b


class ArrayDetector:
    """Pilot detection on all channels: non-coherent sum of the channels' normalised correlations.

    Built on :class:`~seamodem.receive.detect.PilotDetector` (same Doppler
    bank, first-arrival rule and hold-off). For each lag and Doppler bin,
    Z = Σ_k |c_k|² / σ²_{c,k}, each channel normalised by its own noise
    (median over lags and bins / ln 2). In white Gaussian noise Z is
    Gamma(K, 1), so the threshold η_K with P(Z > η_K) = rate / (tests per hour)
    keeps the single detector's false-alarm rate. The normalised correlation
    ρ, against the same ρ_min, is that of the best combination of the channels
    (:meth:`_coherent_rho`), so that it gains the array's SNR too.

    Array gain: a frame of post-correlation SNR γ per element gives
    E[Z] = K(γ + 1) against η_K, one element γ + 1 against η_1: at the
    design rate 0.01/h, jmse2024 at 96 kHz, η_1 = 24.7 and η_4 = 33.6, so 4
    elements reach the threshold on average at γ = 7.4 where one needs
    γ = 23.7 (5.1 dB of array gain for the z test; non-coherent, so less than
    the 6 dB of a coherent sum).
    The ρ test, ≈ Kγ/(1 + Kγ) with γ the in-band SNR per element, moves from
    ≈ −9 dB per element (one hydrophone) to ≈ −9 − 10 log10 K dB.

    Parameters
    ----------
    config : FrameConfig
        The transmitted frame.
    fs : float
        The data basebands' rate [Hz].
    n_channels : int
        Number of channels K.
    **options
        As :class:`~seamodem.receive.detect.PilotDetector` (v_max_mps,
        sound_speed_mps, false_alarms_per_hour, pilot, ...:
        :func:`~seamodem.receive.frame.detector_options`).

    Attributes
    ----------
    base : PilotDetector
        The single detector whose bank, rules and ``find`` run on the array's statistics.
    eta : float
        The threshold η_K on Z.
    """

    def __init__(self, config: FrameConfig, fs: float, n_channels: int, **options):
        import scipy.special

        from ..detect import PilotDetector

        self.base = PilotDetector(config, fs, **options)
        self.n_channels = int(n_channels)
        b = self.base
        p_test = float(options.get("false_alarms_per_hour", 0.01)) / (len(b.doppler_hz) * b.fs * 3600.0)
        b.eta = float(scipy.special.gammainccinv(self.n_channels, p_test))
        # the base's find() uses the array's statistics, given the whole noise context on every call: unlike the
        # single detector, the array's keeps no lags from the previous chunk. The bank's bins snap to multiples of
        # fs/N, N the FFT size of the segment, so |c|² kept from the previous chunk differs from this chunk's by up
        # to 2 % of its peak in noise: a frame's z and ρ move by 0.05-1.3 % and other noise crossings pass η (times
        # and bins of frames unchanged). The context costs about 2 % of the detection (0.5 s per 10 s chunk).
        b.statistics = self.statistics
        self.eta = b.eta

    def statistics(self, r: np.ndarray):
        """z (= Z), ρ, best bin and √Z for every full-overlap lag of the basebands r (n, K).

        ρ is computed at the local maxima of Z above η only (elsewhere 0: the
        lags the detector takes for arrivals and strongest paths are such maxima).

        Parameters
        ----------
        r : numpy.ndarray, shape (n, n_channels), complex
            Data-band basebands.

        Returns
        -------
        z : numpy.ndarray, shape (n − L + 1,)
            Z at each lag (L the pilot template's length).
        rho : numpy.ndarray
            ρ at each lag (0 away from Z's peaks above η).
        best : numpy.ndarray of int
            The Doppler bin of Z's maximum at each lag.
        sqrt_z : numpy.ndarray
            √Z.
        """
        import scipy.fft

        b = self.base
        K = r.shape[1]
        n_out = r.shape[0] - b.length + 1
        n = scipy.fft.next_fast_len(r.shape[0])
        # channels along the first axis: each FFT runs on contiguous samples
        spectrum = scipy.fft.fft(np.ascontiguousarray(r.T, dtype=np.complex64), n, axis=-1)
        pilot = np.conj(scipy.fft.fft(b.template.astype(np.complex64), n))
        shifts = np.round(b.doppler_hz * n / b.fs).astype(np.int64) % n
        power = np.empty((len(shifts), K, n_out), np.float32)
        product = np.empty((K, n), np.complex64)
        for i, m in enumerate(shifts):
            m = int(m)  # product = spectrum · roll(pilot, m), without the roll's copy (as the single detector)
            np.multiply(spectrum[:, m:], pilot[None, : n - m], out=product[:, m:])
            np.multiply(spectrum[:, :m], pilot[None, n - m:], out=product[:, :m])
            _power_rows(scipy.fft.ifft(product, axis=-1, overwrite_x=True), n_out, power[i])
        sample = power[:, :, ::4].transpose(1, 0, 2).reshape(K, -1)  # every 4th lag, as the single detector
        # a noiseless recording keeps Z finite (the floor from the sampled lags: a full pass over power
        # cost a third of the statistics)
        noise = np.maximum(np.median(sample, axis=1) / math.log(2), 1e-6 * np.max(sample, axis=1))
        scale = (1.0 / np.maximum(noise, np.finfo(np.float32).tiny)).astype(np.float32)
        z32, best = np.zeros(n_out, np.float32), np.zeros(n_out, np.int64)
        _best_bin(power, scale, z32, best)
        z = z32.astype(float)
        rho = np.zeros(n_out)
        # ρ at the local maxima of Z above η only: the detector's arrivals and strongest paths are such peaks
        peak = np.ones(n_out, bool)
        peak[1:] &= z[1:] >= z[:-1]
        peak[:-1] &= z[:-1] >= z[1:]
        hit = np.flatnonzero((z >= b.eta) & peak)
        if hit.size:
            # c_k at those lags and bins by direct sums (the bank's circular correlation with the pilot
            # spectrum rolled by m is Σ_i r_k[j + i] conj(p[i] e^{j2π m i/n}), no wrap for full-overlap lags)
            q = np.conj(b.template[None, :] * np.exp(2j * np.pi * np.outer(shifts, np.arange(b.length)) / n))
            c = np.empty((hit.size, K), complex)
            _direct_correlation(np.ascontiguousarray(r, dtype=complex), q, hit, best[hit], c)
            rho[hit] = self._coherent_rho(r, c, hit)
        return z, rho, best, np.sqrt(z)

    def _coherent_rho(self, r: np.ndarray, c: np.ndarray, lags: np.ndarray) -> np.ndarray:
        """ρ of the best linear combination of the channels at each lag: c^H M⁻¹ c / E_p.

        M_km = Σ_window r_k r_m* (the window's Gram matrix). A beam y = Σ_k w_k r_k
        has ρ_y = |Σ w_k c_k|² / (E_p w^T M w*), whose maximum over w is
        c^H M⁻¹ c / E_p (a generalised Rayleigh quotient). For a frame of in-band
        SNR γ per element it is ≈ Kγ/(1 + Kγ), the coherently combined frame's ρ:
        the ρ test gains the array's SNR too, while an impulse (≈ 1/N_p) and the
        frame's own data symbols (≤ 0.06, the same signal on every element: a
        rank-one M) stay where the single detector puts them. One channel: the
        single detector's ρ.
        """
        b = self.base
        K = r.shape[1]
        L = b.length
        out = np.empty(len(lags))
        # runs of lags whose windows overlap share one cumulative Gram sum over their span
        breaks = np.flatnonzero(np.diff(lags) > L) + 1
        for run in np.split(np.arange(len(lags)), breaks):
            for s0 in range(0, len(run), 4096):  # bounded memory
                sel = run[s0:s0 + 4096]
                j = lags[sel]
                lo, hi = int(j[0]), int(j[-1]) + L
                seg = r[lo:hi]
                prod = (seg[:, :, None] * np.conj(seg[:, None, :])).reshape(hi - lo, K * K)
                cs = np.concatenate([np.zeros((1, K * K), complex), np.cumsum(prod, axis=0)])
                M = (cs[j - lo + L] - cs[j - lo]).reshape(len(j), K, K)
                M = M + (1e-9 * np.real(np.trace(M, axis1=1, axis2=2)) / K
                         + np.finfo(float).tiny)[:, None, None] * np.eye(K)
                cj = c[sel].astype(complex)
                q = np.linalg.solve(M, cj[:, :, None])[:, :, 0]
                out[sel] = np.real(np.sum(np.conj(cj) * q, axis=1)) / b.template_energy
        return out

    def find_all(self, bb: np.ndarray):
        """Every detection in the basebands, scanned in chunks of DETECTION_CHUNK_S (bounded memory).

        Parameters
        ----------
        bb : numpy.ndarray, shape (n, n_channels), complex
            Data-band basebands at the detector's rate, sample 0 at time 0.

        Returns
        -------
        list of Detection
            In order of arrival.
        """
        b = self.base
        chunk = max(4 * b.length, int(DETECTION_CHUNK_S * b.fs))
        out, scan_from, end = [], 0, 0
        while True:
            end = min(bb.shape[0], end + chunk)
            final = end >= bb.shape[0]
            start = max(0, scan_from - b.context)
            found, scan_from = b.find(bb[start:end], start, scan_from, final=final)
            out.extend(found)
            if final:
                return out
