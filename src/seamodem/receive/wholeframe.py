"""Whole-frame, path-resolved Doppler: each resolved path's gain and Doppler (with a first-order drift)
fitted over the whole frame, with the frame's symbols as the reference.

Once a frame is decoded (CRC passed) every symbol is known; otherwise the
pilots and the confident decisions are. The frame of ≈ 0.3 s is then a known
signal, and its carrier phase measures each path's Doppler with the data
band's C/N0 over the whole frame (SPEC §6, "whole-frame Doppler of the direct
path"), not over the 23 ms of pilot.

Model (SPEC §3, paper 003 eq 14), in the data baseband (carrier f0):

    r(t) = Σ_p A_p Σ_k x_k g₁((t − t_{p,k})/T') / √E + w(t),
    phase of path p: 2π f0 [ε_p (t − τ_p) + ½ β_p ((t − t_c)² − (D/2)²)],

with ε_p the path's mean v/c over the frame, β_p its drift d(v/c)/dt, D the
frame's duration, t_c = τ_p + D/2, and t_{p,k} the instant symbol k reaches
the receiver on path p. A path's mean closing speed is c·ε_p.

Estimation is space-alternating (SAGE, Fleury et al. 1999): for each path in
turn, every other path's fitted contribution is subtracted, the matched filter
is run at the path's symbol instants, the known symbols are stripped
(z_k = y_k x_k*), and the phase of z summed over ``n_segments`` consecutive
segments is fitted by weighted least squares with a line and a parabola in
time; the line's slope is the Doppler correction, the parabola the drift.
Sweeps repeat until none moves a path's Doppler by a quarter of its σ nor its
delay by its σ (3 sweeps): the paths interfere only through the data's random cross-correlation
once their delays differ by a symbol or more. The matched filter and the
synthesis of each path's contribution are computed in the FFT domain on the
frame's stretch of baseband (:class:`FrameSegment`), the pulse's time scale exact.

The standard deviation of each path's Doppler is the least-squares one from
the segments' phase residuals (it grows with whatever the model leaves:
unresolved or unfitted echoes, impulses, noise), never below the CRLB of a
known signal at the path's measured Es/N0 (Rife & Boorstyn, SPEC §6).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..config import FrameConfig
from .bounds import gabor_bandwidth_hz
from .doppler import log_amplitude_rate
from .measure import power_excess
from .multipath import raised_cosine

__all__ = ["WholeFrameFit", "channel_bend_s2", "fit_whole_frame", "known_signal_velocity_crlb_mps", "split_clusters",
           "subband_bend", "unmodelled_paths", "earlier_path", "intersymbol_slopes"]


@dataclass(frozen=True)
class WholeFrameFit:
    """Per-path result of :func:`fit_whole_frame` (paths in increasing delay).

    Attributes
    ----------
    delays_s : numpy.ndarray
        Frame-start arrival of each path [s].
    amplitudes : numpy.ndarray, complex
        Matched-filter amplitude A_p of each path.
    v_mps : numpy.ndarray
        Mean closing speed of each path over the frame [m/s].
    accel_mps2 : numpy.ndarray
        First-order drift of each path's closing speed [m/s²].
    sigma_v_mps : numpy.ndarray
        Standard deviation of ``v_mps`` [m/s]: the segments' least-squares
        deviation, at least ``crlb_v_mps``.
    crlb_v_mps : numpy.ndarray
        CRLB of a known signal at the path's Es/N0 over the symbols used [m/s].
    es_n0 : numpy.ndarray
        Each path's Es/N0 (linear), noise from the residual of all paths.
    sigma_delay_s : numpy.ndarray
        Standard deviation of ``delays_s`` [s]: the segments' deviation of the
        data-aided timing, at least its CRLB over the reference symbols.
    n_reference : int
        Symbols used as the reference (known or confident).
    amp_rate_hz : numpy.ndarray
        RMS over the frame of the rate of each path's log-amplitude [1/s],
        from a line and a parabola fitted to the segments' ln|Σz| (as their
        phases), each term less its noise expectation (0 when below it), the
        parabola's only beyond 3 of its σ (``log_amplitude_rate``).
        A path that fades, or that an unresolved echo beats with, changes
        amplitude: for a Rician or two-phasor sum the log-amplitude rate and
        the phase-rate error (a Doppler error) have the same scale.
    amp_rate_terms : numpy.ndarray, shape (n_paths, 2, 2)
        The same rate's terms (the slope's, the parabola's) [1/s²], each less
        its noise expectation but not clipped at 0, with that noise's σ:
        unbiased estimates, which the receiver averages over frames
        (``FrameMeasurer``).
    tilt_delay_s : numpy.ndarray
        The direct path's channel shape across its band as a bound on its
        arrival's bias [s] (0 for the other paths): from 4 equal-energy
        sub-bands, the curvature c of ln H over f (ln|H| and the phase, a
        parabola each), counted beyond 3 of what the noise gives it. A merged
        echo b (|b| ≤ 1) at Δ makes the channel 1 + b e^{−j2πfΔ}, whose
        group-delay error Re(w)·Δ, w = b e/(1 + b e), is at most
        √|d²ln H/df²| / 2π whatever Δ (the curvature is −w(1−w)(2πΔ)², and
        |Re w| ≤ √|w(1−w)| for |b| ≤ 1). The slope of ln|H| is left out: a
        loss that grows with frequency (absorption, a transducer) tilts it.
    curvature_s2 : numpy.ndarray
        The direct path's curvature c itself, complex (ln|H|'s and the
        phase's) [s²], scaled so that |c|² is the fourth power of the same
        bound: ``abs(curvature_s2)**2 - curvature_noise_s4`` is that fourth
        power less its noise expectation, unbiased, which the receiver averages
        over frames (``FrameMeasurer``: a merged surface image lasts while one
        frame's curvature is within its noise). c is invariant to the path's
        gain and delay, so a channel whose echo stays put also adds coherently
        over frames. NaN (both) when the reference left a sub-band without
        energy (decisions all alike: its spectrum a line at 0 Hz). With ``clean``, the direct path's is read
        after the paths the fit left in its residual, 1.5/B after it and later, are taken out
        (:func:`unmodelled_paths`).
        With ``echo_bends``, each echo at least 0.2 of the strongest path's amplitude has its own (its bend
        is a cluster's: :func:`split_clusters`); NaN for the other echoes.
    curvature_noise_s4 : numpy.ndarray
        That noise expectation [s⁴] (circular: half of it per component of c),
        also the σ of the unbiased fourth power on a channel without curvature.
    delay_scatter_s : numpy.ndarray
        Deviation of the segments' data-aided timings about their mean, less
        what the timing CRLB gives it [s] (a diagnostic: the segments' timing
        estimator is not efficient, so noise alone leaves 2–4 mm of it at
        12 dB; the fit's ``sigma_delay_s`` already carries the scatter).
    pilot_noise_excess : float
        Mean over median-implied power (× ln 2; ≥ 1, 1 for Gaussian noise) of the residual's matched-filter
        outputs at the pilot's symbols: the impulses left where the pilot lies, which the pilot's arrival sees.
    pilot_es_n0 : numpy.ndarray or None
        Each path's Es/N0 over the pilot's symbols alone, the other paths' models taken out at their gains over
        the pilot: the gain from the known pilot (not from data decisions), the noise from the outputs' scatter
        about a gain fitted in each fifth of the pilot (a phase the fit's Doppler leaves there is not counted);
        NaN when the reference does not hold the whole pilot.
    noise_var : float
        The residual's power per matched-filter output at the first path's instants (``es_n0``'s noise).
    earlier_path : tuple or None
        With ``earlier_reach_s``: the strongest component of the residual before the direct path
        (:func:`earlier_path`: lag [s], amplitude, |amplitude|² over its noise expectation).
    """

    delays_s: np.ndarray
    amplitudes: np.ndarray
    v_mps: np.ndarray
    accel_mps2: np.ndarray
    sigma_v_mps: np.ndarray
    crlb_v_mps: np.ndarray
    es_n0: np.ndarray
    sigma_delay_s: np.ndarray
    n_reference: int
    amp_rate_hz: np.ndarray | None = None
    amp_rate_terms: np.ndarray | None = None
    tilt_delay_s: np.ndarray | None = None
    curvature_s2: np.ndarray | None = None
    curvature_noise_s4: np.ndarray | None = None
    delay_scatter_s: np.ndarray | None = None
    pilot_noise_excess: float = 1.0
    pilot_es_n0: np.ndarray | None = None
    noise_var: float = math.nan
    earlier_path: tuple[float, complex, float] | None = None


def known_signal_velocity_crlb_mps(config: FrameConfig, es_n0, n_symbols: int, *, sound_speed_mps: float):
    """CRLB of v from the carrier of a known PSK signal of ``n_symbols`` symbols [m/s].

    Notes
    -----
    The symbols stripped, the matched-filter outputs are a tone sampled at the
    symbol rate R with per-sample SNR Es/N0: C/N0 = R·Es/N0 over T = n/R, and
    σ_f = √(3 / (2π² (C/N0) T³)) (Rife & Boorstyn 1974, SPEC §6); σ_v = c σ_f / f0.
    """
    rate = config.symbol_rate_hz
    duration = n_symbols / rate
    c_n0 = rate * np.asarray(es_n0, dtype=float)
    sigma_f = np.sqrt(3.0 / (2 * np.pi**2 * np.maximum(c_n0, 1e-30) * duration**3))
    return sound_speed_mps / config.carrier_hz * sigma_f


def delay_gain_information(delays_s, amplitudes, *, config: FrameConfig, v_mps=None,
                           sound_speed_mps: float = 1500.0) -> np.ndarray:
    """Fisher information J of every path's (τ_p, Re a_p, Im a_p), in units of 2E/N0 (E a unit path's
    energy over the frame), rows and columns in that order path after path.

    Parameters
    ----------
    delays_s : array_like
        The paths' delays [s].
    amplitudes : array_like, complex
        Their gains (in the fit's units: a path's mean stripped matched-filter output).
    config : FrameConfig
        The pulse (symbol period, roll-off), the carrier and the frame's duration.
    v_mps : array_like, optional
        Their closing speeds [m/s]: paths whose Doppler differs by Δf decorrelate over the frame by
        sinc(Δf·D).
    sound_speed_mps : float
        c [m/s], for the speeds.

    Notes
    -----
    The paths' sum is μ(t) = Σ a_p g(t − τ_p), g the frame's baseband signal. For random symbols
    Σ g*(t) g(t − Δ) = E·rc(Δ), the raised-cosine pulse (SRRC ⊛ SRRC), so with Δ = τ_q − τ_p:
    J_{τ_p τ_q} = −rc″(Δ)·Re(a_p* a_q), J_{τ_p, Re a_q} = −rc′(Δ)·Re a_p, J_{τ_p, Im a_q} = −rc′(Δ)·Im a_p,
    J_{Re a_p, Re a_q} = J_{Im a_p, Im a_q} = rc(Δ). A path alone is decoupled (rc′(0) = 0); an echo
    within the pulse's width (1/B) trades its gain against the earlier path's delay.
    """
    d = np.asarray(delays_s, dtype=float)
    a = np.asarray(amplitudes, dtype=complex)
    n = d.size
    period, rolloff = config.symbol_period_s, config.rolloff
    h = 1e-3 * period
    lag = d[None, :] - d[:, None]
    r0 = raised_cosine(lag, period, rolloff)
    rp, rm = raised_cosine(lag + h, period, rolloff), raised_cosine(lag - h, period, rolloff)
    r1 = (rp - rm) / (2 * h)
    r2 = (rp - 2 * r0 + rm) / h**2
    if v_mps is not None:
        df = config.carrier_hz * np.asarray(v_mps, dtype=float) / sound_speed_mps
        gamma = np.abs(np.sinc((df[None, :] - df[:, None]) * config.frame_duration_s))
    else:
        gamma = np.ones((n, n))
    j = np.zeros((3 * n, 3 * n))
    tau, re, im = np.arange(n) * 3, np.arange(n) * 3 + 1, np.arange(n) * 3 + 2
    j[np.ix_(tau, tau)] = -r2 * np.real(np.conj(a)[:, None] * a[None, :]) * gamma
    j[np.ix_(tau, re)] = -r1 * a.real[:, None] * gamma
    j[np.ix_(tau, im)] = -r1 * a.imag[:, None] * gamma
    j[np.ix_(re, tau)] = j[np.ix_(tau, re)].T
    j[np.ix_(im, tau)] = j[np.ix_(tau, im)].T
    j[np.ix_(re, re)] = r0 * gamma
    j[np.ix_(im, im)] = r0 * gamma
    return j


def joint_delay_inflation(delays_s, amplitudes, *, config: FrameConfig, v_mps=None,
                          sound_speed_mps: float = 1500.0) -> np.ndarray:
    """Per path, κ ≥ 1: how much its delay's variance grows when every path's delay and gain are fitted
    together, over its variance with the other paths known.

    Parameters
    ----------
    delays_s, amplitudes, config, v_mps, sound_speed_mps
        As :func:`delay_gain_information`.

    Returns
    -------
    numpy.ndarray
        κ_p = (J⁻¹)_{τ_p τ_p} · J_{τ_p τ_p} (inf where J is singular). The SAGE fit's σ of a path,
        measured with the others subtracted at their fitted values, is the conditional one; κ makes it
        the joint one (an echo 0.3 at 0.6 T: κ ≈ 21, 0.3j: ≈ 3).
    """
    n = np.asarray(delays_s).size
    if n < 2:
        return np.ones(n)
    j = delay_gain_information(delays_s, amplitudes, config=config, v_mps=v_mps, sound_speed_mps=sound_speed_mps)
    try:
        inv = np.linalg.inv(j)
    except np.linalg.LinAlgError:
        return np.full(n, np.inf)
    kappa = np.diag(inv)[0::3] * np.diag(j)[0::3]
    return np.where(np.isfinite(kappa), np.maximum(kappa, 1.0), np.inf)


def joint_delay_sigma_s(sigma_s, delays_s, amplitudes, *, config: FrameConfig, v_mps=None,
                        sound_speed_mps: float = 1500.0) -> np.ndarray:
    """The paths' delay σ's [s] when fitted together, from their σ's with the others known.

    Each σ is grown by √κ (:func:`joint_delay_inflation`), but not beyond the gap to the nearest other
    path (if larger than the σ): two paths closer than that are one blurred arrival, whose delays the fit
    cannot tell apart, and the path's arrival lies between them.

    Parameters
    ----------
    sigma_s : array_like
        Each path's delay σ with the other paths known [s].
    delays_s, amplitudes, config, v_mps, sound_speed_mps
        As :func:`joint_delay_inflation`.
    """
    sigma = np.asarray(sigma_s, dtype=float)
    d = np.asarray(delays_s, dtype=float)
    if d.size < 2:
        return sigma.copy()
    kappa = joint_delay_inflation(d, amplitudes, config=config, v_mps=v_mps, sound_speed_mps=sound_speed_mps)
    gaps = np.abs(d[None, :] - d[:, None]) + np.diag(np.full(d.size, np.inf))
    return np.minimum(sigma * np.sqrt(kappa), np.maximum(sigma, gaps.min(axis=1)))


def intersymbol_slopes(symbols: np.ndarray, ref_idx: np.ndarray, config: FrameConfig, scale: float,
                       reach: int = 32) -> np.ndarray:
    """The known symbols' terms in a unit-gain path's stripped derivative outputs at the reference symbols k
    [1/s]: conj(x_k)·Σ_{n≠0} x_{k−n}·r′(n)/T′, T′ the symbol period over ``scale`` (1 + v/c).

    At the right instants a path's matched-filter outputs hold no other symbol (Nyquist pulses), but their
    time derivatives do: r′ at whole symbols is odd and not zero. Over a run of symbols the pairs within it
    cancel, and those across its two ends remain.

    >>> from seamodem import get_preset
    >>> cfg = get_preset("jmse2024")
    >>> x = np.array([1, 1, -1, 1, -1, -1, 1, 1], complex)
    >>> k = intersymbol_slopes(x, np.arange(8), cfg, 1.0)
    >>> bool(abs(k.sum()) < 1e-9 * np.abs(k).sum())  # a whole run: its pairs cancel
    True
    """
    x = np.asarray(symbols, dtype=complex)
    # r′(n) of the raised cosine (the pulse and its matched filter; unit peak), n = 1 … reach, by a central
    # difference (10⁻¹⁰ of the exact slope, its limits at 1/(2α) included), per second at the period T′
    n, h = np.arange(1, reach + 1), 1e-5
    slopes = (raised_cosine(n + h, 1.0, config.rolloff) - raised_cosine(n - h, 1.0, config.rolloff)) / (2 * h) \
        * scale / config.symbol_period_s
    padded = np.concatenate([np.zeros(reach, complex), x, np.zeros(reach, complex)])
    k = np.asarray(ref_idx) + reach
    acc = np.zeros(k.size, complex)
    for n, r in enumerate(slopes, start=1):
        acc += r * (padded[k - n] - padded[k + n])
    return acc * np.conj(x[np.asarray(ref_idx)])


def symbol_instants(config: FrameConfig, delay_s: float, eps: float, beta: float) -> np.ndarray:
    """Arrival of each symbol's pulse centre on a path: α(t) = τ_k solved to first order in the drift.

    Parameters
    ----------
    config : FrameConfig
        The frame.
    delay_s : float
        The path's frame-start arrival [s].
    eps : float
        Its mean Doppler scale v/c over the frame.
    beta : float
        Its drift d(v/c)/dt [1/s].

    Returns
    -------
    numpy.ndarray, (n_pilot + n_data,)
        Arrival time of each symbol's pulse centre [s].
    """
    tau = (config.n_guard + np.arange(config.n_pilot + config.n_data)) * config.symbol_period_s
    half = config.frame_duration_s / 2
    d = tau / (1 + eps)
    return delay_s + (tau - 0.5 * beta * ((d - half) ** 2 - half**2)) / (1 + eps)


def path_phase(config: FrameConfig, t_rel: np.ndarray, eps: float, beta: float) -> np.ndarray:
    """Carrier phase of a path at t − τ_p [rad] (module docstring).

    Parameters
    ----------
    config : FrameConfig
        The frame (its carrier).
    t_rel : numpy.ndarray
        Time since the path's frame-start arrival [s].
    eps, beta : float
        The path's mean Doppler scale and its drift [1/s].

    Returns
    -------
    numpy.ndarray
        The phase 2π f0 [ε t + ½β((t − D/2)² − (D/2)²)] [rad].
    """
    half = config.frame_duration_s / 2
    return 2 * np.pi * config.carrier_hz * (eps * t_rel + 0.5 * beta * ((t_rel - half) ** 2 - half**2))


#: the matched filter's output is computed at this multiple of the baseband rate and read at the
#: symbol instants by 6-point Lagrange interpolation (symbols are spread onto that grid by its
#: transpose): for the data band's ±4.5 kHz at 13.7 kHz × 4, error ≤ 8.5e-5 of the signal (−81 dB)
_UPSAMPLE = 4
#: the fit stops after a sweep that moved no path's Doppler, nor its delay, by this many of its σ: the
#: sweeps contract (a delay step of 0.7σ is followed by one of 0.01σ), so the last step taken is the
#: error left, within a tenth or so of it
_STEP_DOPPLER, _STEP_DELAY = 0.25, 1.0
#: paths whose delay variance grows beyond this factor when fitted together (an echo within ~1.5 symbols)
#: get joint Gauss–Newton steps after the SAGE passes, at most _JOINT_STEPS of them
_COUPLED_KAPPA, _JOINT_STEPS = 1.05, 6
#: ... unless a pair is nearly one path: κ at the worst relative phase beyond this (σ × 7; an echo 0.7 at
#: 60 µs: 120) is a cluster the paths stand in for, whose joint solution drifts with what the model lacks
_IDENTIFIABLE_KAPPA = 50.0
#: sub-bands of a path's band whose amplitudes give its channel's tilt and curvature (``tilt_delay_s``)
_N_BANDS = 4
#: the paths a fit left in its residual (``unmodelled_paths``) are taken out of the direct path's sub-bands from
#: this many 1/B after it on: nearer, the residual of a merged echo fitted with the direct path (its pulse's
#: derivative) peaks (a far recording at 6 dB, a surface image 22 µs behind: peaks 0.09–0.15 at 100–124 µs,
#: 0.9–1.1/B; near the null, out to 1.8–1.9/B: a surface image the depths give is projected out first,
#: ``unmodelled_paths(known_lags_s=…)``). 2/B before session 19: a bottom path and its surface image at 1.7 and
#: 2.2/B, found as one component at 1.9/B (0.12 of the direct path), stayed in the sub-bands and bent them 7
#: times their noise, a 23 mm bound on ranges within 1 mm (the corpus's far family, the depths given)
_MISSED_AFTER_B = 1.5
#: a component before the direct path is sought from this many 1/B before it on (:func:`earlier_path`)
EARLIER_NEAREST_B = 3.0
#: echoes at least this share of the strongest path's amplitude get their own channel's curvature
_BEND_MIN_FRACTION = 0.2
#: an echo whose bend |c|²/noise exceeds this is split (noise alone: exponential, beyond 9 in 1.2e-4 of fits)
_SPLIT_BEND = 9.0
#: the two paths of a split start this many 1/B apart: the echo they replace and one after it, or before it,
#: or either side of it (the fitted echo lies near the stronger of the two)
_SPLIT_WIDTH = 1.0
#: a split is kept when n·(residual's drop)/residual exceeds this (twice its log-likelihood ratio, for 2 added
#: real parameters of delay and 2 of gain and 2 of Doppler and drift; χ² with 6 degrees beyond 20 in 3e-3)
_SPLIT_GAIN = 20.0
_TAPS = np.arange(-2, 4)  # the interpolator's sample offsets around a position


def srrc_spectrum(f_hz: np.ndarray, period_s: float, rolloff: float) -> np.ndarray:
    """H(f) = √T·S(fT) of the unit-energy SRRC pulse h of symbol period T (S: 1 in the flat band, cosine roll-off)."""
    nu = np.abs(f_hz) * period_s
    lo = (1 - rolloff) / 2
    roll = np.cos(np.pi / (2 * rolloff) * np.clip(nu - lo, 0.0, rolloff))  # 0 beyond (1 + rolloff)/2
    return math.sqrt(period_s) * np.where(nu <= lo, 1.0, roll)


def _lagrange_basis() -> np.ndarray:
    """Coefficients (power of d, tap) of the Lagrange basis polynomials on the points ``_TAPS``."""
    basis = np.zeros((len(_TAPS), len(_TAPS)))
    for j, oj in enumerate(_TAPS):
        others = _TAPS[_TAPS != oj]
        basis[:, j] = np.poly(others)[::-1] / np.prod(oj - others)
    return basis


_BASIS = _lagrange_basis()


def _lagrange(pos: np.ndarray, derivative: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Lagrange interpolation on the points ``_TAPS`` around fractional grid positions: (floor, weights (n, 6));
    with ``derivative``, the weights of the interpolating polynomial's derivative [per grid step]
    (error ≤ 5.6e-4 of the band edge's 2πf for the data band at ×4)."""
    i = np.floor(pos).astype(np.int64)
    powers = np.vander(pos - i, len(_TAPS), increasing=True)
    if derivative:
        powers = np.hstack([np.zeros((len(pos), 1)), powers[:, :-1] * np.arange(1, len(_TAPS))])
    return i, powers @ _BASIS


@njit(cache=True, nogil=True)
def _read_kernel(c, pos, basis, first_tap, y, dy):
    """y_k = Σ_j c[(i_k + o_j) mod N] w_j(d_k) and dy_k with the derivative's weights (``_lagrange``'s
    weights, Horner-free: the powers of d times the basis, as the numpy form), in one pass."""
    n_taps = basis.shape[1]
    big = c.size
    for k in range(pos.size):
        i = int(np.floor(pos[k]))
        d = pos[k] - i
        acc = 0j
        dacc = 0j
        for j in range(n_taps):
            w = 0.0
            dw = 0.0
            p = 1.0
            for q in range(n_taps):
                w += p * basis[q, j]
                if q + 1 < n_taps:
                    dw += (q + 1) * p * basis[q + 1, j]
                p *= d
            v = c[(i + first_tap + j) % big]
            acc += w * v
            dacc += dw * v
        y[k] = acc
        dy[k] = dacc


@njit(cache=True, nogil=True)
def _spread_kernel(x, pos, basis, first_tap, grid):
    """grid[(i_k + o_j) mod N] += w_j(d_k)·x_k: the transpose of :func:`_read_kernel` (the symbols spread
    onto the upsampled grid), in one pass."""
    n_taps = basis.shape[1]
    big = grid.size
    for k in range(pos.size):
        i = int(np.floor(pos[k]))
        d = pos[k] - i
        for j in range(n_taps):
            w = 0.0
            p = 1.0
            for q in range(n_taps):
                w += p * basis[q, j]
                p *= d
            grid[(i + first_tap + j) % big] += w * x[k]


class FrameSegment:
    """FFT-domain SRRC matched filter and synthesis on one stretch of baseband.

    The SRRC is band-limited below fs/2, so with h the unit-energy pulse of
    period T' (spectrum :func:`srrc_spectrum`, time scale exact):

    - matched filter: c(t) = ∫ r(u) h(u − t) du is IFFT(R·H) on the grid,
      zero-padded to ``_UPSAMPLE``·fs and read at t_k; y_k = c(t_k)/√T', so that
      r = A Σ x_k √T' h(t − t_k) gives y_k = A x_k (as
      :func:`~seamodem.receive.doppler.matched_filter`, without its 32-symbol truncation);
    - synthesis: s(t) = Σ x_k √T' h(t − t_k) is fs·IFFT(√T' H·X) with
      X(f) = Σ x_k e^{−j2πf(t_k − t0)}, the symbols spread onto the upsampled
      grid by the transposed interpolation.

    One FFT of the segment and one of the upsampled grid per call (≈ 1 ms),
    against a gather of every symbol's 69-sample support (≈ 10 ms).
    """

    def __init__(self, n: int, fs: float, t0_s: float, *, config: FrameConfig):
        import scipy.fft

        self._fft = scipy.fft
        pad = int(math.ceil(config.srrc_span_symbols / 2 * config.symbol_period_s * fs)) + 8
        self.n, self.fs, self.t0_s, self.config = n, fs, t0_s, config
        self.m = scipy.fft.next_fast_len(n + 2 * pad)
        self.big = _UPSAMPLE * self.m
        freqs_hz = scipy.fft.fftfreq(self.m, 1 / fs)
        # the pulse's band (|f| < (1 + rolloff)/(2T'), T' within 1 % of T): the only bins computed
        edge = 1.01 * (1 + config.rolloff) / (2 * config.symbol_period_s)
        self.band = np.flatnonzero(np.abs(freqs_hz) < edge)
        self.band_hz = freqs_hz[self.band]
        self.band_big = np.where(self.band_hz >= 0, self.band, self.band + self.big - self.m)  # same f at L·fs
        self.t_s = t0_s + np.arange(n) / fs

    def _pulse(self, scale: float) -> tuple[float, np.ndarray]:
        period = self.config.symbol_period_s / scale
        return period, srrc_spectrum(self.band_hz, period, float(self.config.rolloff))

    def filter(self, r: np.ndarray, instants_s: np.ndarray, *, scale: float, offset_hz: float, t_ref_s: float,
               derivative: bool = False, half: int = 0):
        """Matched-filter outputs at ``instants_s`` of r with ``offset_hz`` (phase 0 at ``t_ref_s``) removed;
        with ``derivative``, also their time derivative dy/dt [1/s] (the interpolating polynomial's); with
        ``half`` −1 or +1, the filter's lower or upper half band alone."""
        period, h = self._pulse(scale)
        if half:
            h = np.where(half * self.band_hz > 0, h, 0.0)
        x = r * np.exp(-2j * np.pi * offset_hz * (self.t_s - t_ref_s)) if offset_hz else r
        up = np.zeros(self.big, complex)
        up[self.band_big] = self._fft.fft(x, self.m)[self.band] * h
        c = self._fft.ifft(up) * (_UPSAMPLE / math.sqrt(period))
        pos = np.ascontiguousarray((instants_s - self.t0_s) * (self.fs * _UPSAMPLE), dtype=float)
        y, dy = np.empty(pos.size, complex), np.empty(pos.size, complex)
        _read_kernel(c, pos, _BASIS, int(_TAPS[0]), y, dy)
        if not derivative:
            return y
        return y, dy * (self.fs * _UPSAMPLE)

    def band_sums(self, r: np.ndarray, instants_s: np.ndarray, weights: np.ndarray, *, scale: float, offset_hz: float,
                  t_ref_s: float, n_bands: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Σ_k w_k y_k of the matched filter restricted to each of ``n_bands`` equal-energy sub-bands of the
        pulse, computed in the frequency domain (one FFT of r, the weights spread on the grid and one FFT):
        (sums, their share of the full band's noise variance, the sub-bands' centroids [Hz]). The sums are
        on the scale of :meth:`filter`'s outputs to within the interpolation's error."""
        period, h = self._pulse(scale)
        x = r * np.exp(-2j * np.pi * offset_hz * (self.t_s - t_ref_s)) if offset_hz else r
        spec = self._fft.fft(x, self.m)[self.band] * h
        pos = np.ascontiguousarray((instants_s - self.t0_s) * (self.fs * _UPSAMPLE), dtype=float)
        grid = np.zeros(self.big, complex)
        _spread_kernel(np.ascontiguousarray(np.conj(weights), dtype=complex), pos, _BASIS, int(_TAPS[0]), grid)
        w_spec = self._fft.fft(grid)[self.band_big]
        prod = spec * np.conj(w_spec) * (_UPSAMPLE / math.sqrt(period) / self.big)
        energy = h**2 * np.abs(w_spec) ** 2
        order = np.argsort(self.band_hz)
        cum = np.cumsum(energy[order])
        which = np.minimum((cum / cum[-1] * n_bands).astype(int), n_bands - 1)
        sums = np.bincount(which, prod[order].real, n_bands) + 1j * np.bincount(which, prod[order].imag, n_bands)
        e = np.bincount(which, energy[order], n_bands)
        centroid = np.bincount(which, energy[order] * self.band_hz[order], n_bands) / np.maximum(e, 1e-300)
        return sums, e / e.sum(), centroid

    def synthesize(self, symbols: np.ndarray, instants_s: np.ndarray, *, scale: float) -> np.ndarray:
        """Σ x_k √T' h(t_n − t_k) on the segment's grid, without the carrier phase."""
        period, h = self._pulse(scale)
        pos = np.ascontiguousarray((instants_s - self.t0_s) * (self.fs * _UPSAMPLE), dtype=float)
        grid = np.zeros(self.big, complex)
        _spread_kernel(np.ascontiguousarray(symbols, dtype=complex), pos, _BASIS, int(_TAPS[0]), grid)
        spec = np.zeros(self.m, complex)
        spec[self.band] = self._fft.fft(grid)[self.band_big] * h
        return (self.fs * math.sqrt(period)) * self._fft.ifft(spec)[: self.n]


def subband_bend(zb: np.ndarray, share: np.ndarray, fb: np.ndarray, var: np.ndarray) -> tuple[complex, float, float]:
    """A channel's curvature across its band from sub-band sums (``FrameSegment.band_sums``): (c [s²], complex,
    ln|H|'s and the phase's; its noise expectation |c|² [s⁴]; the band's mean square of f [Hz²]).

    Each sub-band's sum is its share of the pulse's energy times the channel there: ln|H| is ln|z| less
    ln(share) (the split into equal-energy sub-bands is by whole FFT bins, so the shares differ by ±0.2 %
    with each frame's symbols; read as ln|H|, that made a bend of its own, ±3e-11 s²: a one-path frame at
    30 dB, its range σ 3.4 mm for errors of 0.05 mm, the pooled bend's bound). ln|H| and the phase across
    the sub-bands each get a line and a parabola in f, weighted by ``var`` (each ln|z|'s noise variance;
    only its shape matters to c); the phase's slope is the fitted delay's (≈ 0 once converged), and the
    slope of ln|H| is left out: a loss that grows with frequency (absorption, 3–4 dB across the band at 1
    km; a transducer's response) tilts |H| without moving the group delay; a merged echo bends it.

    The curvature c (per RMS-of-f squared) of 1 + b e^{−j2πfΔ} is −w(1−w)(2πΔ)² at w = b e/(1 + b e), the
    bias Re(w)·Δ: for |b| ≤ 1, |Re w|/√|w(1 − w)| ≤ 1, so the bias is at most √|d²ln H/df²|/2π = √(2|c|/span²)/2π
    whatever Δ (the slope alone would give |w(1−w)|·2πΔ²·span, 7× smaller for a 0.9 echo 17 µs behind). c
    is scaled so that |c|² is that bound's fourth power [s⁴]; its noise expectation is 2 cov (|c|² of noise
    alone is exponential: its σ is its mean).
    """
    n_bands = len(zb)
    fc = fb - np.sum(fb * share)
    span2 = float(np.sum(share * fc**2))  # mean square of f over the band (energy-weighted) [Hz²]
    u = fc / math.sqrt(span2)  # in units of its RMS: the normal equations well conditioned
    design_f = np.column_stack([np.ones(n_bands), u, u**2])
    cov = np.linalg.inv(design_f.T @ (design_f / var[:, None]))
    power = np.maximum(np.abs(zb) ** 2, np.finfo(float).tiny)
    a = cov @ (design_f.T @ ((np.log(power) / 2 - np.log(share)) / var))
    b = cov @ (design_f.T @ (np.unwrap(np.angle(zb)) / var))
    scale4 = 4 / (span2**2 * (2 * np.pi) ** 4)
    return math.sqrt(scale4) * complex(a[2], b[2]), float(scale4 * 2 * cov[2, 2]), span2


def channel_bend_s2(f_hz: np.ndarray, energy: np.ndarray, channel: np.ndarray, n_bands: int = _N_BANDS) -> np.ndarray:
    """The curvature c [s²] (:func:`subband_bend`) the whole-frame fit reads from channels H(f) (rows of
    ``channel`` on the grid ``f_hz``, offsets from the carrier) seen through a pulse of spectral energy
    ``energy``, noiseless: the same equal-energy sub-bands and the same parabolas. Where ln H is not a
    parabola over the band (a merged echo near the null, f₀Δ near a whole cycle) the fit's c differs from
    d²ln H/df²/(2π)² at f₀: an image 0.9 at 22 µs, 0.1 cycle from the null, 18 % more; at 33 µs, 51 %."""
    order = np.argsort(f_hz)
    f_hz, energy, channel = f_hz[order], energy[order], np.atleast_2d(channel)[:, order]
    cum = np.cumsum(energy)
    which = np.minimum((cum / cum[-1] * n_bands).astype(int), n_bands - 1)
    e = np.bincount(which, energy, n_bands)
    share = e / e.sum()
    fb = np.bincount(which, energy * f_hz, n_bands) / e
    out = np.empty(len(channel), complex)
    for k, h in enumerate(channel):
        zb = (np.bincount(which, (energy * h).real, n_bands) + 1j * np.bincount(which, (energy * h).imag, n_bands)) / e.sum()
        out[k] = subband_bend(zb, share, fb, share / np.maximum(np.abs(zb) ** 2, np.finfo(float).tiny))[0]
    return out


def _peak_offset(mag: np.ndarray, i: int) -> float:
    """The offset in [−½, ½] of the peak of the parabola through ``mag[i − 1 : i + 2]`` from ``i`` (0 at an
    end of ``mag`` or where the three do not make a maximum)."""
    if not 0 < i < len(mag) - 1:
        return 0.0
    den = mag[i - 1] - 2 * mag[i] + mag[i + 1]
    return float(np.clip(0.5 * (mag[i - 1] - mag[i + 1]) / den, -0.5, 0.5)) if den < 0 else 0.0


def unmodelled_paths(resid: np.ndarray, template: np.ndarray, fs: float, config: FrameConfig, *,
                     deviations: float = 4.5, max_components: int = 16,
                     known_lags_s: tuple = (), near_lags_s: tuple | None = None) -> tuple[np.ndarray, list]:
    """The paths a fit left in its residual from :data:`_MISSED_AFTER_B`/B after the direct path on, found one
    after the other (CLEAN): (their sum on the residual's grid, [(lag [s], amplitude)]).

    ``template`` is the direct path's waveform at unit gain. The residual's correlation with it, from
    −:data:`_MISSED_AFTER_B`/B to a pilot's length after the direct path (``find_echoes``' reach), is
    searched for its largest peak (4× interpolated, then a parabola) that stands ``deviations`` noise σ's
    above it (the residual's power over the template's energy: a complex Gaussian beyond 4.5 σ, e^{−20}
    per lag); that component's exact contribution, its amplitude times the template's own correlation at
    the fractional lag, is taken out in the frequency domain, and the next peak sought. Components
    nearer the direct path than :data:`_MISSED_AFTER_B`/B (the misfit of a merged echo fitted with it,
    its pulse's derivative) are taken out of the correlation only, so that their sidelobes are not read
    as paths (at 60 dB, an image −0.9 at 8 µs: its misfit's sidelobes, taken for paths, bent the channel
    read 10× in its phase); the farther ones are the paths returned.

    ``near_lags_s``: when given, lags [s] after the template of the paths the fit models: only the components
    found within :data:`_NEAR_ECHO_B`/B of one of them are returned (their misfit), the others are taken out
    of the correlation only (``fit_whole_frame(echo_misfit=…)``).

    ``known_lags_s``: lags [s] relative to the template of paths merged with it that the receiver models (a
    surface image from the ends' depths: the direct path at −bias, the image at δ − bias). A fit of one
    path to them leaves a misfit within the span of their pulses and the template's, whose sidelobes reach
    1.8–1.9/B near the null (−0.9 at 33 µs); those pulses are projected out of the correlation before the
    search, so that only paths are found.

    The sub-band sums of the direct path's channel (its bend, ``curvature_s2``) see every unmodelled path
    within a few 1/B: a sub-band is B/4 wide, so a path at Δ ripples it by its amplitude times
    sinc(Δ·B/4) (the corpus's far family at 6 dB: bottom paths 0.12–0.15 at 265–533 µs, below the pilot
    fit's 0.15, bent the channel 10 times as much as the merged surface image did, a 30 mm bound). They
    are taken out of the direct path's sub-bands, not fitted (their gains' error is noise's there).
    """
    import scipy.fft

    n = len(resid)
    near = _MISSED_AFTER_B * fs / config.bandwidth_hz  # [samples]
    hi = min(float(n - 1), config.n_pilot * config.symbol_period_s * fs)
    energy = float(np.sum(np.abs(template) ** 2))
    if not energy > 0 or hi <= near:
        return np.zeros(n, complex), []
    m = scipy.fft.next_fast_len(2 * n)
    k = scipy.fft.fftfreq(m) * m  # signed bins
    t_spec = scipy.fft.fft(template, m)
    c_spec = scipy.fft.fft(resid, m) * np.conj(t_spec) / energy  # the correlation's spectrum, at path scale
    own = np.abs(t_spec) ** 2 / energy  # one unit path at lag 0
    var = float(np.mean(np.abs(resid) ** 2)) / energy
    if len(known_lags_s):
        # the modelled paths' pulses (and the template's own) out of the correlation: their misfit is no path
        basis = own[:, None] * np.exp(-2j * np.pi * k[:, None] * np.concatenate([[0.0], known_lags_s])[None, :]
                                      * fs / m)
        c_spec = c_spec - basis @ np.linalg.lstsq(basis, c_spec, rcond=None)[0]
    up = 4
    lags = np.arange(-int(near * up), int(hi * up) + 1)  # [samples / up], negative ones wrapped
    half = m // 2
    found, total = [], np.zeros(m, complex)
    for _ in range(max_components):
        big = np.zeros(up * m, complex)
        big[:half], big[-(m - half):] = c_spec[:half], c_spec[half:]
        mag = np.abs(scipy.fft.ifft(big)[lags % (up * m)]) * up
        i = int(np.argmax(mag))
        if mag[i] ** 2 < deviations**2 * var:
            break
        lag = (lags[i] + _peak_offset(mag, i)) / up  # [samples]
        ramp = np.exp(-2j * np.pi * k * lag / m)
        amp = complex(np.sum(c_spec * np.conj(ramp)) / np.sum(own))  # least squares at that lag
        c_spec = c_spec - amp * own * ramp
        if lag >= near and (near_lags_s is None or np.any(np.abs(np.asarray(near_lags_s) * fs - lag)
                                                          <= _NEAR_ECHO_B * fs / config.bandwidth_hz)):
            total += amp * t_spec * ramp
            found.append((lag / fs, amp))
    return scipy.fft.ifft(total)[:n], found


def earlier_path(resid: np.ndarray, template: np.ndarray, fs: float, config: FrameConfig, *,
                 reach_s: float, nearest_b: float = EARLIER_NEAREST_B) -> tuple[float, complex, float] | None:
    """The strongest component of a fit's residual that arrives before the direct path: (its lag after the
    direct path [s], < 0; its amplitude at the direct path's scale; |amplitude|² over its noise expectation),
    None when the search window is empty or the template has no energy.

    ``template`` is the direct path's waveform at unit gain on the residual's grid. The residual's
    correlation with it (zero-padded: linear) is read at the whole lags from −``reach_s`` to −``nearest_b``/B,
    the largest taken, its lag refined by a parabola through |c|. Its noise expectation is the residual's
    power over the template's energy (a complex Gaussian: |c|²/var beyond x with probability e^{−x} per
    lag). Nearer than a few 1/B the misfit of a merged echo fitted with the direct path (its pulse's
    derivative) and its sidelobes peak (decoded corpus frames: up to 98 times the noise at 2–3/B, 0.02–0.05
    of the direct path); beyond, the 235 decoded frames of 24 corpus recordings held at most 22 times it,
    median 8 (fits on wrong decisions more: their residual is the frame). A frame whose direct path faded
    below the pilot fit's threshold (a surface image near its null) shows it here: 740–894 times its
    noise, 0.85 of the path taken, 0.42 ms before it (``FrameMeasurer._whole_frame``).
    """
    import scipy.fft

    n = len(resid)
    energy = float(np.sum(np.abs(template) ** 2))
    far = min(int(reach_s * fs), n - 1)
    near = int(math.ceil(nearest_b * fs / config.bandwidth_hz))
    if not energy > 0 or far <= near + 1:
        return None
    m = scipy.fft.next_fast_len(2 * n)
    corr = scipy.fft.ifft(scipy.fft.fft(resid, m) * np.conj(scipy.fft.fft(template, m))) / energy
    lags = np.arange(-far, -near + 1)  # [samples], wrapped to the end of the padded correlation
    mag = np.abs(corr[lags % m])
    i = int(np.argmax(mag))
    var = float(np.mean(np.abs(resid) ** 2)) / energy
    value = complex(corr[lags[i] % m])
    return (lags[i] + _peak_offset(mag, i)) / fs, value, float(abs(value) ** 2 / var) if var > 0 else math.inf


def split_clusters(fit: WholeFrameFit, refit, direct_s: float, *, config: FrameConfig,
                   splits: int = 1) -> WholeFrameFit:
    """The fit with up to ``splits`` echoes that are clusters of paths resolved, each into two paths.

    An echo whose own channel bends beyond its noise (``WholeFrameFit.curvature_s2``: |c|² beyond
    :data:`_SPLIT_BEND` times its noise expectation) is two or more paths fitted as one: a bottom path and
    its surface image 1/B apart, at long range. Its misfit leaks into the direct path's sub-bands through
    the pulse's sidelobes (the corpus's far family at 15 dB, the ends' depths given: the direct path's
    bend 7–45 times its noise where the fit had one path for two, 1–5 where it had both), and the bend
    bound (``FrameMeasurer``) reads it as a merged echo of the direct path's. The most bent echo is
    replaced by two paths 1/B apart (:data:`_SPLIT_WIDTH`): the echo and one after it, one before it,
    or either side of it, since the fitted echo lies near the stronger of the two (none within 1/B of
    the direct path, before the fit or after it: a path there couples with the direct one, whose
    channel's shape is the bend bound's to judge); the frame is fitted
    again from each (``refit(delays)``), and the best kept when its residual dropped by more than two
    added paths explain by chance (:data:`_SPLIT_GAIN`).

    Parameters
    ----------
    fit : WholeFrameFit
        The frame's fit.
    refit : callable
        ``refit(delays_s)``: the frame fitted again from these paths' arrivals.
    direct_s : float
        The direct path's arrival [s] (never split: a merged echo there is the bend bound's).
    config : FrameConfig
        The frame (its band).
    splits : int
        Most echoes split, one after the other.
    """
    width_s = _SPLIT_WIDTH / config.bandwidth_hz
    for _ in range(splits):
        if fit.curvature_s2 is None:
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            bends = np.abs(fit.curvature_s2) ** 2 / fit.curvature_noise_s4
        bends[int(np.argmin(np.abs(fit.delays_s - direct_s)))] = np.nan
        if not np.any(bends > _SPLIT_BEND):
            break
        q = int(np.nanargmax(bends))
        best = fit
        for pair in ((0.0, width_s), (-width_s, 0.0), (-width_s / 2, width_s / 2)):
            if fit.delays_s[q] + pair[0] - direct_s < width_s:
                continue  # a path within 1/B of the direct one: the bend bound's, not a split's
            trial = refit(np.concatenate([np.delete(fit.delays_s, q), fit.delays_s[q] + np.array(pair)]))
            others = np.abs(trial.delays_s - direct_s)
            if np.count_nonzero(others < width_s) > 1:
                continue  # the fit moved one there
            if trial.noise_var < best.noise_var:
                best = trial
        if not fit.n_reference * (fit.noise_var - best.noise_var) / best.noise_var > _SPLIT_GAIN:
            break
        fit = best
    return fit


#: the misfit of an echo the fit models (a cluster fitted as one path, an echo that moved) is taken out of the
#: direct path's sub-bands within this many 1/B of the echo's fitted lag (``fit_whole_frame(echo_misfit=…)``)
_NEAR_ECHO_B = 2.0


def _segment_gain(phase, counts, amp, t_mid_s, t_s):
    """A path's gain over the frame relative to its fitted one (``amp``), from its segments' sums (``phase``:
    their sums and centres after ``t_mid_s``, as ``phase_fit`` keeps them), linear between the segments'
    centres on the grid ``t_s`` (1 when the fitted gain is 0)."""
    zs, ts = phase
    if not abs(amp) > 0:
        return 1.0
    g = (zs / counts) / amp
    return np.interp(t_s, ts + t_mid_s, g.real) + 1j * np.interp(t_s, ts + t_mid_s, g.imag)


#: the pilot's outputs are split in this many parts, each with its own gain, for a path's Es/N0 over the pilot
_PILOT_GAIN_SEGMENTS = 5


def fit_whole_frame(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    symbols: np.ndarray,
    reference: np.ndarray,
    delays_s,
    v_mps: float,
    sound_speed_mps: float,
    n_segments: int = 32,
    sweeps: int = 4,
    direct_s: float | None = None,
    split: int = 0,
    clean: bool = False,
    clean_lags_s: tuple = (),
    echo_bends: bool | None = None,
    earlier_reach_s: float = 0.0,
    segment_gains: bool = True,
    echo_misfit: str | None = "larger",
) -> WholeFrameFit:
    """Fit every path's gain, mean Doppler and drift over the whole frame.

    Parameters
    ----------
    bb : numpy.ndarray, complex
        Data-band baseband, bb[n] at t0 + n/fs [s].
    symbols : numpy.ndarray, complex, shape (n_pilot + n_data,)
        The frame's symbols: known, or decided.
    reference : numpy.ndarray of bool, shape (n_pilot + n_data,)
        Which symbols are trusted as the reference (the others are neither
        fitted nor subtracted).
    delays_s : array_like
        Frame-start arrival of each resolved path [s] (from the pilot fit).
    v_mps : float
        Starting closing speed of every path [m/s] (tone or pilot bank).
    n_segments : int
        Segments whose phases the Doppler and the drift are fitted to.
    sweeps : int
        Most passes over the paths; the fit stops after a pass that moved no
        path's Doppler by a quarter of its σ nor its delay by its σ (the first pass always
        has a second: it ran before the later paths were subtracted, and the
        delays are updated from the second pass on).
    direct_s : float, optional
        Arrival of the direct path [s]: the path nearest to it gets the
        sub-band analysis of ``tilt_delay_s`` (default: the earliest path).
    split : int
        Most echoes that are clusters of paths split in two, the frame fitted again
        each time (:func:`split_clusters`; default none).
    clean : bool
        Read the direct path's bend after the paths the fit left in its residual, 1.5/B
        after it and later, are taken out (:func:`unmodelled_paths`). The receiver
        does so when the ends' depths are given (``FrameMeasurer``).
    clean_lags_s : tuple of float
        Lags [s] after the direct path's fitted arrival of paths merged with it that
        are modelled (the surface image from the ends' depths: −bias and δ − bias),
        projected out before the paths are sought (:func:`unmodelled_paths`).
    echo_bends : bool, optional
        Read each echo's own bend too (``curvature_s2``; default: with ``split``).
    earlier_reach_s : float
        Look this far [s] before the direct path for a component the fit left in its residual
        (``earlier_path``; default 0: not looked for).
    segment_gains : bool
        Read the direct path's bend with the other paths 1.5/B or more from every path taken out at their
        gains segment by segment (default) rather than at their one fitted gain (a nearer one's segment
        sums are its pair's: split clusters' bends 13–29 times their noise). An echo that fades within the
        frame leaves its gain's change in the residual, a copy of the frame Δ later that a sub-band (B/4
        wide) does not resolve from the direct path: an echo 0.9 at 500 µs, its gain turning at 1.5 Hz,
        bent the direct path 20–32 times its noise with one gain, 0.1–0.4 segment by segment, its arrival
        unchanged (tests/receive/test_channel_bend.py).
    echo_misfit : {"larger", "out", None}
        Without ``clean``: ``"out"`` takes out of the direct path's sub-bands the components the residual
        holds within 2/B of a fitted echo (:func:`unmodelled_paths` restricted to them), the misfit of a
        cluster fitted as one path (−0.8 and 0.6 80 µs apart: bends 8–14 times the noise, 0.3–0.8 without
        it; a near-cancelling pair, 0.8 and −0.7 90 µs apart, 22–41 → 4–12; within 1/B only, the part left
        bent some frames more than the whole misfit had). ``"larger"`` (default) reads the bend with and
        without the misfit and keeps the larger: without the depths, a merged surface image's bend and a
        cluster's misfit are not told apart, and either may mask the other. On the corpus's far family
        the misfit taken out unmasked an image's bend on one recording (fresh seed 5171282, −0.5 dB: up
        to 7.1σ → within 1σ) and took away the bound that covered the image on three others (errors 4–15
        mm, σ 15–32 → 0.9–4.5 mm, up to 7.3σ). ``None``: neither (before session 27).
    """
    if echo_misfit not in ("larger", "out", None):
        raise ValueError(f"echo_misfit must be 'larger', 'out' or None, got {echo_misfit!r}")
    c = sound_speed_mps
    f0 = config.carrier_hz
    delays = np.sort(np.asarray(delays_s, dtype=float))
    n_paths = len(delays)
    x = np.where(reference, np.asarray(symbols, dtype=complex), 0.0)
    ref_idx = np.flatnonzero(reference)
    n_ref = ref_idx.size
    if n_ref < 4 * n_segments or n_paths == 0:
        raise ValueError(f"fit_whole_frame needs at least {4 * n_segments} reference symbols and a path")
    eps = np.full(n_paths, v_mps / c)
    beta = np.zeros(n_paths)
    amps = np.zeros(n_paths, complex)
    lo = max(0, int((delays[0] - t0_s) * fs) - config.srrc_span_symbols * int(fs * config.symbol_period_s + 1))
    hi = min(len(bb), int((delays[-1] + config.frame_duration_s - t0_s) * fs) + 1)
    seg = FrameSegment(hi - lo, fs, t0_s + lo / fs, config=config)
    seg_bb = bb[lo:hi]
    models = np.zeros((n_paths, hi - lo), complex)
    total = np.zeros(hi - lo, complex)  # Σ models
    # segments of equal reference-symbol counts
    edges = np.linspace(0, n_ref, n_segments + 1).round().astype(int)
    seg_of = np.searchsorted(edges, np.arange(n_ref), side="right") - 1
    counts = np.bincount(seg_of, minlength=n_segments).astype(float)
    half = config.frame_duration_s / 2

    def model(p):
        inst = symbol_instants(config, delays[p], eps[p], beta[p])
        shape = seg.synthesize(x, inst, scale=1 + eps[p])
        return amps[p] * shape * np.exp(1j * path_phase(config, seg.t_s - delays[p], eps[p], beta[p]))

    def outputs(p, r, count=None):
        """Symbols stripped matched-filter outputs z_k of path p and their time derivatives, drift phase removed;
        with ``count``, the first ``count`` reference symbols' outputs alone, without the derivatives (None)."""
        idx = ref_idx if count is None else ref_idx[:count]
        inst = symbol_instants(config, delays[p], eps[p], beta[p])[idx]
        y = seg.filter(r, inst, scale=1 + eps[p], offset_hz=f0 * eps[p], t_ref_s=delays[p],
                       derivative=count is None)
        strip = np.exp(-1j * path_phase(config, inst - delays[p], 0.0, beta[p])) * np.conj(x[idx])
        if count is not None:
            return y * strip, None, inst
        y, dy = y
        return y * strip, dy * strip, inst

    def timing_fit(z, dz, p):
        """Data-aided timing error of path p's instants [s] and its σ from the segments' scatter.

        Near the right instants y_k ≈ A x_k R(δ) with R the pulse's autocorrelation
        (R(0) = 1, R''(0) = −(2πβ)², β the Gabor bandwidth), so Σ dz ≈ n A R''(0) δ
        and Σ z ≈ n A per segment: δ_seg = Re(Σdz·conj(Σz)) / (|Σz|² R''(0)).
        """
        r2 = -(2 * np.pi * gabor_bandwidth_hz(config.symbol_rate_hz * (1 + eps[p]), config.rolloff)) ** 2
        zs = np.bincount(seg_of, z.real, n_segments) + 1j * np.bincount(seg_of, z.imag, n_segments)
        dzs = np.bincount(seg_of, dz.real, n_segments) + 1j * np.bincount(seg_of, dz.imag, n_segments)
        power = np.maximum(np.abs(zs) ** 2, np.finfo(float).tiny)
        d_seg = np.real(dzs * np.conj(zs)) / (power * r2)
        w = power / counts
        d = float(np.sum(w * d_seg) / np.sum(w))
        last_timing[p] = (d_seg, w)
        return d, math.sqrt(float(np.sum(w * (d_seg - d) ** 2)) / ((n_segments - 1) * float(np.sum(w))))

    def phase_fit(z, inst, p):
        """Weighted LS line + parabola through the segments' phases: (coefficients, σ of the slope)."""
        zs = np.bincount(seg_of, z.real, n_segments) + 1j * np.bincount(seg_of, z.imag, n_segments)
        ts = np.bincount(seg_of, inst, n_segments) / counts - (delays[p] + half)
        phi = np.unwrap(np.angle(zs))
        w = np.abs(zs) ** 2 / counts  # ∝ segment SNR: phase variance 1/(2·SNR)
        design = np.column_stack([np.ones(n_segments), ts, ts**2])
        # the normal equations (3 × 3, times within ±D/2: well conditioned), their inverse the covariance's shape
        g_inv = np.linalg.inv(design.T @ (design * w[:, None]))
        coef = g_inv @ (design.T @ (w * phi))
        last_phase[p] = (zs, ts)
        resid = phi - design @ coef
        s2 = float(np.sum(w * resid**2) / (n_segments - 3))
        return coef, math.sqrt(max(s2 * g_inv[1, 1], 0.0))

    sigma_b = np.full(n_paths, math.inf)
    sigma_d = np.full(n_paths, math.inf)
    last_outputs: dict = {}
    last_phase: dict = {}
    last_timing: dict = {}
    quarter = config.symbol_period_s / 4
    # SAGE: each sweep filters every path once, the others' fitted contributions removed. The
    # Doppler found moves the symbol instants, so a path, a lone one too, is filtered again in
    # the next sweep; the fit stops after a sweep that moved no path's Doppler by a quarter of
    # its σ nor its delay by its σ (three paths at 12 dB: 3 sweeps, 10 filters and 9 syntheses)
    def sweep(update_delays: bool) -> bool:
        """One SAGE pass over the paths; whether it moved any path's Doppler or delay beyond its step."""
        moved = False
        for p in range(n_paths):
            z, dz, inst = outputs(p, seg_bb - (total - models[p]) if n_paths > 1 else seg_bb)
            last_outputs[p] = (z, dz, 1 + eps[p])
            coef, sigma_b[p] = phase_fit(z, inst, p)
            delta, sigma_d[p] = timing_fit(z, dz, p)
            eps[p] += coef[1] / (2 * np.pi * f0)
            beta[p] += coef[2] / (np.pi * f0)
            if update_delays:  # the first sweep's Doppler error skews the instants' timing (overshoots by 10σ)
                delays[p] -= float(np.clip(delta, -quarter, quarter))
            moved |= bool(abs(coef[1]) > _STEP_DOPPLER * sigma_b[p] or abs(delta) > _STEP_DELAY * sigma_d[p])
            # the amplitude from the outputs, less the phase the update added to the model
            # (c1·(t − τ_p) + c2·((t − t_c)² − (D/2)²)); the update moves the instants by a hair
            tk = inst - (delays[p] + half)
            amps[p] = np.mean(z * np.exp(-1j * (coef[1] * (tk + half) + coef[2] * (tk**2 - half**2))))
            if n_paths > 1:
                new = model(p)
                total[:] += new - models[p]
                models[p] = new
        return moved

    def joint_step(damping: float) -> tuple[bool, float]:
        """A damped Gauss–Newton (Levenberg–Marquardt) step on every path's delay and gain together, kept
        only if it lowers the residual energy and leaves every pair identifiable (κ at the worst phase
        within ``_IDENTIFIABLE_KAPPA``); (whether it moved a delay beyond a tenth of its σ, the next
        damping). Each path's own (conditional) step g_p, the others held, is J_pp⁻¹ of its gradient:
        the joint step solves (J + λ·diag J)·s = diag J·g (J from :func:`delay_gain_information`)."""
        info = delay_gain_information(delays, amps, config=config, v_mps=eps * c, sound_speed_mps=c)
        own = np.zeros(3 * n_paths)
        for p in range(n_paths):
            z, dz, _ = outputs(p, seg_bb - (total - models[p]))
            own[3 * p] = -timing_fit(z, dz, p)[0]
            gain = np.mean(z) - amps[p]
            own[3 * p + 1], own[3 * p + 2] = gain.real, gain.imag
        before = float(np.sum(np.abs(seg_bb - total) ** 2))
        saved = (delays.copy(), amps.copy(), models.copy(), total.copy())
        for _ in range(3):
            try:
                step = np.linalg.solve(info + damping * np.diag(np.diag(info)), np.diag(info) * own)
            except np.linalg.LinAlgError:
                return False, damping
            if not np.all(np.isfinite(step)):
                return False, damping
            moves = np.clip(step[0::3], -quarter, quarter)
            delays[:] = saved[0] + moves
            amps[:] = saved[1] + step[1::3] + 1j * step[2::3]
            if np.max(joint_delay_inflation(delays, np.abs(amps), config=config)) > _IDENTIFIABLE_KAPPA:
                damping *= 10  # towards one blurred path: a shorter step
                continue
            for p in range(n_paths):
                models[p] = model(p)
            total[:] = models.sum(axis=0)
            if float(np.sum(np.abs(seg_bb - total) ** 2)) < before:
                return bool(np.any(np.abs(moves) > 0.1 * sigma_d)), damping / 10
            damping *= 10
        delays[:], amps[:], models[:], total[:] = saved
        return False, damping

    for k in range(sweeps):
        if not sweep(update_delays=k > 0) and k > 0:
            break
    # SAGE moves one path at a time: where an echo overlaps a path (within the pulse's width), the two trade
    # delay against gain and the passes contract slowly (an echo 0.35 at 91 µs, noiseless: the direct path
    # 5 µs off after the first delay update, still 3 µs after 8 passes). Joint steps where the paths couple,
    # then a pass (every path's σ's and phases at the joint solution, where its own step is nil)
    if n_paths > 1 and np.max(joint_delay_inflation(delays, amps, config=config, v_mps=eps * c,
                                                    sound_speed_mps=c)) > _COUPLED_KAPPA \
            and np.max(joint_delay_inflation(delays, np.abs(amps), config=config)) <= _IDENTIFIABLE_KAPPA:
        damping = 1e-3
        for _ in range(_JOINT_STEPS):
            moved, damping = joint_step(damping)
            if not moved:
                break
        sweep(update_delays=True)
    if n_paths == 1:
        total = model(0)
    # each path's timing σ from its segments' scatter without the known symbols' intersymbol terms in its
    # derivative outputs (the pulse's derivative at whole symbols, odd in the lag: :func:`intersymbol_slopes`),
    # which sum over a segment to pairs across its two ends and cancel between neighbours in the frame's mean.
    # Left in, they were the scatter at high SNR and no error of the arrival: a lone path at 25 dB, σ 2.7–3.3
    # times its CRLB (the corpus's steep family with its echoes removed, 8–17 dB: 1.4–1.5 times, lag-one
    # correlation of the segments' timings −0.26, the errors at 0.95 of the CRLB; tests/receive/test_wholeframe.py).
    # Taken out of the last pass's outputs at its gain, they give the σ that the path's own model taken out of
    # the frame's residual does, without another filter pass (which cost 10–12 % of the decoding receiver):
    # within 0.1 % on analytic frames (one path and three, 10 and 25 dB); on a corpus seed's 600 rows the
    # same ranges, range σ's median ratio 1.000, 4 rows 2–11 % apart (that pass's last update not in them)
    # (the terms scale with the path's time scale alone: the symbols' sums once per fit, at scale 1)
    unit_slopes = intersymbol_slopes(x, ref_idx, config, 1.0) if last_outputs else None
    for p, (z, dz, scale) in last_outputs.items():
        known = unit_slopes * (scale * np.mean(z))
        sigma_d[p] = timing_fit(z, dz - known, p)[1]
    # noise per matched-filter output from the residual of all paths, at the first path's instants
    resid = seg_bb - total
    inst = symbol_instants(config, delays[0], eps[0], beta[0])[ref_idx]
    noise = seg.filter(resid, inst, scale=1 + eps[0], offset_hz=f0 * eps[0], t_ref_s=delays[0])
    noise_var = max(float(np.mean(np.abs(noise) ** 2)), np.finfo(float).tiny)
    # the pilot's own outputs' noise: its mean over the median-implied power (1 for Gaussian noise), the
    # impulses that blanking left where the pilot lies (the noise windows around the frame may miss them)
    pilot_excess = max(1.0, power_excess(np.abs(noise[: config.n_pilot]) ** 2) or 1.0)
    # each path's Es/N0 over the pilot alone, the other paths taken out: the known pilot gives each path's gain
    # whatever the data decisions (a fit on decisions has them wrong in runs, which shrinks every path's fitted
    # gain and would leave part of each echo in the others' outputs), the outputs' scatter about it the noise
    # there, which blanking may leave larger than the noise windows around the frame show (α-stable noise:
    # impulses the signal hides from the blanker's robust scale)
    pilot_es_n0 = np.full(n_paths, math.nan)
    if config.n_pilot >= 4 * _PILOT_GAIN_SEGMENTS and np.all(np.asarray(reference)[: config.n_pilot]):
        unit = np.array([m / a if abs(a) > 0 else np.zeros_like(m) for m, a in zip(models, amps)]) \
            if n_paths > 1 else None
        gains = amps.copy()
        for _ in range(3 if n_paths > 1 else 1):  # Gauss–Seidel over the paths' pilot gains
            for p in range(n_paths):
                others = 0.0 if n_paths == 1 else np.tensordot(np.delete(gains, p), np.delete(unit, p, axis=0), 1)
                zp = outputs(p, seg_bb - others, config.n_pilot)[0]
                gains[p] = np.mean(zp)
                # the gain segment by segment: a phase the fit's Doppler leaves over the pilot (a fit on
                # wrong decisions bends it) is not noise to the pilot's own arrival, which fits its own Doppler
                parts = np.array_split(zp, _PILOT_GAIN_SEGMENTS)
                spread = sum(float(np.sum(np.abs(q - np.mean(q)) ** 2)) for q in parts) \
                    / (config.n_pilot - len(parts))
                power = np.mean([abs(np.mean(q)) ** 2 for q in parts]) - spread / (config.n_pilot / len(parts))
                pilot_es_n0[p] = max(power, 0.0) / max(spread, np.finfo(float).tiny)
    es_n0 = np.abs(amps) ** 2 / noise_var
    crlb = known_signal_velocity_crlb_mps(config, es_n0, n_ref, sound_speed_mps=c)
    sigma_ls = c * sigma_b / (2 * np.pi * f0)
    # delay CRLB of a known signal of n symbols: 1/(2πβ√(2 n Es/N0)) (SPEC §6, with the whole frame's energy)
    crlb_d = 1.0 / (2 * np.pi * gabor_bandwidth_hz(config.symbol_rate_hz, config.rolloff)
                    * np.sqrt(2 * n_ref * np.maximum(es_n0, 1e-30)))
    amp_rate = np.zeros(n_paths)
    amp_rate_terms = np.zeros((n_paths, 2, 2))
    scatter = np.zeros(n_paths)
    tilt = np.zeros(n_paths)
    curv, curv_noise = np.zeros(n_paths, complex), np.zeros(n_paths)
    for p in range(n_paths):
        zs, ts = last_phase[p]
        # ln|Σz| has the phase's noise variance, 1/(2 SNR_seg) = counts·noise_var/(2|Σz|²); each term of the
        # rate less its noise expectation (not beyond 3 of its σ, as a gap between two estimates: that leaves
        # 0 on most fading frames, and the fading direct path's Doppler 6–25σ off with it, the phase rate
        # being a second, independent draw of the same scale), whose noise-only remainder adds at most the
        # fit's own σ
        var = counts * noise_var / (2 * np.maximum(np.abs(zs) ** 2, np.finfo(float).tiny))
        log_amp = np.log(np.maximum(np.abs(zs), np.finfo(float).tiny))
        amp_rate[p], amp_rate_terms[p] = log_amplitude_rate(log_amp, var, ts,
                                                            duration_s=config.frame_duration_s)
        d_seg, wt = last_timing[p]
        dm = float(np.sum(wt * d_seg) / np.sum(wt))
        spread2 = float(np.sum(wt * (d_seg - dm) ** 2) / np.sum(wt))
        # the noise's share: (n − 1) σ_mean² for independent segments, σ_mean from the timing CRLB per segment
        seg_crlb2 = float(crlb_d[p]) ** 2 * n_segments
        scatter[p] = math.sqrt(max(spread2 - seg_crlb2 * (n_segments - 1) / n_segments, 0.0))
    # the earliest path's channel across its band: ln|z| of 4 equal-energy sub-bands, a line and a parabola
    # in f; the RMS of its slope over the band (less the noise's) as a delay: a merged echo b at Δ makes the
    # channel 1 + b e^{−j2πfΔ}, whose log-amplitude slope and group-delay error (the arrival's bias) are the
    # imaginary and real parts of one number (the curvature brings in the real part where the slope is 0)
    # (with echo_bends, the same for every echo as strong as _BEND_MIN_FRACTION of the strongest path: a bend
    # there is a cluster of paths fitted as one, which ``split`` resolves; its tilt is not counted)
    direct = int(np.argmin(delays if direct_s is None else np.abs(delays - direct_s)))
    strongest = float(np.max(np.abs(amps)))
    if echo_bends is None:
        echo_bends = split > 0
    # each path 1.5/B or more from every other: what its gain segment by segment adds to its one fitted gain's
    # model (a nearer one keeps its one gain: its segments' sums are the pair's)
    fades = {}
    if n_paths > 1 and segment_gains:
        for q in range(n_paths):
            if np.all(np.abs(np.delete(delays, q) - delays[q]) * config.bandwidth_hz >= _MISSED_AFTER_B):
                fades[q] = models[q] * (1.0 - _segment_gain(last_phase[q], counts, amps[q], delays[q] + half,
                                                            seg.t_s))
    for p in range(n_paths):
        if p != direct and not (echo_bends and abs(amps[p]) >= _BEND_MIN_FRACTION * strongest):
            curv[p], curv_noise[p] = complex(math.nan, math.nan), math.nan
            continue
        r_p = seg_bb - (total - models[p]) if n_paths > 1 else seg_bb
        if fades:
            r_p = r_p + sum(f for q, f in fades.items() if q != p)
        # (the residual of the paths as taken out: segment by segment, an echo's fading is not in it)
        resid_p = r_p - models[p] if n_paths > 1 else resid
        if clean and p == direct and abs(amps[p]) > 0:
            # less the paths the fit left in its residual: they ripple the sub-bands (unmodelled_paths)
            r_p = r_p - unmodelled_paths(resid_p, (models[p] if n_paths > 1 else total) / amps[p], fs, config,
                                         known_lags_s=tuple(clean_lags_s))[0]
        readings = [r_p]
        if echo_misfit is not None and not clean and p == direct and n_paths > 1 and abs(amps[p]) > 0:
            # less the fitted echoes' misfit (a cluster fitted as one path), which ripples them alike
            out = r_p - unmodelled_paths(resid_p, models[p] / amps[p], fs, config,
                                         near_lags_s=tuple(np.delete(delays, p) - delays[p]))[0]
            readings = [out] if echo_misfit == "out" else [r_p, out]
        inst_p = symbol_instants(config, delays[p], eps[p], beta[p])[ref_idx]
        strip = np.exp(-1j * path_phase(config, inst_p - delays[p], 0.0, beta[p])) * np.conj(x[ref_idx])
        bends = []
        for r in readings:
            zb, share, fb = seg.band_sums(r, inst_p, strip, scale=1 + eps[p], offset_hz=f0 * eps[p],
                                          t_ref_s=delays[p], n_bands=_N_BANDS)
            if np.all(share > 0):
                power = np.maximum(np.abs(zb) ** 2, np.finfo(float).tiny)
                # no sub-band without energy, nor one without noise (a noiseless fit): each ln|z| at least 1e-12
                # of variance
                var = np.maximum(n_ref * noise_var * share / (2 * power), 1e-12)
                bends.append(subband_bend(zb, share, fb, var))
        if len(bends) == len(readings):
            # (with the misfit read both ways, the larger bend: without the depths, a merged image's bend and a
            # cluster's misfit are not told apart, and either may mask the other)
            curv[p], curv_noise[p], span2 = max(bends, key=lambda b: abs(b[0]) if cmath.isfinite(b[0]) else -1.0)
            # the bias lies within ± the bound, its sign and size set by the echo's phase: its σ is that of a uniform
            # spread over it, bound/√3. A bend beyond |c| ≈ 1/2 is more than a weaker echo gives (several, or one
            # stronger than the path): the slope's RMS over the band, 2|c|/(2π span), the larger there, is the scale
            # (|c|² beyond 3 of its noise σ, as the amplitude rate)
            c4 = abs(curv[p]) ** 2 - 9 * curv_noise[p]
            if math.isfinite(c4) and c4 > 0 and p == direct:
                tilt[p] = max(c4**0.25 / math.sqrt(3), 2 * np.pi * math.sqrt(c4 * span2))
        else:
            # a sub-band the reference put no energy in (a fit on few trusted decisions): no curvature to read
            curv[p], curv_noise[p] = complex(math.nan, math.nan), math.nan
    # each path's delay σ above is the one with the other paths at their fitted values; fitted together,
    # an echo within the pulse's width trades its gain against the path's delay
    sigma_delay = joint_delay_sigma_s(np.maximum(sigma_d, crlb_d), delays, amps, config=config, v_mps=eps * c,
                                      sound_speed_mps=c)
    order = np.argsort(delays)
    fit = WholeFrameFit(
        delays_s=delays[order],
        amplitudes=amps[order],
        v_mps=(eps * c)[order],
        accel_mps2=(beta * c)[order],
        sigma_v_mps=np.maximum(sigma_ls, crlb)[order],
        crlb_v_mps=crlb[order],
        es_n0=es_n0[order],
        sigma_delay_s=sigma_delay[order],
        n_reference=int(n_ref),
        amp_rate_hz=amp_rate[order],
        amp_rate_terms=amp_rate_terms[order],
        delay_scatter_s=scatter[order],
        tilt_delay_s=tilt[order],
        curvature_s2=curv[order],
        curvature_noise_s4=curv_noise[order],
        pilot_noise_excess=pilot_excess,
        pilot_es_n0=pilot_es_n0[order],
        noise_var=noise_var,
        earlier_path=earlier_path(resid, (models[direct] if n_paths > 1 else total) / amps[direct], fs, config,
                                  reach_s=earlier_reach_s) if earlier_reach_s > 0 and abs(amps[direct]) > 0 else None,
    )
    if split > 0:
        def refit(trial_delays):
            return fit_whole_frame(bb, fs, t0_s, config=config, symbols=symbols, reference=reference,
                                   delays_s=trial_delays, v_mps=v_mps, sound_speed_mps=sound_speed_mps,
                                   n_segments=n_segments, sweeps=sweeps, direct_s=direct_s, clean=clean,
                                   clean_lags_s=clean_lags_s,
                                   echo_bends=True, earlier_reach_s=earlier_reach_s)

        fit = split_clusters(fit, refit, float(delays[direct]), config=config, splits=split)
    return fit
