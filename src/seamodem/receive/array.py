"""Multichannel reception: direction of arrival per frame and maximal-ratio combining (issue 17).

For each frame the single-hydrophone receiver detects (on a reference
channel), every channel k is correlated with the frame's pilot as an
*analytic passband* waveform, Doppler-scaled by the measured speed:

    c_k(δ) = Σ_n x_k(t_n) r*(t_n − δ),   r(t) = b((t − t_a)(1 + v/c)) e^{j2π f0 (t − t_a)(1 + v/c)},

evaluated at any lag δ by its band-limited Fourier sum. A plane wave from the
unit direction u (body frame, towards the source) reaches element p_k at
δ_k = t0 − p_k·u / c, and near its peak c_k(δ) ≈ A_k e^{j2π f0 (δ − δ_k)}.

1. Wideband (ambiguity-free): each channel's envelope peak |c_k| gives a
   coarse δ_k; a least-squares plane wave through them gives t0 and u.
2. Carrier phase: at the plane-wave lags, arg c_k turns the coarse delays
   into fine ones, δ_k = δ̂_k − arg(c_k)/(2π f0) (the common phase goes into
   t0); the carrier period (36 µs at 28 kHz) is resolved because the
   wideband step is within a fraction of it. Weighted Gauss–Newton on
   (t0, azimuth, elevation), repeated until the lags stop moving.
3. σ: the Cramér–Rao bound of this model at the measured per-channel SNR,
   cov = (Jᵀ W J)⁻¹, W_k = 2 |c_k|² (2π)² (f0² + β²) / σ²_{c,k} with σ²_{c,k}
   the noise variance of c_k from the noise just before the frame (the
   envelope's share, β²/f0² ≈ 0.5 %, is counted in the bound), inflated by
   the fit's misfit when its χ² exceeds its degrees of freedom.

Combining: each channel is advanced by its direct-path lag and weighted by
conj(c_k)/σ²_{c,k} (maximal-ratio combining), scaled so that the combined
noise level equals the reference channel's; the single-hydrophone receiver
then measures and decodes the combined frame.

Array geometry and angles: :mod:`seamodem.channel.array` (body frame x
forward, y port, z up; azimuth atan2(u_y, u_x), elevation asin(u_z)). The
receiver uses the *nominal* element positions and removes the array's
``complex_gains`` (its calibration, :func:`calibrate_array`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from ..errors import ConfigError, InputFileError
from ..transmit.pilot import pilot_symbols
from .bounds import gabor_bandwidth_hz
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings

__all__ = [
    "ArrayCorrelation",
    "DoaEstimate",
    "array_correlation",
    "estimate_doa",
    "combine_channels",
    "receive_array",
    "calibrate_array",
    "receive_array_file",
    "unit_vector",
]

#: the correlation window extends this far beyond the pilot on each side [s]
WINDOW_MARGIN_S = 0.007
#: noise is measured over this window, ending this long before the frame start [s]
NOISE_SEGMENT_S, NOISE_GAP_S = 0.03, 0.001
#: echoes are looked for up to ECHO_SEARCH_S after the direct path, at most MAX_ECHOES per channel, while
#: their correlation exceeds ECHO_FRACTION of the direct path's (the pilot's sidelobes are modelled, not searched)
ECHO_SEARCH_S, MAX_ECHOES, ECHO_FRACTION = 0.006, 4, 0.05
#: Gauss–Newton iterations at most, and the lag change [s] under which they stop
MAX_ITERATIONS, LAG_TOLERANCE_S = 8, 1e-9


def unit_vector(azimuth_rad, elevation_rad) -> np.ndarray:
    """u = (cos e cos a, cos e sin a, sin e), shape (..., 3)."""
    a, e = np.asarray(azimuth_rad, float), np.asarray(elevation_rad, float)
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


def _pilot_reference(config: FrameConfig, pilot: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """Analytic passband pilot b(τ) e^{j2π f0 τ} at frame times τ [s] (zero outside the pilot)."""
    from ..transmit.pulse import srrc_matrix

    T = config.symbol_period_s
    tk = (config.n_guard + np.arange(config.n_pilot)) * T
    g = srrc_matrix(tau_s, tk, symbol_period_s=T, rolloff=config.rolloff, span_symbols=config.srrc_span_symbols)
    return (g @ np.asarray(pilot, complex)) * np.exp(2j * np.pi * config.carrier_hz * tau_s)


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
    """

    spectra: np.ndarray
    freqs_hz: np.ndarray
    noise_var: np.ndarray
    t_arrival_s: float
    kernel: np.ndarray
    n_fft: int

    @property
    def energy(self) -> float:
        """c(0) of a unit path at lag 0: Σ kernel."""
        return float(np.sum(self.kernel))

    def without(self, lags_s: np.ndarray, amplitudes: np.ndarray) -> ArrayCorrelation:
        """The correlations with paths (n_channels, n_paths) of those lags and amplitudes removed."""
        lags = np.atleast_2d(np.asarray(lags_s, float).T).T
        amps = np.atleast_2d(np.asarray(amplitudes, complex).T).T
        model = np.einsum("kp,kpm->km", amps, np.exp(-2j * np.pi * lags[:, :, None] * self.freqs_hz[None, None, :]))
        return dataclasses.replace(self, spectra=self.spectra - model * self.kernel[None, :])

    def on_sample_grid(self, fs: float) -> np.ndarray:
        """c_k at lags i/fs, i = 0 … N−1 (circular: the last ones are negative lags), shape (n_channels, N)."""
        full = np.zeros((self.spectra.shape[0], self.n_fft), complex)
        full[:, np.rint(self.freqs_hz * self.n_fft / fs).astype(int)] = self.spectra
        return np.fft.ifft(full, axis=1) * self.n_fft

    def at(self, lags_s: np.ndarray) -> np.ndarray:
        """c_k(δ_k) for one lag per channel (shape (n_channels,)) or a grid (n_channels, n_lags)."""
        lags = np.asarray(lags_s, float)
        if lags.ndim == 1:
            return np.einsum("km,km->k", self.spectra, np.exp(2j * np.pi * lags[:, None] * self.freqs_hz[None, :]))
        return np.einsum("km,klm->kl", self.spectra, np.exp(2j * np.pi * lags[:, :, None] * self.freqs_hz[None, None, :]))


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
    """Pilot correlations c_k of one frame (module docstring).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels; row i at time t0_s + i/fs [s].
    t_arrival_s : float
        Frame start arrival on the reference channel [s] (lag 0).
    v_mps : float
        Closing speed the reference is scaled by [m/s].
    complex_gains : numpy.ndarray, shape (n_channels,), optional
        Known channel gains (calibration), divided out.

    Raises
    ------
    ConfigError
        The recording does not hold the frame's pilot.
    """
    x = np.asarray(x, float)
    scale = 1.0 + v_mps / sound_speed_mps
    T = config.symbol_period_s
    half = config.srrc_span_symbols // 2
    tau_a = (config.n_guard - half) * T
    tau_b = (config.n_guard + config.n_pilot - 1 + half) * T
    i0 = math.floor((t_arrival_s + tau_a / scale - WINDOW_MARGIN_S - t0_s) * fs)
    i1 = math.ceil((t_arrival_s + tau_b / scale + WINDOW_MARGIN_S - t0_s) * fs)
    if i0 < 0 or i1 > x.shape[0]:
        raise ConfigError("t_arrival_s", f"the frame's pilot at {t_arrival_s:.4f} s is not inside the recording")
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
    j1 = math.floor((t_arrival_s - NOISE_GAP_S - t0_s) * fs)
    j0 = j1 - round(NOISE_SEGMENT_S * fs)
    if j0 < 0:  # the frame starts the recording: measure after its pilot's window instead
        j0 = i1 + round(0.5 * config.frame_duration_s * fs)
        j0 = max(i1, min(j0, x.shape[0] - round(NOISE_SEGMENT_S * fs)))
        j1 = j0 + round(NOISE_SEGMENT_S * fs)
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
    return ArrayCorrelation(spectra, freqs, noise_var, float(t_arrival_s), np.abs(R) ** 2 / n, n)


