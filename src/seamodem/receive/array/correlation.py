"""Pilot correlations of every channel around one frame (:mod:`seamodem.receive.array`, its first formula).

c_k(δ) = Σ_n x_k(t_n) r*(t_n − δ) with r the analytic passband pilot,
Doppler-scaled by the detection's speed, kept as in-band spectra
(:class:`ArrayCorrelation`) so that it is evaluated at any lag δ by its
band-limited Fourier sum: on passband samples (:func:`array_correlation`) or
on the front end's decimated basebands (:func:`baseband_correlation`, a tenth
of the samples), with each channel's noise variance from the noise before
the frame.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ...config import FrameConfig
from ...errors import ConfigError


#: the correlation window extends this far beyond the pilot on each side [s]
WINDOW_MARGIN_S = 0.007
#: noise is measured over this window, ending this long before the frame start [s]
NOISE_SEGMENT_S, NOISE_GAP_S = 0.03, 0.001


def _pilot_envelope(config: FrameConfig, pilot: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """Pilot envelope b(τ) = Σ a_k g(τ − (Ng + k)T) at frame times τ [s] (zero outside the pilot)."""
    from ...transmit.pulse import srrc_matrix

    T = config.symbol_period_s
    tk = (config.n_guard + np.arange(config.n_pilot)) * T
    g = srrc_matrix(tau_s, tk, symbol_period_s=T, rolloff=config.rolloff, span_symbols=config.srrc_span_symbols)
    return g @ np.asarray(pilot, complex)


def _pilot_reference(config: FrameConfig, pilot: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """Analytic passband pilot b(τ) e^{j2π f0 τ} at frame times τ [s] (zero outside the pilot)."""
    return _pilot_envelope(config, pilot, tau_s) * np.exp(2j * np.pi * config.carrier_hz * tau_s)


def _pilot_window(config: FrameConfig, t_arrival_s: float, scale: float, fs: float, t0_s: float,
                  n_total: int) -> tuple[int, int]:
    """Sample span [i0, i1) of the pilot (its SRRC tails and WINDOW_MARGIN_S either side) for a frame at t_arrival_s."""
    T = config.symbol_period_s
    half = config.srrc_span_symbols // 2
    tau_a = (config.n_guard - half) * T
    tau_b = (config.n_guard + config.n_pilot - 1 + half) * T
    i0 = math.floor((t_arrival_s + tau_a / scale - WINDOW_MARGIN_S - t0_s) * fs)
    i1 = math.ceil((t_arrival_s + tau_b / scale + WINDOW_MARGIN_S - t0_s) * fs)
    if i0 < 0 or i1 > n_total:
        raise ConfigError("t_arrival_s", f"the frame's pilot at {t_arrival_s:.4f} s is not inside the recording")
    return i0, i1


def _noise_window(config: FrameConfig, t_arrival_s: float, fs: float, t0_s: float, i1: int,
                  n_total: int) -> tuple[int, int]:
    """Sample span of the noise measurement: NOISE_SEGMENT_S ending NOISE_GAP_S before the frame, or,
    when the frame starts the recording, after its pilot's window (which ends at i1)."""
    j1 = math.floor((t_arrival_s - NOISE_GAP_S - t0_s) * fs)
    j0 = j1 - round(NOISE_SEGMENT_S * fs)
    if j0 < 0:
        j0 = i1 + round(0.5 * config.frame_duration_s * fs)
        j0 = max(i1, min(j0, n_total - round(NOISE_SEGMENT_S * fs)))
        j1 = j0 + round(NOISE_SEGMENT_S * fs)
    return j0, j1


@njit(cache=True, nogil=True)
def _phasor_sums(spectra, f0, df, lags, out):
    """out[k, l] = Σ_m spectra[k, m] e^{j2π lags[k, l] (f0 + m·df)}: the phasor turned bin by bin (one exp per
    lag; the product of m unit phasors drifts by ~m·1e-16)."""
    n_ch, n_bins = spectra.shape
    for k in range(n_ch):
        for l in range(lags.shape[1]):
            w = np.exp(2j * np.pi * lags[k, l] * f0)
            step = np.exp(2j * np.pi * lags[k, l] * df)
            acc = 0j
            for m in range(n_bins):
                acc += spectra[k, m] * w
                w *= step
            out[k, l] = acc


