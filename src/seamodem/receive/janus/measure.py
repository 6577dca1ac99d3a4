"""Arrival time and time scale of a JANUS packet from its known chips (preamble, or the whole decoded packet).

Every chip is a known tone with a known phase: the transmitter's phasor runs on from chip to chip.
The received baseband is modelled as A·e^{jθ}·s((1 + ε)(t − τ))·e^{j2π fc ε (t − τ)} + noise, with
τ the arrival of the first preamble chip. Each chip's complex correlation c_i with the model moves,
for small changes δτ and δε, by the phase −2π f_i δτ + 2π (fc + f_i)(t_i − τ) δε (f_i its tone
about fc, t_i its centre; a change of τ also turns every chip by 2π fc ε δτ, which the common phase θ takes). A grid over (δτ, δε) finds the peak of
|Σ c_i e^{jφ_i}|; weighted least squares on the chips' residual phases then gives the estimate and
its covariance, the phase variance of each chip being N0/(2 A² E_i) with N0 measured from the
residual after the fit (so that misfit, echoes and impulses widen σ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...transmit.janus import JanusParameterSet, chip_bounds, chip_envelope

__all__ = ["ChipCorrelations", "chip_correlations", "ScaleDelayFit", "fit_delay_scale"]


@dataclass(frozen=True)
class ChipCorrelations:
    """Correlations of known chips with the received baseband.

    Attributes
    ----------
    c : numpy.ndarray, complex, shape (n,)
    energy : numpy.ndarray, shape (n,)
        Σ|model|² over each chip's samples.
    rx_energy : numpy.ndarray, shape (n,)
        Σ|r|² over the same samples.
    n_samples : numpy.ndarray, shape (n,)
    f_hz : numpy.ndarray, shape (n,)
        Tone of each chip about fc [Hz].
    t_rel_s : numpy.ndarray, shape (n,)
        Chip centre relative to τ [s].
    """

    c: np.ndarray
    energy: np.ndarray
    rx_energy: np.ndarray
    n_samples: np.ndarray
    f_hz: np.ndarray
    t_rel_s: np.ndarray


def chip_correlations(
    x_bb: np.ndarray, fs_bb: float, tones: np.ndarray, pset: JanusParameterSet, fs_tx: float, tau_s: float, eps: float,
    first: int = 0,
) -> ChipCorrelations:
    """Correlate chips ``first`` … ``len(tones) − 1`` of a packet with the received baseband.

    Parameters
    ----------
    x_bb : numpy.ndarray
        Baseband about fc, sample m at m / fs_bb [s].
    fs_bb : float
        Its rate [Hz].
    tones : numpy.ndarray, shape (n_chips,)
        Tone index of every chip from the first preamble chip (its phase depends on all before).
    pset : JanusParameterSet
        Parameter set.
    fs_tx : float
        The transmitter's sample rate (its phasor steps once per sample before output) [Hz].
    tau_s : float
        Arrival of the first preamble chip [s].
    eps : float
        Time scale ε.
    first : int
        First chip to correlate.
    """
    offsets = np.asarray(pset.tone_offsets_hz(), dtype=np.float64)
    f = offsets[np.asarray(tones)]
    bounds = chip_bounds(len(tones), pset.chip_s, fs_tx)
    lengths = np.diff(bounds)
    phase0 = np.concatenate([[0.0], np.cumsum(2 * np.pi * f[:-1] * lengths[:-1] / fs_tx)])
    lt = int(round(pset.chip_s * fs_tx))
    idx = np.arange(first, len(tones))
    b_s = bounds[idx] / fs_tx
    len_s = lengths[idx] / fs_tx
    n_win = int(np.ceil(pset.chip_s * fs_bb / (1 + eps))) + 2
    m0 = np.floor((tau_s + b_s / (1 + eps)) * fs_bb).astype(np.int64)
    m = m0[:, None] + np.arange(n_win)[None, :]
    t = m / fs_bb
    u = (1 + eps) * (t - tau_s) - b_s[:, None]
    inside = (u >= 0) & (u < len_s[:, None]) & (m >= 0) & (m < len(x_bb))
    env_len = int(lengths.max())
    env = chip_envelope(env_len, lt) if len(set(lengths.tolist())) == 1 else None
    if env is None:
        env_u = np.zeros_like(u)
        for row, i in enumerate(idx):
            e = chip_envelope(int(lengths[i]), lt)
            env_u[row] = np.interp(u[row] * fs_tx, np.arange(e.size), e)
    else:
        env_u = np.interp(u * fs_tx, np.arange(env.size), env)
    model = env_u * np.exp(1j * (np.mod(phase0[idx], 2 * np.pi)[:, None] + 2 * np.pi * f[idx, None] * (u + 1 / fs_tx)
                                 + 2 * np.pi * pset.fc_hz * eps * (t - tau_s)))
    model[~inside] = 0
    r = x_bb[np.clip(m, 0, len(x_bb) - 1)] * inside
    c = np.sum(r * np.conj(model), axis=1)
    t_mid = tau_s + (b_s + len_s / 2) / (1 + eps)
    return ChipCorrelations(
        c=c, energy=np.sum(np.abs(model) ** 2, axis=1), rx_energy=np.sum(np.abs(r) ** 2, axis=1),
        n_samples=inside.sum(axis=1), f_hz=f[idx], t_rel_s=t_mid - tau_s,
    )


@dataclass(frozen=True)
class ScaleDelayFit:
    """Delay and time scale of a packet from its known chips.

    Attributes
    ----------
    tau_s, eps : float
        Arrival of the first preamble chip [s] and time scale.
    sigma_tau_s, sigma_eps : float
        Their standard deviations.
    amplitude : float
        |A| (baseband units).
    n0 : float
        Noise energy per baseband sample, from the residual.
    snr_chip : float
        Mean chip energy over N0 (Es/N0, linear).
    rho : float
        |Σ c_i| / √(Σ E_i · Σ |r|²): 1 for a clean packet.
    """

    tau_s: float
    eps: float
    sigma_tau_s: float
    sigma_eps: float
    amplitude: float
    n0: float
    snr_chip: float
    rho: float


def _regressors(cc: ChipCorrelations, fc_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase change per unit δτ and per unit δε of each chip's correlation."""
    d_tau = 2 * np.pi * cc.f_hz
    d_eps = -2 * np.pi * (fc_hz + cc.f_hz) * cc.t_rel_s
    return d_tau, d_eps