@dataclass(frozen=True)
class DoaEstimate:
    """Direct path's direction of arrival on one frame (body frame of the array's positions).

    Attributes
    ----------
    azimuth_rad, elevation_rad : float
    sigma_azimuth_rad, sigma_elevation_rad : float
        CRLB-based standard deviations (module docstring, step 3).
    covariance : numpy.ndarray, shape (3, 3)
        Of (t0, azimuth, elevation).
    t0_s : float
        Lag of the body origin [s]; the channels' common phase goes into it too,
        so only the differences ``lags_s − t0_s`` are geometric.
    lags_s : numpy.ndarray, shape (n_channels,)
        Fitted plane-wave lag of each channel [s].
    amplitudes : numpy.ndarray, shape (n_channels,), complex
        c_k at those lags.
    snr : numpy.ndarray, shape (n_channels,)
        |c_k|² / σ²_{c,k}, post-correlation SNR of each channel.
    chi2 : float
        Weighted misfit of the fine lags (n_channels − 3 degrees of freedom).
    coarse_azimuth_rad, coarse_elevation_rad : float
        The wideband (step 1) estimate.
    n_echoes : int
        Later paths removed per channel before the final fit (step 2b).
    """

    azimuth_rad: float
    elevation_rad: float
    sigma_azimuth_rad: float
    sigma_elevation_rad: float
    covariance: np.ndarray
    t0_s: float
    lags_s: np.ndarray
    amplitudes: np.ndarray
    snr: np.ndarray
    chi2: float
    coarse_azimuth_rad: float
    coarse_elevation_rad: float
    n_echoes: int = 0