@dataclass(frozen=True, eq=False)
class ArrayCorrelation:
    """Pilot correlations of every channel around one frame, as in-band spectra.

    Attributes
    ----------
    spectra : numpy.ndarray, shape (n_channels, n_bins), complex
        X_k[m] R*[m] / N on the in-band bins: c_k(δ) = Σ_m spectra[k, m] e^{j2π f_m δ}.
    freqs_hz : numpy.ndarray, shape (n_bins,)
    noise_var : numpy.ndarray, shape (n_channels,)
        Variance of c_k(δ) from noise alone (from the noise before the frame).
    t_arrival_s : float
        The reference arrival t_a: lag 0 [s].
    kernel : numpy.ndarray, shape (n_bins,)
        |R[m]|² / N: a path of amplitude a at lag δ adds a·kernel·e^{−j2π f δ} to a channel's spectrum.
    n_fft : int
        Window length N (samples).
    fs_hz : float
        Sample rate of the window [Hz] (the passband rate, or the decimated
        baseband's for :func:`baseband_correlation`).
    """

    spectra: np.ndarray
    freqs_hz: np.ndarray
    noise_var: np.ndarray
    t_arrival_s: float
    kernel: np.ndarray
    n_fft: int
    fs_hz: float

    @property
    def energy(self) -> float:
        """c(0) of a unit path at lag 0: Σ kernel."""
        return float(np.sum(self.kernel))

    def without(self, lags_s: np.ndarray, amplitudes: np.ndarray) -> ArrayCorrelation:
        """The correlations with paths of those lags and amplitudes removed.

        Parameters
        ----------
        lags_s : numpy.ndarray, shape (n_channels,) or (n_channels, n_paths)
            The paths' lags on each channel [s].
        amplitudes : numpy.ndarray, same shape, complex
            Their amplitudes (c / E).

        Returns
        -------
        ArrayCorrelation
            A copy with those paths' model subtracted from the spectra.
        """
        lags = np.atleast_2d(np.asarray(lags_s, float).T).T
        amps = np.atleast_2d(np.asarray(amplitudes, complex).T).T
        model = np.einsum("kp,kpm->km", amps, np.exp(-2j * np.pi * lags[:, :, None] * self.freqs_hz[None, None, :]))
        return dataclasses.replace(self, spectra=self.spectra - model * self.kernel[None, :])

    def on_sample_grid(self, fs: float) -> np.ndarray:
        """|c_k| at lags i/fs, i = 0 … N−1 (circular: the last ones are negative lags), shape (n_channels, N).

        The bins are placed relative to the lowest one (a baseband window's
        frequencies are offset by the carrier), so only the magnitude is c_k's.

        Parameters
        ----------
        fs : float
            The window's sample rate [Hz].

        Returns
        -------
        numpy.ndarray, shape (n_channels, N)
            |c_k(i/fs)|.
        """
        full = np.zeros((self.spectra.shape[0], self.n_fft), complex)
        full[:, np.rint((self.freqs_hz - self.freqs_hz[0]) * self.n_fft / fs).astype(int) % self.n_fft] = self.spectra
        return np.abs(np.fft.ifft(full, axis=1)) * self.n_fft

    def at(self, lags_s: np.ndarray) -> np.ndarray:
        """c_k(δ) at any lags: one per channel, or a grid per channel.

        Parameters
        ----------
        lags_s : numpy.ndarray, shape (n_channels,) or (n_channels, n_lags)
            Lags δ [s] relative to ``t_arrival_s``.

        Returns
        -------
        numpy.ndarray, complex, the shape of ``lags_s``
            The correlations there.
        """
        lags = np.asarray(lags_s, float)
        f = self.freqs_hz
        df = (f[-1] - f[0]) / max(len(f) - 1, 1)
        if len(f) > 1 and np.allclose(np.diff(f), df, rtol=1e-9, atol=0.0):
            # equally spaced bins (both correlations): a rotating phasor per lag instead of an exp per bin
            grid = np.ascontiguousarray(lags.reshape(lags.shape[0], -1))
            out = np.empty(grid.shape, complex)
            _phasor_sums(np.ascontiguousarray(self.spectra, dtype=complex), float(f[0]), float(df), grid, out)
            return out[:, 0] if lags.ndim == 1 else out
        if lags.ndim == 1:
            return np.einsum("km,km->k", self.spectra, np.exp(2j * np.pi * lags[:, None] * f[None, :]))
        return np.einsum("km,klm->kl", self.spectra, np.exp(2j * np.pi * lags[:, :, None] * f[None, None, :]))