def _grid_peak(cc: ChipCorrelations, fc_hz: float, tau_span: float, eps_span: float, n_tau: int, n_eps: int,
               segments: list[np.ndarray] | None = None, earliest: float | None = None):
    """Peak of |Σ c_i e^{j(d_tau δτ + d_eps δε)}|² on a grid; with ``segments``, of Σ_s |Σ_{i ∈ s} …|²
    (coherent within each stretch of chips only: free of the whole packet's sidelobes in ε).

    With ``earliest``, the earliest local peak in δτ (at its best δε) whose amplitude is at least that
    fraction of the highest: the first arrival, not merely the strongest (a packet's own delay
    sidelobes stay below 0.2 of its peak beyond its main lobe)."""
    d_tau, d_eps = _regressors(cc, fc_hz)
    taus = np.linspace(-tau_span, tau_span, n_tau)
    epss = np.linspace(-eps_span, eps_span, n_eps)
    # one complex matrix product per axis
    a = np.exp(1j * np.outer(taus, d_tau)) * cc.c[None, :]
    b = np.exp(1j * np.outer(d_eps, epss))
    if segments is None:
        p = np.abs(a @ b)
    else:
        p = sum(np.abs(a[:, g] @ b[g, :]) ** 2 for g in segments)
    i, j = np.unravel_index(np.argmax(p), p.shape)
    if earliest is not None:
        amp = np.sqrt(p.max(axis=1)) if segments is not None else p.max(axis=1)
        peaks = [k for k in range(len(amp)) if amp[k] >= earliest * amp[i]
                 and (k == 0 or amp[k] >= amp[k - 1]) and (k == len(amp) - 1 or amp[k] >= amp[k + 1])]
        i = peaks[0] if peaks else i
        j = int(np.argmax(p[i]))
    return taus[i], epss[j]


#: an earlier delay peak at least this share of the highest is taken as the first arrival
_FIRST_ARRIVAL_SHARE = 0.5