def _check_positions(positions_m: np.ndarray) -> np.ndarray:
    p = np.asarray(positions_m, float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 4:
        raise ConfigError("array", f"direction finding needs >= 4 element positions (n, 3), got shape {p.shape}")
    if np.linalg.matrix_rank(p[1:] - p[0], tol=1e-6) < 3:
        raise ConfigError("array", "direction finding needs elements that are not all in one plane "
                                   "(azimuth and elevation both unambiguous), e.g. the 'tetra' array")
    return p


def _coarse_lags(corr: ArrayCorrelation, max_lag_s: float, fs_grid: float = 1e6) -> np.ndarray:
    """Each channel's envelope peak |c_k| within ±max_lag_s [s], refined by a parabola."""
    grid = np.arange(-max_lag_s, max_lag_s + 0.5 / fs_grid, 1.0 / fs_grid)
    mag = np.abs(corr.at(np.broadcast_to(grid, (corr.spectra.shape[0], grid.size))))
    out = np.empty(mag.shape[0])
    for k, m in enumerate(mag):
        i = int(np.clip(np.argmax(m), 1, grid.size - 2))
        a, b, c = m[i - 1], m[i], m[i + 1]
        den = a - 2 * b + c
        out[k] = grid[i] + (0.5 * (a - c) / den / fs_grid if den < 0 else 0.0)
    return out


#: post-correlation SNR cap: a noiseless input (synthetic tests) still gives finite weights
MAX_SNR = 1e12


def _snr(amp: np.ndarray, noise_var: np.ndarray) -> np.ndarray:
    """|c_k|² / σ²_{c,k}, capped at MAX_SNR."""
    power = np.abs(amp) ** 2
    return power / np.maximum(noise_var, power / MAX_SNR)


def _jacobian(positions_m: np.ndarray, az: float, el: float, c: float) -> np.ndarray:
    """∂δ_k/∂(t0, az, el) for δ_k = t0 − p_k·u(az, el)/c, shape (n, 3)."""
    du_da = np.array([-math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), 0.0])
    du_de = np.array([-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)])
    return np.column_stack([np.ones(len(positions_m)), -positions_m @ du_da / c, -positions_m @ du_de / c])