def _band_bins(n: int, fs: float, config: FrameConfig) -> np.ndarray:
    lo, hi = config.data_band_hz
    f = np.arange(n // 2 + 1) * fs / n
    return np.flatnonzero((f >= 0.98 * lo) & (f <= 1.02 * hi))


def array_correlation(
    x: np.ndarray,
    fs: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_arrival_s: float,
    v_mps: float,
    sound_speed_mps: float,
    t0_s: float = 0.0,
    complex_gains: np.ndarray | None = None,
) -> ArrayCorrelation:
    """Pilot correlations c_k of one frame (:mod:`seamodem.receive.array`).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels; row i at time t0_s + i/fs [s].
    fs : float
        Their sample rate [Hz].
    config : FrameConfig
        The frame (pilot pulse, carrier, data band).
    pilot : numpy.ndarray
        Pilot symbols.
    t_arrival_s : float
        Frame start arrival on the reference channel [s] (lag 0).
    v_mps : float
        Closing speed the reference is scaled by [m/s].
    sound_speed_mps : float
        Sound speed c [m/s] (the scale 1 + v/c).
    t0_s : float
        Time of row 0 [s].
    complex_gains : numpy.ndarray, shape (n_channels,), optional
        Known channel gains (calibration), divided out.

    Returns
    -------
    ArrayCorrelation
        The frame's correlations and their noise variances.

    Raises
    ------
    ConfigError
        The recording does not hold the frame's pilot.
    """
    x = np.asarray(x, float)
    scale = 1.0 + v_mps / sound_speed_mps
    i0, i1 = _pilot_window(config, t_arrival_s, scale, fs, t0_s, x.shape[0])
    n = i1 - i0
    t = t0_s + (i0 + np.arange(n)) / fs
    r = _pilot_reference(config, pilot, (t - t_arrival_s) * scale)
    bins = _band_bins(n, fs, config)
    X = 2.0 * np.fft.rfft(x[i0:i1], axis=0)[bins].T  # analytic, in band
    R = np.fft.fft(r)[bins]
    if complex_gains is not None:
        X = X / np.asarray(complex_gains)[:, None]
    spectra = X * np.conj(R)[None, :] / n
    freqs = bins * fs / n
    # noise before the frame: per-bin periodogram, smoothed, at this window's bins
    j0, j1 = _noise_window(config, t_arrival_s, fs, t0_s, i1, x.shape[0])
    seg = x[j0:j1]
    L = seg.shape[0]
    fseg = np.fft.rfftfreq(L, 1.0 / fs)
    P = np.abs(np.fft.rfft(seg, axis=0)) ** 2 / L  # E = σ² per bin for white noise
    kernel = np.ones(9) / 9
    P = np.stack([np.convolve(P[:, k], kernel, mode="same") for k in range(P.shape[1])], axis=1)
    psd = np.stack([np.interp(freqs, fseg, P[:, k]) for k in range(P.shape[1])])
    if complex_gains is not None:
        psd = psd / np.abs(np.asarray(complex_gains))[:, None] ** 2
    noise_var = 4.0 / n * np.sum(np.abs(R)[None, :] ** 2 * psd, axis=1)
    return ArrayCorrelation(spectra, freqs, noise_var, float(t_arrival_s), np.abs(R) ** 2 / n, n, float(fs))


def baseband_correlation(
    bb: np.ndarray,
    fs: float,
    centre_hz: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_arrival_s: float,
    v_mps: float,
    sound_speed_mps: float,
    t0_s: float = 0.0,
) -> ArrayCorrelation:
    """:func:`array_correlation` on the front end's decimated complex basebands (one FFT over all channels).

    With x_pb = Re[x_bb e^{j2π fc t}] (:mod:`seamodem.receive.frontend`), the analytic
    passband correlation is c_k(δ) = e^{j2π fc δ} Σ_n x_bb,k(t_n) r_bb*(t_n − δ),
    r_bb(t) = b(τ) e^{j2π (f0 τ − fc t)}, τ = (t − t_a)(1 + v/c): the spectra
    are those of the baseband window, their frequencies shifted up by fc, so
    that :meth:`ArrayCorrelation.at` evaluates the same c_k(δ) as the passband
    version at a tenth of the samples.

    Parameters
    ----------
    bb : numpy.ndarray, shape (n_samples, n_channels), complex
        Data-band basebands; row i at time t0_s + i/fs [s].
    fs : float
        Their rate [Hz].
    centre_hz : float
        The front end's mixing frequency fc [Hz].
    config, pilot, t_arrival_s, v_mps, sound_speed_mps, t0_s
        As :func:`array_correlation`.

    Returns
    -------
    ArrayCorrelation
        The frame's correlations (frequencies in passband) and their noise variances.

    Raises
    ------
    ConfigError
        The basebands do not hold the frame's pilot.
    """
    scale = 1.0 + v_mps / sound_speed_mps
    i0, i1 = _pilot_window(config, t_arrival_s, scale, fs, t0_s, bb.shape[0])
    n = i1 - i0
    idx = np.arange(n)
    tau = (t0_s + (i0 + idx) / fs - t_arrival_s) * scale
    env = _pilot_envelope(config, pilot, tau)
    start_cycles = math.fmod(centre_hz * (t0_s + i0 / fs), 1.0)  # fc·t modulo one cycle, for precision
    r = env * np.exp(2j * np.pi * (config.carrier_hz * tau - start_cycles - centre_hz * idx / fs))
    f = np.fft.fftfreq(n, 1.0 / fs)
    lo, hi = config.data_band_hz
    bins = np.flatnonzero((f + centre_hz >= 0.98 * lo) & (f + centre_hz <= 1.02 * hi))
    bins = bins[np.argsort(f[bins])]
    X = np.fft.fft(bb[i0:i1], axis=0)[bins].T
    R = np.fft.fft(r)[bins]
    spectra = X * np.conj(R)[None, :] / n
    # noise before the frame: per-bin periodogram of each channel, smoothed, at this window's bins
    j0, j1 = _noise_window(config, t_arrival_s, fs, t0_s, i1, bb.shape[0])
    seg = bb[j0:j1]
    L = seg.shape[0]
    order = np.argsort(np.fft.fftfreq(L, 1.0 / fs))
    fseg = np.fft.fftfreq(L, 1.0 / fs)[order]
    P = (np.abs(np.fft.fft(seg, axis=0)) ** 2 / L)[order]  # E = noise power per bin
    kernel = np.ones(9) / 9
    psd = np.stack([np.interp(f[bins], fseg, np.convolve(P[:, k], kernel, mode="same")) for k in range(P.shape[1])])
    noise_var = np.sum(np.abs(R)[None, :] ** 2 * psd, axis=1) / n
    return ArrayCorrelation(spectra, f[bins] + centre_hz, noise_var, float(t_arrival_s), np.abs(R) ** 2 / n, n,
                            float(fs))


def fs_of(corr: ArrayCorrelation) -> float:
    """Sample rate of the correlation window [Hz] (bin spacing × N).

    Parameters
    ----------
    corr : ArrayCorrelation
        A frame's correlations.

    Returns
    -------
    float
        ``corr.fs_hz`` [Hz].
    """
    return corr.fs_hz
