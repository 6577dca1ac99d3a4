"""Multichannel reception: direction of arrival per frame and maximal-ratio combining (issue 17).

:func:`receive_array` takes every channel through the receiver's front end,
detects on all channels at once (:class:`ArrayDetector`) and, per frame,
correlates every channel with the frame's pilot as an *analytic passband*
waveform, Doppler-scaled by the detection's speed (on the decimated basebands,
:func:`baseband_correlation`; :func:`array_correlation` is the same on
passband samples):

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

Combining: each channel's baseband is advanced by its direct-path lag and
weighted by conj(c_k)/σ²_{c,k} (maximal-ratio combining), scaled so that the
combined noise level equals the reference channel's; the single-hydrophone
receiver's measurement and decoding then run once on the combined frame.

Flat and linear arrays (:func:`array_geometry`): the mirror image through a
flat array's plane, or the cone about a line, fits as well as the truth; an
assumption (beacon below the plane; beacon to port at elevation 0) picks one,
and the estimate states it (``DoaEstimate.ambiguity``).

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
from numba import njit

from ..config import FrameConfig
from ..errors import ConfigError, InputFileError
from ..transmit.pilot import pilot_symbols
from .bounds import gabor_bandwidth_hz
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings

__all__ = [
    "ArrayCorrelation",
    "ArrayDetector",
    "ArrayGeometry",
    "DoaEstimate",
    "array_geometry",
    "baseband_correlation",
    "blank_like_reference",
    "front_end_array",
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


def _pilot_envelope(config: FrameConfig, pilot: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """Pilot envelope b(τ) = Σ a_k g(τ − (Ng + k)T) at frame times τ [s] (zero outside the pilot)."""
    from ..transmit.pulse import srrc_matrix

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
        """The correlations with paths (n_channels, n_paths) of those lags and amplitudes removed."""
        lags = np.atleast_2d(np.asarray(lags_s, float).T).T
        amps = np.atleast_2d(np.asarray(amplitudes, complex).T).T
        model = np.einsum("kp,kpm->km", amps, np.exp(-2j * np.pi * lags[:, :, None] * self.freqs_hz[None, None, :]))
        return dataclasses.replace(self, spectra=self.spectra - model * self.kernel[None, :])

    def on_sample_grid(self, fs: float) -> np.ndarray:
        """|c_k| at lags i/fs, i = 0 … N−1 (circular: the last ones are negative lags), shape (n_channels, N).

        The bins are placed relative to the lowest one (a baseband window's
        frequencies are offset by the carrier), so only the magnitude is c_k's.
        """
        full = np.zeros((self.spectra.shape[0], self.n_fft), complex)
        full[:, np.rint((self.freqs_hz - self.freqs_hz[0]) * self.n_fft / fs).astype(int) % self.n_fft] = self.spectra
        return np.abs(np.fft.ifft(full, axis=1)) * self.n_fft

    def at(self, lags_s: np.ndarray) -> np.ndarray:
        """c_k(δ_k) for one lag per channel (shape (n_channels,)) or a grid (n_channels, n_lags)."""
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
    ambiguity : str
        For a flat or linear array, the assumption that resolved its ambiguity ("" otherwise).
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
    ambiguity: str = ""


#: a flat array's normal (a line's axis) must be this far from horizontal (vertical) for the stated assumption
MIN_AXIS_COMPONENT = 0.2


@dataclass(frozen=True, eq=False)
class ArrayGeometry:
    """What an array's element positions can measure, and the assumption that completes it.

    Attributes
    ----------
    positions_m : numpy.ndarray, shape (n, 3)
    kind : str
        "volume" (azimuth and elevation unambiguous), "planar" (the direction's
        component along the plane's normal is known up to its sign: the mirror
        image through the plane fits equally well) or "linear" (only the angle
        to the line is measured: every direction on a cone about it fits).
    axis : numpy.ndarray, shape (3,)
        Planar: the plane's unit normal, oriented upwards (n_z > 0). Linear: the
        line's unit direction (horizontal). Volume: zeros.
    assume : str
        Planar: "below" (default) or "above": the side of the plane the beacon is on.
        Linear: "port" (default) or "starboard" of the line, and elevation 0.
    """

    positions_m: np.ndarray
    kind: str
    axis: np.ndarray
    assume: str = ""

    @property
    def ambiguity(self) -> str:
        """One line: the ambiguity and how it is resolved ("" for a volume array)."""
        if self.kind == "planar":
            return (f"flat array: the elevation's sign is not measured; the beacon is assumed {self.assume} "
                    "the array's plane (its mirror image through the plane fits equally well)")
        if self.kind == "linear":
            return ("linear array: only the angle to the line is measured (a cone about it); the beacon is assumed "
                    f"on its {self.assume} side at elevation 0, elevation not reported")
        return ""


_ASSUMPTIONS = {"planar": ("below", "above"), "linear": ("port", "starboard")}


def array_geometry(positions_m, assume: str | None = None) -> ArrayGeometry:
    """Classify element positions for direction finding (volume, planar, linear) and check the assumption.

    Raises
    ------
    ConfigError
        Too few elements, coincident elements, a flat array standing vertically
        or a line that is not horizontal (their ambiguity is not about the
        elevation's sign or the side), or an assumption the geometry does not take.
    """
    p = np.asarray(positions_m, float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
        raise ConfigError("array", f"direction finding needs >= 2 element positions (n, 3), got shape {p.shape}")
    centred = p - p.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred)
    rank = int(np.sum(sv > 1e-6 * max(sv[0], 1e-300))) if sv[0] > 1e-9 else 0
    kind = {3: "volume", 2: "planar", 1: "linear"}.get(rank)
    if kind is None:
        raise ConfigError("array", "direction finding needs elements at distinct positions")
    if kind == "volume":
        if p.shape[0] < 4:
            raise ConfigError("array", f"a volume array needs >= 4 elements, got {p.shape[0]}")
        if assume not in (None, ""):
            raise ConfigError("array", f"assume={assume!r}: this array measures azimuth and elevation "
                                       "unambiguously (no assumption to make)")
        return ArrayGeometry(p, kind, np.zeros(3), "")
    choices = _ASSUMPTIONS[kind]
    a = choices[0] if assume in (None, "") else str(assume)
    if a not in choices:
        raise ConfigError("array", f"assume={assume!r}: a {kind} array takes one of {', '.join(choices)}")
    if kind == "planar":
        n = vt[2] if vt[2][2] >= 0 else -vt[2]
        if n[2] < MIN_AXIS_COMPONENT:
            raise ConfigError("array", "a flat array standing (nearly) vertically: its mirror ambiguity is "
                                       "fore/aft or port/starboard, not the elevation's sign; not supported "
                                       "(use a horizontal flat array or a volume array such as 'tetra')")
        if p.shape[0] < 3:
            raise ConfigError("array", "a flat array needs >= 3 elements")
        return ArrayGeometry(p, kind, n, a)
    d = vt[0]
    if abs(d[2]) > MIN_AXIS_COMPONENT:
        raise ConfigError("array", "a linear array that is not (nearly) horizontal is not supported: "
                                   "its cone does not map to a body azimuth under the elevation-0 assumption")
    d = np.array([d[0], d[1], 0.0])
    d = d / np.linalg.norm(d)
    return ArrayGeometry(p, kind, d, a)


def _check_positions(positions_m: np.ndarray, assume: str | None = None) -> np.ndarray:
    return array_geometry(positions_m, assume).positions_m


def _coarse_lags(corr: ArrayCorrelation, max_lag_s: float, fs_grid: float = 2.5e5) -> np.ndarray:
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
    assume: str | None = None,
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
    assume : str, optional
        A flat array ("below" by default, or "above": the side of its plane the
        beacon is on; the fit's mirror image is taken when it lands on the other
        side) or a horizontal linear array ("port" by default, or "starboard",
        with elevation 0 assumed and NaN reported): :func:`array_geometry`.
        The estimate's ``ambiguity`` states it.

    Returns
    -------
    DoaEstimate
    """
    geom = array_geometry(positions_m, assume)
    p = geom.positions_m
    c = sound_speed_mps
    f0 = config.carrier_hz * (1.0 + v_mps / c)
    aperture = float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1)))
    # around the first arrival only: an echo a symbol or two later must stay out of the search
    coarse = _coarse_lags(corr, aperture / c + 0.25 / config.symbol_rate_hz)
    # step 1: unconstrained plane wave δ = t0 − p·w, u = w / |w|
    A = np.column_stack([np.ones(len(p)), -p])
    sol = np.linalg.lstsq(A, coarse, rcond=None)[0]
    w = sol[1:]
    model = _PlaneWave(geom, c)
    theta = model.start(coarse, c * w)
    theta = _fit_plane_wave(corr, model, theta, f0, position_sigma_m / c)
    # step 2b: echoes resolved from the direct path (> 3/4 symbol later) are fitted per channel and removed,
    # so that their pilot sidelobes do not pull the direct path's phases; then the fit again
    lags = model.lags(theta)
    echo_lags, echo_amps = _echoes(corr, lags, corr.at(lags) / corr.energy, fs=fs_of(corr),
                                   after_s=0.75 / config.symbol_rate_hz)
    if echo_lags.size:
        corr = corr.without(echo_lags, echo_amps)
        theta = _fit_plane_wave(corr, model, theta, f0, position_sigma_m / c)
    lags = model.lags(theta)
    amp = corr.at(lags)
    ref = np.sum(amp * np.abs(amp))
    resid = -np.angle(amp * np.conj(ref)) / (2 * np.pi * f0)
    snr = _snr(amp, corr.noise_var)
    beta = gabor_bandwidth_hz(config.symbol_rate_hz, config.rolloff)
    fisher_w = 1.0 / (1.0 / (2.0 * snr * (2 * np.pi) ** 2 * (f0**2 + beta**2)) + (position_sigma_m / c) ** 2)
    J = model.jacobian(theta)
    try:
        cov_theta = np.linalg.inv(J.T @ (fisher_w[:, None] * J))
    except np.linalg.LinAlgError:  # a direction the array cannot see
        cov_theta = np.full((len(theta), len(theta)), np.inf)
    dof = len(p) - len(theta)
    r = resid - np.sum(fisher_w * resid) / np.sum(fisher_w)  # the common phase is t0's
    chi2 = float(np.sum(fisher_w * r**2))
    if dof > 0 and chi2 > dof:
        cov_theta = cov_theta * (chi2 / dof)
    t0, az, el, G = model.angles(theta)
    cov = G @ cov_theta @ G.T  # of (t0, azimuth, elevation), first order
    if geom.kind == "planar":
        # near the plane the elevation follows |s| = cos e ≈ 1 − e²/2, not linearly: with |s| within 3σ of 1,
        # e is only known to within √(2σ_|s|) (and is 0 when noise puts |s| beyond 1)
        span = theta[1:]
        norm = float(np.linalg.norm(span))
        sigma_norm = math.sqrt(max(float(span @ cov_theta[1:, 1:] @ span) / max(norm, 1e-300) ** 2, 0.0))
        if 1.0 - norm < 3.0 * sigma_norm:
            cov[2, 2] = max(cov[2, 2], 2.0 * sigma_norm)
    az0, el0 = model.angles(model.start(coarse, c * w))[1:3]
    linear = geom.kind == "linear"
    return DoaEstimate(
        azimuth_rad=float(math.remainder(az, 2 * math.pi)),
        elevation_rad=math.nan if linear else float(el),
        sigma_azimuth_rad=float(math.sqrt(cov[1, 1])),
        sigma_elevation_rad=math.nan if linear else float(math.sqrt(cov[2, 2])),
        covariance=cov,
        t0_s=float(t0),
        lags_s=lags,
        amplitudes=amp,
        snr=snr,
        chi2=chi2,
        coarse_azimuth_rad=az0,
        coarse_elevation_rad=el0,
        n_echoes=int(echo_lags.shape[1]) if echo_lags.size else 0,
        ambiguity=geom.ambiguity,
    )