def estimate_doa(
    corr: ArrayCorrelation,
    positions_m: np.ndarray,
    *,
    config: FrameConfig,
    sound_speed_mps: float,
    v_mps: float = 0.0,
    position_sigma_m: float = 0.0,
) -> DoaEstimate:
    """The direct path's direction of arrival from one frame's correlations (module docstring).

    Parameters
    ----------
    corr : ArrayCorrelation
    positions_m : numpy.ndarray, shape (n_channels, 3)
        Element positions in the body frame [m]; not all in one plane.
    config : FrameConfig
        Carrier f0 and the pilot's Gabor bandwidth β.
    sound_speed_mps : float
    v_mps : float
        Closing speed [m/s]: the carrier the phases turn at is f0 (1 + v/c).
    position_sigma_m : float
        Std of each element's true position about the nominal one, per axis [m]:
        adds (σ_p/c)² to every element's delay variance in the weights and in σ
        (a 1 mm uncertainty is worth ≈ 1° on an 8 cm array; not in the CRLB proper).

    Returns
    -------
    DoaEstimate
    """
    p = _check_positions(positions_m)
    c = sound_speed_mps
    f0 = config.carrier_hz * (1.0 + v_mps / c)
    aperture = float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1)))
    # around the first arrival only: an echo a symbol or two later must stay out of the search
    coarse = _coarse_lags(corr, aperture / c + 0.25 / config.symbol_rate_hz)
    # step 1: unconstrained plane wave δ = t0 − p·w, u = w / |w|
    A = np.column_stack([np.ones(len(p)), -p])
    sol = np.linalg.lstsq(A, coarse, rcond=None)[0]
    w = sol[1:]
    az0, el0 = math.atan2(w[1], w[0]), math.asin(float(np.clip(w[2] / max(np.linalg.norm(w), 1e-300), -1, 1)))
    theta = np.array([float(np.mean(coarse + p @ unit_vector(az0, el0) / c)), az0, el0])
    theta = _fit_plane_wave(corr, p, theta, c, f0, position_sigma_m / c)
    # step 2b: echoes resolved from the direct path (> 3/4 symbol later) are fitted per channel and removed,
    # so that their pilot sidelobes do not pull the direct path's phases; then the fit again
    lags = theta[0] - p @ unit_vector(theta[1], theta[2]) / c
    echo_lags, echo_amps = _echoes(corr, lags, corr.at(lags) / corr.energy, fs=fs_of(corr),
                                   after_s=0.75 / config.symbol_rate_hz)
    if echo_lags.size:
        corr = corr.without(echo_lags, echo_amps)
        theta = _fit_plane_wave(corr, p, theta, c, f0, position_sigma_m / c)
    lags = theta[0] - p @ unit_vector(theta[1], theta[2]) / c
    amp = corr.at(lags)
    ref = np.sum(amp * np.abs(amp))
    resid = -np.angle(amp * np.conj(ref)) / (2 * np.pi * f0)
    snr = _snr(amp, corr.noise_var)
    beta = gabor_bandwidth_hz(config.symbol_rate_hz, config.rolloff)
    fisher_w = 1.0 / (1.0 / (2.0 * snr * (2 * np.pi) ** 2 * (f0**2 + beta**2)) + (position_sigma_m / c) ** 2)
    J = _jacobian(p, theta[1], theta[2], c)
    cov = np.linalg.inv(J.T @ (fisher_w[:, None] * J))
    dof = len(p) - 3
    r = resid - np.sum(fisher_w * resid) / np.sum(fisher_w)  # the common phase is t0's
    chi2 = float(np.sum(fisher_w * r**2))
    if dof > 0 and chi2 > dof:
        cov = cov * (chi2 / dof)
    az = float(math.remainder(theta[1], 2 * math.pi))
    return DoaEstimate(
        azimuth_rad=az,
        elevation_rad=float(theta[2]),
        sigma_azimuth_rad=float(math.sqrt(cov[1, 1])),
        sigma_elevation_rad=float(math.sqrt(cov[2, 2])),
        covariance=cov,
        t0_s=float(theta[0]),
        lags_s=lags,
        amplitudes=amp,
        snr=snr,
        chi2=chi2,
        coarse_azimuth_rad=az0,
        coarse_elevation_rad=el0,
        n_echoes=int(echo_lags.shape[1]) if echo_lags.size else 0,
    )


def fs_of(corr: ArrayCorrelation) -> float:
    """Sample rate of the correlation window [Hz] (bin spacing × N)."""
    return float(corr.freqs_hz[1] - corr.freqs_hz[0]) * corr.n_fft