def _excess_scatter(res: np.ndarray, w: np.ndarray) -> float:
    """Residual phases' scatter over what N0 predicts, per chip and per stretch of ~8 consecutive chips.

    A merged echo with its own Doppler, or fading, turns the phase slowly: per chip it hides in the
    noise, averaged over a stretch it shows.
    """
    chi2 = float(np.sum(w * res**2) / max(len(res) - 3, 1))
    n_seg = min(16, len(res) // 8)
    if n_seg > 3:
        groups = np.array_split(np.arange(len(res)), n_seg)
        ws = np.array([np.sum(w[g]) for g in groups])
        rs = np.array([np.sum(w[g] * res[g]) for g in groups]) / ws
        chi2 = max(chi2, float(np.sum(ws * rs**2) / (n_seg - 2)))
    return chi2


def _ripple_delay_s(cc: ChipCorrelations, model_phase: np.ndarray, amplitude: float, n0: float) -> float:
    """Arrival-time uncertainty from the channel's ripple across the tones [s].

    An echo too close to separate (e.g. a surface reflection a fraction of a millisecond late) makes
    the channel's gain vary across the band: its phase part is indistinguishable from a delay and
    biases the arrival, its magnitude part shows. The rms ripple of the per-tone gain magnitude
    beyond the noise, r, bounds the phase ripple; its delay equivalent is r / (2π f_rms), f_rms the
    tones' rms spread.
    """
    z = cc.c * np.exp(-1j * model_phase)
    tones = np.unique(cc.f_hz)
    if tones.size < 4 or amplitude <= 0:
        return 0.0
    mags, var = [], []
    for f in tones:
        k = cc.f_hz == f
        e = np.sum(cc.energy[k])
        mags.append(abs(np.sum(z[k])) / (amplitude * e))
        var.append(n0 / (2 * amplitude**2 * e))
    mags, var = np.asarray(mags), np.asarray(var)
    dev2 = (mags / np.mean(mags) - 1) ** 2
    # noise alone: Σ dev²/var is χ² with n − 1 degrees of freedom; ripple only when 3 σ beyond
    dof = tones.size - 1
    if np.sum(dev2 / var) < dof + 3 * np.sqrt(2 * dof):
        return 0.0
    excess = float(np.mean(dev2 - var))
    f_rms = float(np.sqrt(np.mean((cc.f_hz - np.mean(cc.f_hz)) ** 2)))
    return float(np.sqrt(max(excess, 0.0))) / (2 * np.pi * f_rms)


def _fading_rate(cc: ChipCorrelations, model_phase: np.ndarray, amplitude: float, n0: float) -> float:
    """Rate of change of the log-amplitude over the packet beyond the noise [1/s].

    Two paths too close to separate, with different Doppler, beat: their sum's phase turns at a
    rate that looks like Doppler, and its amplitude changes at a rate of the same order (a fading
    surface does the same). This rate, as a phase rate, is the scale's uncertainty that the
    phases alone cannot show.
    """
    n_seg = min(16, len(cc.c) // 8)
    if n_seg < 4 or amplitude <= 0:
        return 0.0
    groups = np.array_split(np.arange(len(cc.c)), n_seg)
    z = cc.c * np.exp(-1j * model_phase)
    e = np.array([np.sum(cc.energy[g]) for g in groups])
    m = np.array([abs(np.sum(z[g])) for g in groups]) / (amplitude * e)
    t = np.array([np.mean(cc.t_rel_s[g]) for g in groups])
    # ln m has variance ≈ N0 / (2 A² E) per stretch
    w = 2 * amplitude**2 * e / n0
    y = np.log(np.maximum(m, 1e-3))
    tc = t - np.sum(w * t) / np.sum(w)
    sxx = np.sum(w * tc**2)
    slope = np.sum(w * tc * (y - np.sum(w * y) / np.sum(w))) / sxx
    # the slope's noise σ is 1/√sxx: a rate only when 3 σ beyond it
    if slope**2 * sxx < 9:
        return 0.0
    return float(np.sqrt(slope**2 - 1 / sxx))


def _phase_drift(res: np.ndarray, w: np.ndarray, t: np.ndarray) -> float:
    """Curvature of the residual phases over the packet beyond the noise [rad/s²].

    One path at a constant speed leaves none; a fading or beating echo turns the merged phase
    unevenly, and its mean slope (the Doppler) is then off by about the curvature times half the
    packet. Zero unless 3 σ beyond its noise.
    """
    tc = t - np.sum(w * t) / np.sum(w)
    q = tc**2 - np.sum(w * tc**2) / np.sum(w)
    # q's part not explained by the linear term (the fit removed constant and slope already)
    q = q - tc * np.sum(w * q * tc) / np.sum(w * tc**2)
    sqq = np.sum(w * q**2)
    if sqq <= 0:
        return 0.0
    kappa = np.sum(w * q * res) / sqq
    if kappa**2 * sqq < 9:
        return 0.0
    return float(np.sqrt(kappa**2 - 1 / sqq))


def fit_delay_scale(
    x_bb: np.ndarray, fs_bb: float, tones: np.ndarray, pset: JanusParameterSet, fs_tx: float, tau_s: float, eps: float,
    *, tau_span_s: float, eps_span: float, segment_chips: int | None = None,
) -> ScaleDelayFit:
    """Fit τ and ε of a packet whose chips ``tones`` are known, starting from (τ, ε) ± the spans.

    Parameters
    ----------
    x_bb : numpy.ndarray
        Baseband about fc, sample m at m / fs_bb [s].
    fs_bb : float
        Its rate [Hz].
    tones : numpy.ndarray, shape (n_chips,)
        Tone index of every chip from the first preamble chip.
    pset : JanusParameterSet
        Parameter set.
    fs_tx : float
        The transmitter's sample rate [Hz] (taken as the recording's).
    tau_s, eps : float
        Starting arrival of the first preamble chip [s] and time scale.
    tau_span_s, eps_span : float
        Searched ± about them.
    segment_chips : int, optional
        First search the spans with the chips summed coherently only within stretches of this many
        (a wide search in ε without the whole packet's sidelobes), then coherently about its peak.

    Returns
    -------
    ScaleDelayFit
    """
    fc = pset.fc_hz
    duration = len(tones) * pset.chip_s
    if segment_chips:
        cc = chip_correlations(x_bb, fs_bb, tones, pset, fs_tx, tau_s, eps)
        n_seg = max(len(tones) // segment_chips, 1)
        segments = np.array_split(np.arange(len(tones)), n_seg)
        n_tau = int(min(max(2 * tau_span_s * pset.used_band_hz * 10, 3), 401)) | 1
        n_eps = int(min(max(2 * eps_span * fc * duration / n_seg * 10, 3), 401)) | 1
        d_tau, d_eps = _grid_peak(cc, fc, tau_span_s, eps_span, n_tau, n_eps, segments, earliest=_FIRST_ARRIVAL_SHARE)
        tau_s, eps = tau_s + d_tau, eps + d_eps
        tau_span_s = 2 * tau_span_s / max(n_tau - 1, 1)
        eps_span = 2 * eps_span / max(n_eps - 1, 1)
    cc = chip_correlations(x_bb, fs_bb, tones, pset, fs_tx, tau_s, eps)
    # steps of a tenth of a cycle: of the highest tone in delay, of the carrier over the packet in scale
    # (the peak is then within a twentieth of a cycle everywhere, where Gauss-Newton converges)
    n_tau = int(min(max(2 * tau_span_s * pset.used_band_hz * 10, 5), 401)) | 1
    n_eps = int(min(max(2 * eps_span * fc * duration * 10, 5), 401)) | 1
    d_tau, d_eps = _grid_peak(cc, fc, tau_span_s, eps_span, n_tau, n_eps)
    tau_s, eps = tau_s + d_tau, eps + d_eps
    # Gauss-Newton on the chips' phases from the grid's peak: two steps (σ from the second's linearisation)
    for _ in range(2):
        cc = chip_correlations(x_bb, fs_bb, tones, pset, fs_tx, tau_s, eps)
        d_tau, d_eps = _regressors(cc, fc)
        amp_c = np.sum(cc.c) / np.sum(cc.energy)
        theta = np.angle(amp_c)
        amplitude = abs(amp_c)
        resid_phase = np.angle(cc.c * np.exp(-1j * theta))
        # residual energy: Σ|r|² − |A|²·Σ E over the chips' samples (the fitted model removed)
        n0 = max((np.sum(cc.rx_energy) - amplitude**2 * np.sum(cc.energy)) / max(np.sum(cc.n_samples), 1), 1e-300)
        w = 2 * amplitude**2 * cc.energy / n0
        h = np.column_stack([np.ones_like(d_tau), -d_tau, -d_eps])
        cov = np.linalg.pinv(h.T @ (w[:, None] * h))
        delta = cov @ (h.T @ (w * resid_phase))
        tau_s, eps = tau_s + delta[1], eps + delta[2]
    res = resid_phase - h @ delta
    cov = cov * max(_excess_scatter(res, w), 1.0)
    model_phase = theta + (resid_phase - res)
    cov[1, 1] += _ripple_delay_s(cc, model_phase, amplitude, n0) ** 2
    cov[2, 2] += (_fading_rate(cc, model_phase, amplitude, n0) / (2 * np.pi * fc)) ** 2
    cov[2, 2] += (_phase_drift(res, w, cc.t_rel_s) * duration / 2 / (2 * np.pi * fc)) ** 2
    rho = abs(np.sum(cc.c)) / np.sqrt(np.sum(cc.energy) * np.sum(cc.rx_energy))
    return ScaleDelayFit(
        tau_s=float(tau_s), eps=float(eps), sigma_tau_s=float(np.sqrt(cov[1, 1])), sigma_eps=float(np.sqrt(cov[2, 2])),
        amplitude=float(amplitude), n0=float(n0), snr_chip=float(amplitude**2 * np.mean(cc.energy) / n0), rho=float(rho),
    )
