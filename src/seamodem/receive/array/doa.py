"""Direction of arrival of the direct path from one frame's correlations (:mod:`seamodem.receive.array`, steps 1–3).

Wideband plane wave through each channel's envelope peak, then the carrier
phases at its lags (weighted Gauss–Newton on the parameters the array's
geometry measures, :class:`_PlaneWave`), echoes resolved after the direct
path removed, and σ from the Cramér–Rao bound at the measured SNRs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...config import FrameConfig
from ..bounds import gabor_bandwidth_hz
from .correlation import ArrayCorrelation, fs_of
from .geometry import ArrayGeometry, array_geometry, unit_vector


#: echoes are looked for up to ECHO_SEARCH_S after the direct path, at most MAX_ECHOES per channel, while
#: their correlation exceeds ECHO_FRACTION of the direct path's (the pilot's sidelobes are modelled, not searched)
ECHO_SEARCH_S, MAX_ECHOES, ECHO_FRACTION = 0.006, 4, 0.05
#: Gauss–Newton iterations at most, and the lag change [s] under which they stop
MAX_ITERATIONS, LAG_TOLERANCE_S = 8, 1e-9


@dataclass(frozen=True)
class DoaEstimate:
    """Direct path's direction of arrival on one frame (body frame of the array's positions).

    Attributes
    ----------
    azimuth_rad, elevation_rad : float
    sigma_azimuth_rad, sigma_elevation_rad : float
        CRLB-based standard deviations (:mod:`seamodem.receive.array`, step 3).
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


def coarse_lags(corr: ArrayCorrelation, max_lag_s: float, fs_grid: float = 2.5e5) -> np.ndarray:
    """Each channel's envelope peak |c_k| within ±max_lag_s [s], refined by a parabola (step 1's lags).

    Parameters
    ----------
    corr : ArrayCorrelation
        The frame's correlations.
    max_lag_s : float
        The search spans lags [−max_lag_s, max_lag_s] [s].
    fs_grid : float
        Rate of the lag grid searched [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_channels,)
        Each channel's peak lag [s].
    """
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


def correlation_snr(amp: np.ndarray, noise_var: np.ndarray) -> np.ndarray:
    """Post-correlation SNR of each channel, |c_k|² / σ²_{c,k}, capped at MAX_SNR.

    Parameters
    ----------
    amp : numpy.ndarray, shape (n_channels,), complex
        c_k at the path's lags.
    noise_var : numpy.ndarray, shape (n_channels,)
        σ²_{c,k}: the variance of c_k from noise alone (:attr:`ArrayCorrelation.noise_var`).

    Returns
    -------
    numpy.ndarray, shape (n_channels,)
        The SNRs (linear).
    """
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
    """Direction of arrival of the direct path from one frame's correlations (:mod:`seamodem.receive.array`, steps 1–3).

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
    coarse = coarse_lags(corr, aperture / c + 0.25 / config.symbol_rate_hz)
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
    echo_lags, echo_amps = later_paths(corr, lags, corr.at(lags) / corr.energy, fs=fs_of(corr),
                                       after_s=0.75 / config.symbol_rate_hz)
    if echo_lags.size:
        corr = corr.without(echo_lags, echo_amps)
        theta = _fit_plane_wave(corr, model, theta, f0, position_sigma_m / c)
    lags = model.lags(theta)
    amp = corr.at(lags)
    ref = np.sum(amp * np.abs(amp))
    resid = -np.angle(amp * np.conj(ref)) / (2 * np.pi * f0)
    snr = correlation_snr(amp, corr.noise_var)
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


def later_paths(corr: ArrayCorrelation, direct_lags: np.ndarray, direct_amps: np.ndarray, *, fs: float,
                after_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Per channel, the strongest later paths (echoes) of the residual with the direct path removed.

    Greedy (CLEAN): the peak, refined by a parabola on |c|, and its amplitude
    c/E, removed, and again, while above ECHO_FRACTION of the direct path and
    4.5 σ of noise, at most MAX_ECHOES, between ``after_s`` past the direct
    path and ECHO_SEARCH_S.

    Parameters
    ----------
    corr : ArrayCorrelation
        The frame's correlations.
    direct_lags : numpy.ndarray, shape (n_channels,)
        The direct path's lag on each channel [s].
    direct_amps : numpy.ndarray, shape (n_channels,), complex
        Its amplitude on each channel (c_k / E).
    fs : float
        Rate of the lag grid searched [Hz] (the correlation window's).
    after_s : float
        Paths are looked for from this long after the latest direct lag [s].

    Returns
    -------
    lags_s : numpy.ndarray, shape (n_channels, n_echoes)
        The echoes' lags [s].
    amplitudes : numpy.ndarray, shape (n_channels, n_echoes), complex
        Their amplitudes (0 on a channel where that echo is not strong enough).
    """
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
        snr = correlation_snr(amp, corr.noise_var)
        wts = 1.0 / (1.0 / (2.0 * snr * (2 * np.pi * f0) ** 2) + (sigma_p_s) ** 2)
        J = model.jacobian(theta)
        sw = np.sqrt(wts)
        step = np.linalg.lstsq(sw[:, None] * J, sw * (fine - lags), rcond=None)[0]
        theta = model.clip(theta + step)
        if np.max(np.abs(J @ step)) < LAG_TOLERANCE_S:
            break
    return theta