def _echoes(corr: ArrayCorrelation, direct_lags: np.ndarray, direct_amps: np.ndarray, *, fs: float,
            after_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Per channel, the strongest later paths of the residual (direct path removed): lags and amplitudes
    (n_channels, n_echoes), greedy (CLEAN): the peak, refined by a parabola on |c| and its amplitude c/E,
    removed, and again, while above ECHO_FRACTION of the direct path and 4.5 σ of noise."""
    res = corr.without(direct_lags, direct_amps)
    n_ch = corr.spectra.shape[0]
    lags = np.zeros((n_ch, MAX_ECHOES))
    amps = np.zeros((n_ch, MAX_ECHOES), complex)
    found = 0
    for j in range(MAX_ECHOES):
        grid = res.on_sample_grid(fs)
        i_lo = int(math.ceil((np.max(direct_lags) + after_s) * fs))
        i_hi = int(math.floor((np.min(direct_lags) + ECHO_SEARCH_S) * fs))
        if i_hi <= i_lo + 2:
            break
        seg = np.abs(grid[:, i_lo:i_hi])
        i = np.clip(np.argmax(seg, axis=1), 1, seg.shape[1] - 2)
        a, b, cc = (seg[np.arange(n_ch), i + d] for d in (-1, 0, 1))
        den = a - 2 * b + cc
        frac = np.where(den < 0, 0.5 * (a - cc) / np.where(den < 0, den, -1.0), 0.0)
        lag = (i_lo + i + frac) / fs
        c_val = res.at(lag)
        strong = (np.abs(c_val) > ECHO_FRACTION * np.abs(direct_amps) * corr.energy) & (np.abs(c_val) ** 2 > 20 * corr.noise_var)
        if not np.any(strong):
            break
        amp = np.where(strong, c_val / corr.energy, 0.0)
        lags[:, j], amps[:, j] = lag, amp
        res = res.without(lag, amp)
        found = j + 1
    return lags[:, :found], amps[:, :found]


def _fit_plane_wave(corr: ArrayCorrelation, p: np.ndarray, theta: np.ndarray, c: float, f0: float,
                    sigma_p_s: float = 0.0) -> np.ndarray:
    """Step 2: fine lags from the carrier phase at the plane-wave lags, weighted Gauss–Newton on (t0, az, el)."""
    theta = np.array(theta, float)
    for _ in range(MAX_ITERATIONS):
        lags = theta[0] - p @ unit_vector(theta[1], theta[2]) / c
        amp = corr.at(lags)
        ref = np.sum(amp * np.abs(amp))  # common phase, weighted towards the strong channels
        fine = lags - np.angle(amp * np.conj(ref)) / (2 * np.pi * f0)
        snr = _snr(amp, corr.noise_var)
        wts = 1.0 / (1.0 / (2.0 * snr * (2 * np.pi * f0) ** 2) + (sigma_p_s) ** 2)
        J = _jacobian(p, theta[1], theta[2], c)
        step = np.linalg.solve(J.T @ (wts[:, None] * J), J.T @ (wts * (fine - lags)))
        theta = theta + step
        theta[2] = float(np.clip(theta[2], -0.5 * np.pi, 0.5 * np.pi))
        if np.max(np.abs(J @ step)) < LAG_TOLERANCE_S:
            break
    return theta


def combine_channels(
    x: np.ndarray,
    fs: float,
    lags_s: np.ndarray,
    weights: np.ndarray,
    *,
    complex_gains: np.ndarray | None = None,
) -> np.ndarray:
    """Σ_k Re[w_k · analytic(x_k)(t + δ_k)]: channels advanced by their lags and weighted (real passband out).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
    lags_s : numpy.ndarray, shape (n_channels,)
        Each channel's delay of the wanted path [s].
    weights : numpy.ndarray, shape (n_channels,), complex
        Combining weights on the analytic signals (MRC: conj(c_k)/σ²_k).
    complex_gains : numpy.ndarray, optional
        Known channel gains, divided out first.
    """
    n = x.shape[0]
    f = np.fft.rfftfreq(n, 1.0 / fs)
    w = np.asarray(weights, complex)
    if complex_gains is not None:
        w = w / np.asarray(complex_gains)
    spec = np.fft.rfft(x, axis=0) * (w[None, :] * np.exp(2j * np.pi * f[:, None] * np.asarray(lags_s)[None, :]))
    return np.fft.irfft(np.sum(spec, axis=1), n)


#: frames are combined over [t_a − PAD, t_a + T_F/(1 + v/c) + PAD], joined to the reference channel by ramps
COMBINE_PAD_S, COMBINE_RAMP_S = 0.08, 0.01


def receive_array(
    x: np.ndarray,
    fs: float,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    emissions: Emissions,
    settings: ReceiverSettings | None = None,
    complex_gains: np.ndarray | None = None,
    reference_channel: int = 0,
    position_sigma_m: float = 0.0,
    combine: bool = True,
    payloads=None,
    pilot: np.ndarray | None = None,
) -> tuple[list[MeasurementRecord], list[DoaEstimate | None]]:
    """Measurement records with the direct path's direction of arrival, from a multichannel recording.

    1. The single-hydrophone receiver detects and measures every frame on
       ``reference_channel`` (no decoding).
    2. Per frame: :func:`array_correlation`, :func:`estimate_doa`.
    3. ``combine``: maximal-ratio combining of the frame (module docstring)
       spliced into the reference channel, and the single-hydrophone
       receiver run again on it (with the ``settings``' decoding): the
       records' range (to the array's body origin), Doppler, SNR and payload
       come from the combined channels. Otherwise they are the reference
       channel's (range to that element).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels at ``fs`` [Hz].
    positions_m : numpy.ndarray, shape (n_channels, 3)
        Nominal element positions in the body frame [m].
    complex_gains : numpy.ndarray, optional
        Channel calibration (:func:`calibrate_array`), divided out.
    position_sigma_m : float
        Uncertainty of the nominal element positions [m] (:func:`estimate_doa`).

    Returns
    -------
    records : list of MeasurementRecord
        With ``azimuth_body_rad``, ``elevation_body_rad``, their σ's and
        ``n_channels`` filled; a frame whose pilot the recording cuts keeps
        the reference channel's record (NaN direction, ``n_channels`` 1).
    doas : list of DoaEstimate or None
        One per record (None without a direction).
    """
    from .stream import Receiver

    x = np.asarray(x, float)
    if x.ndim != 2 or x.shape[1] < 2:
        raise InputFileError(f"a receiver array needs a multichannel recording, got shape {x.shape}")
    positions_m = _check_positions(positions_m)
    if positions_m.shape[0] != x.shape[1]:
        raise ConfigError("array", f"{positions_m.shape[0]} element positions for a recording of {x.shape[1]} channels")
    s = ReceiverSettings() if settings is None else settings
    c = s.sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    first = list(Receiver(config, emissions=emissions, settings=dataclasses.replace(s, decode=False), pilot=pilot)
                 .run([x[:, reference_channel]], fs=fs))
    doas, used = [], []
    for rec in first:
        try:
            corr = array_correlation(x, fs, config=config, pilot=pilot, t_arrival_s=rec.t_arrival_s,
                                     v_mps=rec.v_r_bank_mps, sound_speed_mps=c, complex_gains=complex_gains)
        except ConfigError:
            continue  # the pilot is cut by the recording's edge: no direction
        doas.append(estimate_doa(corr, positions_m, config=config, sound_speed_mps=c, v_mps=rec.v_r_bank_mps,
                                 position_sigma_m=position_sigma_m))
        used.append(rec)
    if combine and doas:
        y = x[:, reference_channel].copy()
        ref_var = None
        for rec, d in zip(used, doas):
            scale = 1.0 + rec.v_r_mps / c if math.isfinite(rec.v_r_mps) else 1.0
            i0 = max(0, math.floor((rec.t_arrival_s - COMBINE_PAD_S) * fs))
            i1 = min(x.shape[0], math.ceil((rec.t_arrival_s + config.frame_duration_s / scale + COMBINE_PAD_S) * fs))
            noise = np.abs(d.amplitudes) ** 2 / d.snr
            w = np.conj(d.amplitudes) / noise
            ref_var = noise[reference_channel]
            w = w * math.sqrt(ref_var / np.sum(np.abs(w) ** 2 * noise))  # combined noise level = the reference's
            # each channel to the body origin's time (lags − t0 = −p·u/c): the combined frame's range is the origin's
            beam = combine_channels(x[i0:i1], fs, d.lags_s - d.t0_s, w, complex_gains=complex_gains)
            ramp = np.ones(i1 - i0)
            nr = min(round(COMBINE_RAMP_S * fs), (i1 - i0) // 2)
            edge = np.sin(0.5 * np.pi * (np.arange(nr) + 0.5) / nr)  # power-preserving cross-fade (independent noises)
            ramp[:nr], ramp[-nr:] = edge, edge[::-1]
            y[i0:i1] = ramp * beam + np.sqrt(1.0 - ramp**2) * y[i0:i1]
        second = list(Receiver(config, emissions=emissions, settings=s, pilot=pilot, payloads=payloads).run([y], fs=fs))
    else:
        second = first
    records = []
    out_doas: list[DoaEstimate | None] = []
    for rec in second:
        j = int(np.argmin([abs(u.t_arrival_s - rec.t_arrival_s) for u in used])) if used else -1
        if j < 0 or abs(used[j].t_arrival_s - rec.t_arrival_s) > 0.01:
            records.append(rec)  # no direction (pilot cut by the recording's edge): one hydrophone's record
            out_doas.append(None)
            continue
        d = doas[j]
        records.append(dataclasses.replace(
            rec, azimuth_body_rad=d.azimuth_rad, elevation_body_rad=d.elevation_rad,
            sigma_azimuth_body_rad=d.sigma_azimuth_rad, sigma_elevation_body_rad=d.sigma_elevation_rad,
            n_channels=int(x.shape[1])))
        out_doas.append(d)
    return records, out_doas


def calibrate_array(
    x: np.ndarray,
    fs: float,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    arrivals_s,
    directions_body_rad,
    v_mps=None,
    sound_speed_mps: float,
    pilot: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Channel gain [dB] and phase [rad] offsets from frames whose direction is known.

    For each frame the plane wave's lags are those of the known body-frame
    direction (the common arrival t0 fitted on the envelope); c_k / c_0 at
    those lags is channel k's complex gain relative to channel 0. Gains are
    averaged over frames weighted by their SNR.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
    positions_m : numpy.ndarray, shape (n_channels, 3)
        Element positions in the body frame [m].
    arrivals_s : sequence of float
        Each frame's arrival (e.g. a receiver's ``t_arrival_s``) [s].
    directions_body_rad : sequence of (azimuth, elevation)
        The direct path's known direction for each frame [rad].
    v_mps : sequence of float, optional
        Closing speeds [m/s] (default 0).

    Returns
    -------
    gain_db, phase_rad : numpy.ndarray, shape (n_channels,)
        Channel 0 is the reference (0 dB, 0 rad): give them to
        :class:`~seamodem.channel.array.ReceiverArray` (or ``complex_gains``
        10^(g/20)·e^{jφ}) for the receiver to remove.
    """
    p = np.asarray(positions_m, float)
    c = sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    arrivals = np.atleast_1d(np.asarray(arrivals_s, float))
    dirs = np.asarray(directions_body_rad, float).reshape(-1, 2)
    v = np.zeros(arrivals.size) if v_mps is None else np.asarray(v_mps, float).reshape(-1)
    if not (len(dirs) == arrivals.size == v.size) or arrivals.size == 0:
        raise ConfigError("directions_body_rad", "needs one direction (and speed) per arrival, at least one")
    acc = np.zeros(p.shape[0], complex)
    total = 0.0
    for t_a, (az, el), vk in zip(arrivals, dirs, v):
        corr = array_correlation(x, fs, config=config, pilot=pilot, t_arrival_s=t_a, v_mps=vk, sound_speed_mps=c)
        rel = -p @ unit_vector(az, el) / c
        coarse = _coarse_lags(corr, float(np.max(np.abs(rel))) + 0.25 / config.symbol_rate_hz)
        t0 = float(np.mean(coarse - rel))
        amp = corr.at(t0 + rel)
        ratio = amp / amp[0]
        weight = np.abs(amp[0]) ** 2 / corr.noise_var[0]
        acc += weight * ratio
        total += weight
    g = acc / total
    return 20.0 * np.log10(np.abs(g)), np.angle(g)


def receive_array_file(
    path,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    emissions: Emissions,
    settings: ReceiverSettings | None = None,
    complex_gains: np.ndarray | None = None,
    position_sigma_m: float = 0.0,
    pilot: np.ndarray | None = None,
    payloads=None,
) -> list[MeasurementRecord]:
    """:func:`receive_array` on a multichannel audio file (one channel per element, read whole).

    Raises
    ------
    InputFileError
        Unreadable file, or fewer channels than elements.
    """
    import soundfile

    from ..io.wav import wav_info

    info = wav_info(path)
    n_el = np.asarray(positions_m).shape[0]
    if info.channels != n_el:
        raise InputFileError(f"{path}: has {info.channels} channel(s), the array {n_el} elements")
    x, fs = soundfile.read(str(path), dtype="float64", always_2d=True)
    if not np.all(np.isfinite(x)):
        raise InputFileError(f"{path}: holds NaN or infinite samples")
    records, _ = receive_array(x, float(fs), config, positions_m, emissions=emissions, settings=settings,
                               complex_gains=complex_gains, position_sigma_m=position_sigma_m, pilot=pilot,
                               payloads=payloads)
    return records