class _PlaneWave:
    """The plane-wave delay model δ_k = t0 − p_k·u/c in the parameters an array's geometry can measure.

    * volume: θ = (t0, azimuth, elevation);
    * planar: θ = (t0, s_1, s_2), u's components on an orthonormal basis of
      the plane (δ is linear in them: the fit cannot wander along the badly
      measured normal); u = Σ s_i e_i ± √(1 − |s|²) n, the sign the assumption's;
    * linear: θ = (t0, s), s = u·d = cos ψ on the line d; u at elevation 0 on
      the assumed side: cos ψ d ± sin ψ (ẑ × d).
    """

    def __init__(self, geom: ArrayGeometry, c: float):
        self.geom, self.c = geom, c
        p = geom.positions_m
        if geom.kind == "planar":
            n = geom.axis
            e1 = np.cross(n, [1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.cross(n, [0.0, 1.0, 0.0])
            e1 /= np.linalg.norm(e1)
            self.basis = np.stack([e1, np.cross(n, e1)])
        elif geom.kind == "linear":
            self.basis = geom.axis[None, :]
        else:
            self.basis = None
        self.q = None if self.basis is None else p @ self.basis.T  # element coordinates in the span

    def start(self, coarse: np.ndarray, u_fit: np.ndarray) -> np.ndarray:
        """θ from the coarse lags and the least-squares c·w."""
        p, c = self.geom.positions_m, self.c
        if self.basis is None:
            az, el = math.atan2(u_fit[1], u_fit[0]), math.asin(float(np.clip(u_fit[2] / max(np.linalg.norm(u_fit), 1e-300), -1, 1)))
            return np.array([float(np.mean(coarse + p @ unit_vector(az, el) / c)), az, el])
        s = self.basis @ u_fit
        norm = float(np.linalg.norm(s))
        if norm > 1.0:
            s = s / norm
        return np.array([float(np.mean(coarse + self.q @ s / c)), *s])

    def lags(self, theta: np.ndarray) -> np.ndarray:
        if self.basis is None:
            return theta[0] - self.geom.positions_m @ unit_vector(theta[1], theta[2]) / self.c
        return theta[0] - self.q @ theta[1:] / self.c

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        if self.basis is None:
            return _jacobian(self.geom.positions_m, theta[1], theta[2], self.c)
        return np.column_stack([np.ones(len(self.q)), -self.q / self.c])

    def clip(self, theta: np.ndarray) -> np.ndarray:
        if self.basis is None:
            theta[2] = float(np.clip(theta[2], -0.5 * np.pi, 0.5 * np.pi))
        return theta

    def _direction(self, s: np.ndarray) -> np.ndarray:
        g = self.geom
        norm = float(np.linalg.norm(s))
        if norm > 1.0:  # noise beyond a unit vector: the direction in the span
            s, norm = s / norm, 1.0
        if g.kind == "planar":
            side = -1.0 if g.assume == "below" else 1.0
            return self.basis.T @ s + side * math.sqrt(max(0.0, 1.0 - norm**2)) * g.axis
        d = g.axis
        side_dir = np.cross([0.0, 0.0, 1.0], d) * (1.0 if g.assume == "port" else -1.0)
        return float(s[0]) * d + math.sqrt(max(0.0, 1.0 - float(s[0]) ** 2)) * side_dir

    def angles(self, theta: np.ndarray):
        """(t0, azimuth, elevation, G): G = ∂(t0, az, el)/∂θ for the covariance (first order)."""
        if self.basis is None:
            return float(theta[0]), float(theta[1]), float(theta[2]), np.eye(3)

        def az_el(s):
            u = self._direction(s)
            return np.array([math.atan2(u[1], u[0]), math.asin(float(np.clip(u[2], -1, 1)))])

        s = np.asarray(theta[1:], float)
        ang = az_el(s)
        G = np.zeros((3, len(theta)))
        G[0, 0] = 1.0
        for i in range(len(s)):
            # a step towards the inside of the unit ball (the map has a kink at its edge, where the
            # normal component vanishes and the elevation's derivative grows without bound)
            h = 1e-6 * (-1.0 if s[i] > 0 else 1.0)
            ds = np.zeros(len(s))
            ds[i] = h
            diff = az_el(s + ds) - ang
            diff[0] = math.remainder(diff[0], 2 * math.pi)
            G[1:, 1 + i] = diff / h
        return float(theta[0]), float(ang[0]), float(ang[1]), G


def fs_of(corr: ArrayCorrelation) -> float:
    """Sample rate of the correlation window [Hz] (bin spacing × N)."""
    return corr.fs_hz


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


def _fit_plane_wave(corr: ArrayCorrelation, model: _PlaneWave, theta: np.ndarray, f0: float,
                    sigma_p_s: float = 0.0) -> np.ndarray:
    """Step 2: fine lags from the carrier phase at the plane-wave lags, weighted Gauss–Newton on θ."""
    theta = np.array(theta, float)
    for _ in range(MAX_ITERATIONS):
        lags = model.lags(theta)
        amp = corr.at(lags)
        ref = np.sum(amp * np.abs(amp))  # common phase, weighted towards the strong channels
        fine = lags - np.angle(amp * np.conj(ref)) / (2 * np.pi * f0)
        snr = _snr(amp, corr.noise_var)
        wts = 1.0 / (1.0 / (2.0 * snr * (2 * np.pi * f0) ** 2) + (sigma_p_s) ** 2)
        J = model.jacobian(theta)
        sw = np.sqrt(wts)
        step = np.linalg.lstsq(sw[:, None] * J, sw * (fine - lags), rcond=None)[0]
        theta = model.clip(theta + step)
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
#: the reference channel goes through the impulse blanker in blocks of this many samples
BLANKER_BLOCK = 1 << 16
#: the combined detector scans the basebands in chunks of this length [s] (bounded memory)
DETECTION_CHUNK_S = 10.0


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

    With x_pb = Re[x_bb e^{j2π fc t}] (:mod:`.frontend`), the analytic
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
    """

    def __init__(self, config: FrameConfig, fs: float, n_channels: int, **options):
        import scipy.special

        from .detect import PilotDetector

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
        """Every detection in the basebands bb (n, K), scanned in chunks of DETECTION_CHUNK_S."""
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


def _advance(seg: np.ndarray, fs: float, delays_s: np.ndarray, centre_hz: float) -> np.ndarray:
    """Basebands (n, K) of the passband channels advanced by delays_s: x_bb,k(t + δ_k) e^{j2π fc δ_k}."""
    f = np.fft.fftfreq(seg.shape[0], 1.0 / fs)
    d = np.asarray(delays_s, float)[None, :]
    return np.fft.ifft(np.fft.fft(seg, axis=0) * np.exp(2j * np.pi * f[:, None] * d), axis=0) * np.exp(
        2j * np.pi * centre_hz * d)


def _splice(y: np.ndarray, channels: np.ndarray, fs: float, centre_hz: float, t_from_s: float, t_to_s: float,
            delays_s: np.ndarray, weights: np.ndarray) -> None:
    """y[t_from, t_to] ← Σ_k w_k (channel k advanced by δ_k), cross-faded into y over COMBINE_RAMP_S."""
    i0, i1 = max(0, math.floor(t_from_s * fs)), min(len(y), math.ceil(t_to_s * fs))
    if i1 - i0 < 4:
        return
    beam = _advance(channels[i0:i1], fs, delays_s, centre_hz) @ weights
    ramp = np.ones(i1 - i0)
    nr = max(1, min(round(COMBINE_RAMP_S * fs), (i1 - i0) // 2))
    edge = np.sin(0.5 * np.pi * (np.arange(nr) + 0.5) / nr)  # power-preserving cross-fade (independent noises)
    ramp[:nr], ramp[-nr:] = edge, edge[::-1]
    y[i0:i1] = ramp * beam + np.sqrt(1.0 - ramp**2) * y[i0:i1]


def _blanked_stretches(x: np.ndarray, blanked_reference: np.ndarray, reference_channel: int,
                       spread_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """[start, stop) sample spans of the reference channel's blanked samples widened by ``spread_samples``."""
    hit = np.flatnonzero((blanked_reference == 0.0) & (x[:, reference_channel] != 0.0))
    if not hit.size:
        return hit, hit
    s = max(int(spread_samples), 0)
    new_run = np.flatnonzero(np.diff(hit) > 2 * s + 1) + 1  # widened stretches that do not touch the previous one
    starts = np.maximum(hit[np.concatenate([[0], new_run])] - s, 0)
    stops = np.minimum(hit[np.concatenate([new_run - 1, [hit.size - 1]])] + s + 1, x.shape[0])
    return starts, stops


def blank_like_reference(x: np.ndarray, blanked_reference: np.ndarray, reference_channel: int,
                         spread_samples: int) -> np.ndarray:
    """x with every channel zeroed where the reference channel was blanked, widened by ``spread_samples``.

    A click reaches elements a few centimetres apart within aperture/c of each
    other (5 samples for 8 cm at 96 kHz): the reference channel's blanked
    stretches, widened by that much on either side, cover it on every element.
    """
    starts, stops = _blanked_stretches(x, blanked_reference, reference_channel, spread_samples)
    if not starts.size:
        return x
    out = np.array(x, float)
    for a, b in zip(starts, stops):
        out[a:b] = 0.0
    return out


def front_end_array(x: np.ndarray, fs: float, config: FrameConfig, settings: ReceiverSettings,
                    reference_channel: int = 0, spread_samples: int = 8):
    """Basebands of every channel: (plan, bb (n, K), tone (n_t, K), blanker or None).

    Impulses are found on the reference channel and zeroed on every channel
    (:func:`blank_like_reference`, ``spread_samples`` either side): one
    blanker's cost, not K.
    """
    from .frontend import FrontEnd, plan_front_end
    from .impulse import ImpulseBlanker

    s = settings
    plan = plan_front_end(config, fs, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)
    blanker = None
    stretches = (np.zeros(0, int), np.zeros(0, int))
    if s.blank_impulses:
        blanker = ImpulseBlanker(threshold=s.impulse_threshold)
        ref = x[:, reference_channel]
        # in blocks, as the streaming receiver feeds it: the blanker's envelope pass runs only on the blocks
        # that hold an impulse (one push of the whole recording ran it over every sample: 0.2 s per 31 s)
        y0 = np.concatenate([*(blanker.push(ref[i:i + BLANKER_BLOCK]) for i in range(0, len(ref), BLANKER_BLOCK)),
                             blanker.flush()])
        if blanker.n_blanked:
            stretches = _blanked_stretches(x, y0, reference_channel, spread_samples)
    bbs, tones = [], []
    for k in range(x.shape[1]):
        fe = FrontEnd(plan)
        xk = np.array(x[:, k], float)  # contiguous (the front end copies it anyway)
        for i0, i1 in zip(*stretches):
            xk[i0:i1] = 0.0
        a, b = fe.push(xk)
        c, d = fe.flush()
        bbs.append(np.concatenate([a, c]))
        tones.append(np.concatenate([b, d]))
    return plan, np.stack(bbs, axis=1), np.stack(tones, axis=1), blanker


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
    assume: str | None = None,
) -> tuple[list[MeasurementRecord], list[DoaEstimate | None]]:
    """Measurement records with the direct path's direction of arrival, from a multichannel recording.

    One pass over the recording:

    1. every channel through the receiver's front end (impulses blanked as
       found on ``reference_channel``) to its decimated data and tone basebands;
    2. detection on all channels at once (:class:`ArrayDetector`: array gain
       at the single detector's false-alarm rate);
    3. per frame: :func:`baseband_correlation`, :func:`estimate_doa` at the
       detection's time and Doppler bin;
    4. ``combine``: maximal-ratio combining of the frame's basebands (module
       docstring) spliced into the reference channel's, and the
       single-hydrophone receiver's measurement and decoding
       (:class:`~seamodem.receive.stream.Receiver`, same settings) run once
       on it: range (to the array's body origin), Doppler, SNR and payload
       come from the combined channels. Otherwise from the reference
       channel's baseband (range to that element).

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
    assume : str, optional
        For a flat (planar) array, which side of its plane the beacon is:
        "below" or "above" (:func:`estimate_doa`).

    Returns
    -------
    records : list of MeasurementRecord
        With ``azimuth_body_rad``, ``elevation_body_rad``, their σ's and
        ``n_channels`` filled; a frame whose pilot the recording cuts keeps
        the reference channel's record (NaN direction, ``n_channels`` 1).
    doas : list of DoaEstimate or None
        One per record (None without a direction).
    """
    from .frame import BasebandBuffers, FrameMeasurer, one_blas_thread
    from .measure import NOISE_WINDOW_S

    x = np.asarray(x, float)
    if x.ndim != 2 or x.shape[1] < 2:
        raise InputFileError(f"a receiver array needs a multichannel recording, got shape {x.shape}")
    positions_m = _check_positions(positions_m, assume=assume)
    if positions_m.shape[0] != x.shape[1]:
        raise ConfigError("array", f"{positions_m.shape[0]} element positions for a recording of {x.shape[1]} channels")
    s = ReceiverSettings() if settings is None else settings
    c = s.sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    aperture_m = float(np.max(np.linalg.norm(positions_m[:, None] - positions_m[None], axis=-1)))
    spread = math.ceil(aperture_m / c * fs) + 1  # a click's spread over the elements [samples]
    # one BLAS thread for the whole pass (the per-frame work is many small products: receive/stream.py _one_blas_thread)
    with one_blas_thread():
        plan, bb, tone, blanker = front_end_array(x, fs, config, s, reference_channel, spread)
        if complex_gains is not None:
            g = np.asarray(complex_gains, complex)[None, :]
            bb, tone = bb / g, tone / g
        det = ArrayDetector(config, plan.fs_data, x.shape[1], v_max_mps=s.v_max_mps, sound_speed_mps=c,
                            false_alarms_per_hour=s.false_alarms_per_hour, pilot=pilot)
        detections = det.find_all(bb)
        measurer = FrameMeasurer(config, plan, emissions=emissions, settings=s, pilot=pilot, payloads=payloads,
                                 blanker=blanker)
        span = measurer.span_s
        y_bb, y_tone = bb[:, reference_channel].copy(), tone[:, reference_channel].copy()
        f_data, f_tone = plan.data.centre_hz, plan.tone.centre_hz
        records: list[MeasurementRecord] = []
        out_doas: list[DoaEstimate | None] = []
        for d in detections:
            v0 = d.doppler_hz * c / config.carrier_hz
            try:
                corr = baseband_correlation(bb, plan.fs_data, f_data, config=config, pilot=pilot,
                                            t_arrival_s=d.t_start_s, v_mps=v0, sound_speed_mps=c)
            except ConfigError:
                corr = None  # the pilot is cut by the recording's edge: no direction
            doa = None if corr is None else estimate_doa(corr, positions_m, config=config, sound_speed_mps=c, v_mps=v0,
                                                         position_sigma_m=position_sigma_m, assume=assume)
            if combine and doa is not None:
                noise = np.abs(doa.amplitudes) ** 2 / doa.snr
                w = np.conj(doa.amplitudes) / noise
                # combined noise level = the reference channel's (the noise the measurement sees around the frame)
                w = w * math.sqrt(noise[reference_channel] / np.sum(np.abs(w) ** 2 * noise))
                rel = doa.lags_s - doa.t0_s  # each channel to the body origin's time: the range is the origin's
                t_a = d.t_start_s
                t_end = t_a + config.frame_duration_s * (1 + 2 * s.v_max_mps / c) + COMBINE_PAD_S
                _splice(y_bb, bb, plan.fs_data, f_data, t_a - COMBINE_PAD_S, t_end, rel, w)
                _splice(y_tone, tone, plan.fs_tone, f_tone, t_a - COMBINE_PAD_S, t_end, rel, w)
            # the measurement sees the frame's neighbourhood only, as in the streaming receiver's buffers
            t_lo, t_hi = d.t_start_s - 2 * COMBINE_PAD_S - NOISE_WINDOW_S, d.t_start_s + span + COMBINE_PAD_S
            i_bb, i_tone = max(0, math.floor(t_lo * plan.fs_data)), max(0, math.floor(t_lo * plan.fs_tone))
            window = BasebandBuffers(y_bb[i_bb: max(i_bb, math.ceil(t_hi * plan.fs_data))],
                                     y_tone[i_tone: max(i_tone, math.ceil(t_hi * plan.fs_tone))],
                                     bb_start=i_bb, tone_start=i_tone)
            rec = measurer.measure(d, window)
            if doa is None:
                records.append(rec)
                out_doas.append(None)
                continue
            records.append(dataclasses.replace(
                rec, azimuth_body_rad=doa.azimuth_rad, elevation_body_rad=doa.elevation_rad,
                sigma_azimuth_body_rad=doa.sigma_azimuth_rad, sigma_elevation_body_rad=doa.sigma_elevation_rad,
                n_channels=int(x.shape[1])))
            out_doas.append(doa)
    return records, out_doas


#: prior std of each element's position error when they are estimated [m]: directions the calibration frames
#: do not span (e.g. the vertical, when every frame has the same elevation) are left at zero error
POSITION_PRIOR_M = 0.005


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
    estimate_positions: bool = False,
    position_prior_m: float = POSITION_PRIOR_M,
):
    """Channel gain [dB] and phase [rad] offsets, and optionally element position errors, from frames whose
    direction is known.

    For each frame the plane wave's lags are those of the known body-frame
    direction u_f (the common arrival t0 fitted on the envelope); c_k / c_0 at
    those lags is channel k's complex gain relative to channel 0. Gains are
    averaged over frames weighted by their SNR.

    ``estimate_positions``: an element displaced by e_k from its nominal
    position reaches the wave e_k·u_f/c earlier, so the phase of c_k / c_0
    left after the mean gain turns, frame by frame, as

        s_{k,f} = −arg(c_k c_0* / g_k) / (2π f0) = −(e_k − e_0)·u_f / c + b_k,

    linear in (e_k − e_0, b_k) (b_k: the part of the channel's phase offset the
    mean did not take). Per channel, weighted least squares over the frames
    (weights from each frame's SNR on channels k and 0) with a prior of
    ``position_prior_m`` on each coordinate, which leaves at zero what the
    frames' directions do not separate from a constant phase (with every frame
    at one elevation, the vertical component); the phase offset becomes
    arg g_k − 2π f0 b_k. The errors are returned about their mean (a common
    translation of the array only shifts t0: it is not measured).
    Frames at several azimuths *and* elevations determine all three components.

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
    estimate_positions : bool
        Also estimate the element position errors (needs frames from at least
        three directions not in one plane through the origin, or fewer
        components are determined).
    position_prior_m : float
        Prior std of each position error coordinate [m] (``estimate_positions``).

    Returns
    -------
    gain_db, phase_rad : numpy.ndarray, shape (n_channels,)
        Channel 0 is the reference (0 dB, 0 rad): give them to
        :class:`~seamodem.channel.array.ReceiverArray` (or ``complex_gains``
        10^(g/20)·e^{jφ}) for the receiver to remove.
    position_errors_m : numpy.ndarray, shape (n_channels, 3)
        Only with ``estimate_positions``: true − nominal positions, about
        their mean; the receiver takes ``positions_m + position_errors_m`` (and
        the phases returned with them).

    Raises
    ------
    ConfigError
        Not one direction and speed per arrival, or a non-positive prior.
    """
    p = np.asarray(positions_m, float)
    c = sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    arrivals = np.atleast_1d(np.asarray(arrivals_s, float))
    dirs = np.asarray(directions_body_rad, float).reshape(-1, 2)
    v = np.zeros(arrivals.size) if v_mps is None else np.asarray(v_mps, float).reshape(-1)
    if not (len(dirs) == arrivals.size == v.size) or arrivals.size == 0:
        raise ConfigError("directions_body_rad", "needs one direction (and speed) per arrival, at least one")
    if estimate_positions and not (math.isfinite(position_prior_m) and position_prior_m > 0):
        raise ConfigError("position_prior_m", f"must be > 0 m, got {position_prior_m!r}")
    ratios, snrs, units = [], [], []
    for t_a, (az, el), vk in zip(arrivals, dirs, v):
        corr = array_correlation(x, fs, config=config, pilot=pilot, t_arrival_s=t_a, v_mps=vk, sound_speed_mps=c)
        u = unit_vector(az, el)
        rel = -p @ u / c
        coarse = _coarse_lags(corr, float(np.max(np.abs(rel))) + 0.25 / config.symbol_rate_hz)
        t0 = float(np.mean(coarse - rel))
        amp = corr.at(t0 + rel)
        # echoes resolved from the direct path removed first (as estimate_doa, step 2b): a calibration run's
        # geometry repeats, so their pilot sidelobes at the direct lag bias every frame alike (0.36 dB and
        # 0.033 rad on the lower elements of a tetrahedron under a surface and a bottom echo, 24 frames)
        echo_lags, echo_amps = _echoes(corr, t0 + rel, amp / corr.energy, fs=corr.fs_hz,
                                       after_s=0.75 / config.symbol_rate_hz)
        if echo_lags.size:
            amp = corr.without(echo_lags, echo_amps).at(t0 + rel)
        ratios.append(amp / amp[0])
        snrs.append(_snr(amp, corr.noise_var))
        units.append(u)
    ratios, snrs, units = np.array(ratios), np.array(snrs), np.array(units)
    weight = snrs[:, 0]
    g = np.sum(weight[:, None] * ratios, axis=0) / np.sum(weight)
    # the gain from the mean magnitude: a phase that turns from frame to frame (position errors) would shrink
    # the complex mean's (by 0.1 dB with ±2 mm on 8 cm)
    gain_db = 20.0 * np.log10(np.sum(weight[:, None] * np.abs(ratios), axis=0) / np.sum(weight))
    phase_rad = np.angle(g)
    if not estimate_positions:
        return gain_db, phase_rad
    f0 = config.carrier_hz
    s_kf = -np.angle(ratios / g[None, :]) / (2 * np.pi * f0)  # (frames, channels), small once g is removed
    # variance of each frame's phase difference: 1/(2 SNR) per channel, in delay units
    var = (1.0 / (2.0 * snrs) + 1.0 / (2.0 * snrs[:, :1])) / (2 * np.pi * f0) ** 2
    d = np.zeros((p.shape[0], 3))
    design = np.column_stack([-units / c, np.ones(len(units))])
    prior = np.zeros((3, 4))
    prior[:, :3] = np.eye(3) / position_prior_m
    for k in range(1, p.shape[0]):
        sw = 1.0 / np.sqrt(var[:, k])
        A = np.vstack([sw[:, None] * design, prior])
        y = np.concatenate([sw * s_kf[:, k], np.zeros(3)])
        sol = np.linalg.lstsq(A, y, rcond=None)[0]
        d[k] = sol[:3]
        phase_rad[k] = float(np.angle(g[k] * np.exp(-2j * np.pi * f0 * sol[3])))
    return gain_db, phase_rad, d - d.mean(axis=0)


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
    assume: str | None = None,
) -> list[MeasurementRecord]:
    """:func:`receive_array` on a multichannel audio file (one channel per element, read whole).

    A flat or linear array's assumption (``assume``, :func:`array_geometry`) is
    warned about once (a :class:`~seamodem.receive.stream.ReceiverWarning`).

    Raises
    ------
    InputFileError
        Unreadable file, or fewer channels than elements.
    """
    import soundfile

    from ..io.wav import wav_info

    import warnings

    from .stream import ReceiverWarning

    geometry = array_geometry(positions_m, assume)
    info = wav_info(path)
    n_el = np.asarray(positions_m).shape[0]
    if info.channels != n_el:
        raise InputFileError(f"{path}: has {info.channels} channel(s), the array {n_el} elements")
    if geometry.ambiguity:
        warnings.warn(geometry.ambiguity, ReceiverWarning, stacklevel=2)
    x, fs = soundfile.read(str(path), dtype="float64", always_2d=True)
    if not np.all(np.isfinite(x)):
        raise InputFileError(f"{path}: holds NaN or infinite samples")
    records, _ = receive_array(x, float(fs), config, positions_m, emissions=emissions, settings=settings,
                               complex_gains=complex_gains, position_sigma_m=position_sigma_m, pilot=pilot,
                               payloads=payloads, assume=assume)
    return records
