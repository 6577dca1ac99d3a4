"""Fine arrival time and Doppler of one frame from its basebands.

Model (SPEC §1, constant v over the pilot): the frame received from t_a on is
s((t − t_a)(1 + ε)), ε = v_r/c, so in the data baseband (carrier f0)

    r(t) = A Σ_k x_k √T' g_{T'}(t − t_a − (Ng + k)T') e^{j2π f0 ε (t − t_a)},  T' = T/(1 + ε),

and in the tone baseband (carrier f_pt) the tone is a w(·) e^{j2π f_pt ε t}.

* :func:`fit_pilot` — paper 002's filter bank, refined: the detector's bank
  of Doppler-shifted pilot replicas gives a coarse ε; here ε is refined by
  dichotomy on the Doppler-scaled pilot correlation |Σ a_k* y_k(t_a, ε)|, and
  t_a by parabolic interpolation of the same correlation evaluated at
  arbitrary times (the pulse is evaluated analytically, so the estimate is
  not tied to the sampling grid).
* :func:`tone_track_eq9` — paper 000 eq 9 / paper 002: phase derivative of the
  low-passed tone, v̂(kT_s) = c/(2π T_s f_pt)·arg(r(kT_s) r*((k−1)T_s)).
* :func:`tone_frequency_ml` — maximum-likelihood frequency of the tone over the
  whole frame (periodogram peak, refined by dichotomy): efficient above
  threshold, i.e. it reaches the Rife–Boorstyn bound of SPEC §6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import scipy.fft
from numba import njit

from ..config import FrameConfig
from ..dsp import UniformTable, windowed_sinc_lowpass
from ..transmit.frame import tone_envelope
from ..transmit.pulse import srrc_pulse, srrc_truncation_energy

__all__ = [
    "matched_filter",
    "pilot_correlation",
    "PilotFit",
    "fit_pilot",
    "ToneFit",
    "tone_frequency_ml",
    "tone_track_eq9",
    "dichotomy_max",
    "tone_segment",
    "log_amplitude_rate",
]


def dichotomy_max(f, lo: float, hi: float, *, tol: float, max_iter: int = 200) -> float:
    """Maximiser of a unimodal f on [lo, hi] by dichotomy (interval halving).

    Each step compares f at the midpoint ± a quarter of ``tol`` and keeps the
    half that holds the larger value.
    """
    eps = tol / 4
    for _ in range(max_iter):
        if hi - lo <= tol:
            break
        mid = 0.5 * (lo + hi)
        if f(mid - eps) < f(mid + eps):
            lo = mid - eps
        else:
            hi = mid + eps
    return 0.5 * (lo + hi)


#: samples per symbol period of the tabulated pulse the matched filter interpolates
_PULSE_TABLE_RATE = 2048


@lru_cache(maxsize=16)
def _srrc_table(rolloff: float, n_half: int) -> UniformTable:
    """√T·g(uT) on u ∈ [−n_half, n_half] at 1/2048 of a symbol (unit symbol period)."""
    return UniformTable(lambda u: srrc_pulse(u, 1.0, rolloff), n_half, _PULSE_TABLE_RATE)


@njit(cache=True, nogil=True)
def _table_read_kernel(values, half_extent, rate, x, out):
    # UniformTable.__call__ in one pass, with the same floating-point operations in the same order
    last = values.size - 1
    for k in range(x.size):
        pos = (x[k] + half_extent) * rate
        i = min(max(int(np.floor(pos)), 0), values.size - 2)
        frac = pos - i
        v = values[i] * (1.0 - frac) + values[i + 1] * frac
        out[k] = v if (pos >= 0 and pos <= last) else 0.0


def table_read(table: UniformTable, x: np.ndarray) -> np.ndarray:
    """``table(x)`` (:class:`~seamodem.dsp.UniformTable`, bit for bit) by a compiled single pass.

    The numpy form makes ten passes over x with temporaries; the receiver's hot loops
    (matched filter, multipath columns) read 10⁴–10⁵ points per call.
    """
    x = np.asarray(x, dtype=float)
    flat = np.ascontiguousarray(x).ravel()
    out = np.empty(flat.size)
    _table_read_kernel(np.ascontiguousarray(table.values, dtype=float), float(table.half_extent),
                       float(table.rate), flat, out)
    return out.reshape(x.shape)


def _srrc_interp(u: np.ndarray, rolloff: float, n_half: int) -> np.ndarray:
    """√T·g(uT) by linear interpolation in the table: error ≤ (Δu)²/8·max|g''| ≈ 1e-6 (−120 dB),
    far below any noise the receiver sees, at a twentieth of the cost of the closed form."""
    return table_read(_srrc_table(rolloff, n_half), u)


def matched_filter(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    symbol_times_s: np.ndarray,
    *,
    config: FrameConfig,
    scale: float = 1.0,
    carrier_offset_hz: float = 0.0,
    t_ref_s: float = 0.0,
) -> np.ndarray:
    """SRRC matched filter of a baseband at arbitrary symbol times.

    y_k = (1/(fs T')) Σ_n r[n] e^{−j2π Δf (t_n − t_ref)} √T' g_{T'}(t_n − t_k), T' = T/scale.

    Parameters
    ----------
    r : numpy.ndarray, complex
        Baseband; r[n] at t_n = t0 + n/fs [s].
    symbol_times_s : numpy.ndarray
        Pulse centres t_k [s].
    scale : float
        Time compression 1 + ε of the received pulses.
    carrier_offset_hz, t_ref_s : float
        Frequency offset removed before filtering, phase zero at t_ref [Hz, s].

    Returns
    -------
    numpy.ndarray, complex
        With r = A Σ x_k √T' g_{T'}(t − t_k) e^{j2πΔf(t − t_ref)}, y_k = A x_k.
    """
    T = config.symbol_period_s / scale
    n_half = config.srrc_span_symbols // 2
    half = n_half * T
    tk = np.asarray(symbol_times_s, dtype=float)
    n_lo = max(0, int(math.floor((np.min(tk) - half - t0_s) * fs)))
    n_hi = min(len(r), int(math.ceil((np.max(tk) + half - t0_s) * fs)) + 1)
    if n_hi <= n_lo:
        return np.zeros(len(tk), complex)
    x = r[n_lo:n_hi]
    if carrier_offset_hz:
        x = x * np.exp(-2j * np.pi * carrier_offset_hz * (t0_s + np.arange(n_lo, n_hi) / fs - t_ref_s))
    # each symbol's support gathered densely (faster than a sparse matrix for one product), in one
    # compiled pass: the same operations, in the same order, as the numpy form
    #   idx = first_k + n, u = t0 + idx/fs − t_k, g = table(u/T)·[inside]/√T, y_k = Σ_n g·x[idx − n_lo]
    # (bit-identical to it; tests/receive/test_kernels.py)
    width = int(math.ceil(2 * half * fs)) + 2
    first = np.ceil((tk - half - t0_s) * fs - 1e-9).astype(np.int64)
    table = _srrc_table(float(config.rolloff), n_half)
    out = np.empty(tk.size, complex)
    _matched_filter_kernel(np.ascontiguousarray(x, dtype=complex), n_lo, n_hi, first, width, float(t0_s),
                           float(fs), np.ascontiguousarray(tk), float(T), float(half), table.values,
                           float(table.half_extent), float(table.rate), 1.0 / math.sqrt(T), out)
    norm = np.sqrt(T / srrc_truncation_energy(float(config.rolloff), n_half)) / (fs * T)
    return out * norm


@njit(cache=True, nogil=True)
def _matched_filter_kernel(x, n_lo, n_hi, first, width, t0_s, fs, tk, T, half, values, half_extent, rate,
                           inv_sqrt_t, out):
    last = values.size - 1
    for k in range(tk.size):
        acc_re = 0.0
        acc_im = 0.0
        for n in range(width):
            idx = first[k] + n
            u = t0_s + idx / fs - tk[k]
            inside = idx >= n_lo and idx < n_hi and abs(u) <= half
            pos = (u / T + half_extent) * rate
            i = min(max(int(np.floor(pos)), 0), values.size - 2)
            frac = pos - i
            v = values[i] * (1.0 - frac) + values[i + 1] * frac
            if not (pos >= 0 and pos <= last):
                v = 0.0
            g = v * (inv_sqrt_t if inside else 0.0)
            s = x[min(max(idx - n_lo, 0), n_hi - n_lo - 1)]
            acc_re += g * s.real
            acc_im += g * s.imag
        out[k] = complex(acc_re, acc_im)


def pilot_outputs(r, fs, t0_s, config: FrameConfig, t_start_s: float, eps: float) -> np.ndarray:
    """Matched-filter outputs at the pilot symbols of a frame starting at t_start with Doppler ε.

    Parameters
    ----------
    r : numpy.ndarray
        Data-band complex baseband.
    fs : float
        Its rate [Hz].
    t0_s : float
        Time of its first sample [s].
    config : FrameConfig
        The frame (guard, pilot length, symbol period, carrier).
    t_start_s : float
        The frame's start [s].
    eps : float
        Doppler factor v/c (time scale 1 + ε).

    Returns
    -------
    numpy.ndarray, shape (n_pilot,), complex
        One matched-filter output per pilot symbol.
    """
    tau = (config.n_guard + np.arange(config.n_pilot)) * config.symbol_period_s
    return matched_filter(
        r,
        fs,
        t0_s,
        t_start_s + tau / (1 + eps),
        config=config,
        scale=1 + eps,
        carrier_offset_hz=config.carrier_hz * eps,
        t_ref_s=t_start_s,
    )


def pilot_correlation(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_start_s: np.ndarray,
    v_mps: float,
    sound_speed_mps: float,
) -> np.ndarray:
    """|Σ a_k* y_k| / Np, the Doppler-scaled pilot correlation, at candidate frame starts [s]."""
    eps = v_mps / sound_speed_mps
    a_conj = np.conj(np.asarray(pilot, dtype=complex))
    return np.array([abs(a_conj @ pilot_outputs(r, fs, t0_s, config, t, eps)) for t in np.atleast_1d(t_start_s)]) / len(
        a_conj
    )


@dataclass(frozen=True)
class PilotFit:
    """Arrival time, Doppler and SNR from the pilot.

    Attributes
    ----------
    t_start_s : float
        Reception time of the frame start [s].
    v_mps : float
        Closing speed over the pilot [m/s].
    gain : complex
        Complex amplitude A of the pilot symbols after the matched filter.
    es_n0 : float
        Measured Es/N0 (linear) from the pilot residual.
    snr_db : float
        In-band SNR, Es/N0 / (1 + α), [dB].
    """

    t_start_s: float
    v_mps: float
    gain: complex
    es_n0: float
    snr_db: float


def fit_pilot(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_start_s: float,
    doppler_hz: float,
    search_hz: float,
    sound_speed_mps: float,
    iterations: int = 2,
) -> PilotFit:
    """Refine a coarse detection to the sub-sample arrival time and the pilot Doppler.

    Parameters
    ----------
    r : numpy.ndarray, complex
        Data-band baseband, r[n] at t0 + n/fs.
    pilot : numpy.ndarray
        Pilot symbols a_k.
    t_start_s, doppler_hz : float
        Coarse frame start [s] and carrier offset f0·v/c [Hz] (detector's bin).
    search_hz : float
        Half-width of the first Doppler dichotomy [Hz] (e.g. the bin spacing).

    Notes
    -----
    Doppler bank and dichotomy: paper 002 §II.B (Trubuil & Chonavel). The
    correlation is real and symmetric about its peak in t_a, so the parabola
    through three points centred near the peak is unbiased once centred; two
    passes (h = T/2, T/8, then twice T/32 after the Doppler update) make it so.
    """
    f0 = config.carrier_hz
    T = config.symbol_period_s
    tau = (config.n_guard + np.arange(config.n_pilot)) * T
    a_conj = np.conj(np.asarray(pilot, dtype=complex))

    def mf(t, eps):
        return pilot_outputs(r, fs, t0_s, config, t, eps)

    def corr(t, eps):
        return abs(a_conj @ mf(t, eps))

    t, eps = float(t_start_s), float(doppler_hz) / f0
    width = float(search_hz) / f0
    for it in range(iterations):
        weighted = a_conj * mf(t, eps)
        phase_t = tau / (1 + eps)
        delta = dichotomy_max(
            lambda d: abs(weighted @ np.exp(-2j * np.pi * f0 * d * phase_t)), -width, width, tol=1e-9
        )
        eps += delta
        width = max(abs(delta), width / 8)
        # the coarse start is within half a baseband sample: wide steps first
        for h in (T / 2, T / 8) if it == 0 else (T / 32, T / 32):
            fm, fc, fp = corr(t - h, eps), corr(t, eps), corr(t + h, eps)
            curvature = fm - 2 * fc + fp
            if curvature < 0:
                t += float(np.clip(h * (fm - fp) / (2 * curvature), -h, h))
    y = mf(t, eps)
    gain = (a_conj @ y) / len(y)
    resid = y - gain * np.conj(a_conj)
    noise = float(np.sum(np.abs(resid) ** 2) / max(len(y) - 1, 1))
    es_n0 = abs(gain) ** 2 / max(noise, np.finfo(float).tiny)
    snr_db = 10 * math.log10(max(es_n0 / (1 + config.rolloff), 1e-30))
    return PilotFit(t_start_s=t, v_mps=eps * sound_speed_mps, gain=complex(gain), es_n0=es_n0, snr_db=snr_db)


@dataclass(frozen=True)
class ToneFit:
    """Tone frequency (ML) and its C/N0.

    Attributes
    ----------
    offset_hz : float
        Tone frequency minus f_pt [Hz] (= f_pt·v/c).
    amplitude : complex
        Complex envelope amplitude.
    c_n0_hz : float
        Measured tone power over one-sided noise PSD [Hz].
    spread_hz : float
        RMS offset from ``offset_hz`` of the other spectral lines the tone
        band holds, each weighted by its power relative to the fitted line's
        (√ρ·Δf for one echo line ρ times as strong, Δf away) [Hz]: echoes
        with their own Doppler, which pull the fitted line, or are the line
        taken when stronger than the direct path's. 0 when none stands out of
        the noise.
    amp_rate_hz : float
        RMS rate of the tone's log-amplitude over the frame [1/s] (line and
        parabola through 16 segments' ln|Σ w x e^{−j2πft}|, each term less its
        noise expectation, the parabola's beyond 3 of its σ,
        :func:`log_amplitude_rate`): a fading or beating tone's phase wanders at the
        same scale, a speed error c·rate/(2π f_pt).
    amp_rate_terms : numpy.ndarray, shape (2, 2)
        The same rate's terms (the slope's, the parabola's), each less its
        noise expectation but not clipped at 0, with that noise's σ
        (unbiased: the receiver averages them over frames,
        :func:`log_amplitude_rate`).
    """

    offset_hz: float
    amplitude: complex
    c_n0_hz: float
    spread_hz: float = 0.0
    amp_rate_hz: float = 0.0
    amp_rate_terms: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))


#: a residual spectral line counts when its periodogram bin stands above the noise floor by ln(bins / this):
#: white noise alone crosses it in at most about 1 frame in 100
_LINE_FALSE_ALARM = 0.01


def _line_spread_hz(resid_w: np.ndarray, spectrum: np.ndarray, grid: np.ndarray, n_fft: int, f_hz: float, *,
                    search_hz: float) -> float:
    """√(Σ (P_res − floor)·(f − f̂)² / E_line) over the residual periodogram's bins that stand out of the
    noise, E_line the energy the fitted line took out (the periodogram of the weighted samples, whose
    magnitude ``spectrum`` the ML search computed on ``grid``, less the residual's); the floor is the
    residual periodogram's median / ln 2 (an exponential's mean)."""
    inside = np.abs(grid) <= search_hz
    p_res = np.abs(np.fft.fft(resid_w, n_fft))[inside] ** 2
    p_all = spectrum[inside] ** 2
    floor = float(np.median(p_res)) / math.log(2)
    e_line = float(np.sum(p_all) - np.sum(p_res))
    if not (floor > 0 and e_line > 0):
        return 0.0
    excess = p_res - floor
    # every bin tested (the zero-padded grid's are correlated: the count errs on the quiet side)
    lines = p_res > floor * math.log(p_res.size / _LINE_FALSE_ALARM)
    if not np.any(lines):
        return 0.0
    df = grid[inside][lines] - f_hz
    return float(math.sqrt(np.sum(excess[lines] * df**2) / e_line))


def tone_frequency_ml(
    x: np.ndarray, t_s: np.ndarray, weights: np.ndarray, *, search_hz: float, noise_bandwidth_hz: float
) -> ToneFit:
    """Maximum-likelihood frequency of a tone of known envelope in white noise.

    Maximises P(f) = |Σ w_n x_n e^{−j2π f t_n}|² over |f| ≤ search_hz: a grid
    of fs/(8·n) by FFT, then dichotomy to 1 µHz.

    Parameters
    ----------
    x : numpy.ndarray, complex
        Tone baseband samples.
    t_s : numpy.ndarray
        Their times [s].
    weights : numpy.ndarray
        Known envelope w_n (0 outside the tone).
    search_hz : float
        Half-width of the search [Hz].
    noise_bandwidth_hz : float
        ∫|H|² df of the front-end filter [Hz], to turn the residual variance
        into a noise PSD.

    Notes
    -----
    Rife & Boorstyn (1974): the periodogram maximiser is the ML estimator and
    attains the CRLB above the SNR threshold.
    """
    tc = t_s - np.mean(t_s)
    wx = weights * x
    fs = 1.0 / (t_s[1] - t_s[0])
    # periodogram on a grid of 1/(8·span) by a zero-padded FFT (uniform samples)
    n_fft = scipy.fft.next_fast_len(8 * len(x))
    grid = np.fft.fftfreq(n_fft, 1.0 / fs)
    power = np.abs(np.fft.fft(wx, n_fft))
    power[np.abs(grid) > search_hz] = 0.0
    k = int(np.argmax(power))
    step = fs / n_fft

    def p(f):
        return abs(wx @ np.exp(-2j * np.pi * f * tc))

    f = dichotomy_max(p, grid[k] - step, grid[k] + step, tol=1e-6)
    basis = weights * np.exp(2j * np.pi * f * tc)
    amplitude = (np.conj(basis) @ x) / (np.conj(basis) @ basis)
    inside = weights > 0.5
    resid = x[inside] - amplitude * basis[inside]
    variance = float(np.mean(np.abs(resid) ** 2))
    c_n0 = abs(amplitude) ** 2 * noise_bandwidth_hz / max(variance, np.finfo(float).tiny)
    spread = _line_spread_hz(weights * (x - amplitude * basis), power, grid, n_fft, f, search_hz=search_hz)
    # the white noise's variance from the residual's sample-to-sample differences: a fading tone's slow
    # amplitude changes, which the residual also holds, are what the rate is to measure, not noise
    white = float(np.mean(np.abs(np.diff(resid)) ** 2)) / 2 if resid.size > 1 else variance
    rate, rate_terms = _amplitude_rate_hz(wx * np.exp(-2j * np.pi * f * tc), weights, tc, white)
    return ToneFit(offset_hz=float(f), amplitude=complex(amplitude), c_n0_hz=float(c_n0), spread_hz=spread,
                   amp_rate_hz=rate, amp_rate_terms=rate_terms)


#: segments of the tone whose log-amplitudes give its rate (``ToneFit.amp_rate_hz``)
_TONE_SEGMENTS = 16


def _amplitude_rate_hz(y: np.ndarray, weights: np.ndarray, tc: np.ndarray, noise_var: float
                       ) -> tuple[float, np.ndarray]:
    """:func:`log_amplitude_rate` of ln|Σ y| over ``_TONE_SEGMENTS``
    segments of equal weight (y = w·x·e^{−j2πft}, the tone at its fitted frequency), each segment's
    ln-amplitude noise variance noise_var·Σw²/(2|Σy|²)."""
    w2 = weights**2
    cum = np.cumsum(w2)
    if cum[-1] <= 0:
        return 0.0, np.zeros((2, 2))
    seg = np.minimum((cum / cum[-1] * _TONE_SEGMENTS).astype(int), _TONE_SEGMENTS - 1)
    sums = np.bincount(seg, y.real, _TONE_SEGMENTS) + 1j * np.bincount(seg, y.imag, _TONE_SEGMENTS)
    energy = np.bincount(seg, w2, _TONE_SEGMENTS)
    times = np.bincount(seg, w2 * tc, _TONE_SEGMENTS) / np.maximum(energy, np.finfo(float).tiny)
    power = np.abs(sums) ** 2
    if np.any(energy <= 0) or np.any(power <= 0):
        return 0.0, np.zeros((2, 2))
    var = np.maximum(noise_var * energy / (2 * power), 1e-12)
    duration = float(times[-1] - times[0]) * _TONE_SEGMENTS / (_TONE_SEGMENTS - 1)
    log_amp = np.log(np.sqrt(power) / energy)
    return log_amplitude_rate(log_amp, var, times, duration_s=duration)


def log_amplitude_rate(log_amp: np.ndarray, var: np.ndarray, t_s: np.ndarray, *, duration_s: float
                       ) -> tuple[float, np.ndarray]:
    """RMS rate over a stretch of a phasor's log-amplitude [1/s], less what its noise gives it, and the
    terms it is made of, unclipped.

    A line and a parabola a0 + a1·t + a2·t² are fitted to the segments' log-amplitudes by weighted
    least squares; the rate's mean square over t uniform in ±D/2 is a1² + a2²·D²/3, each squared
    coefficient taken less its variance (an unbiased estimate). A fading or beating phasor's phase
    wanders at the same scale as its log-amplitude (the real and imaginary parts of one analytic
    function): c·rate/(2πf) is then a speed error at carrier f (the whole-frame fit's
    ``WholeFrameFit.amp_rate_hz``, the tone's ``ToneFit.amp_rate_hz``).

    The slope's noise is the phase slope's (the fit's own Doppler σ), and less its expectation, clipped
    at 0, noise alone leaves 0.67 of it. The parabola's term has five times that noise over the
    stretch: it counts only beyond 3 of its σ (clipped at 0 alone, noise had left 1.7 of the fit's σ
    there: the corpus's steep family, which does not fade, had whole-frame v_r σ 1.6 times its errors).

    Parameters
    ----------
    log_amp : numpy.ndarray
        ln|segment sum| of each segment.
    var : numpy.ndarray
        Its noise variance (> 0).
    t_s : numpy.ndarray
        The segments' times, about the stretch's middle [s].
    duration_s : float
        The stretch's duration D [s].

    Returns
    -------
    rate_hz : float
        √ of the slope's term clipped at 0 plus the parabola's beyond 3 of its σ: this frame's rate.
    terms : numpy.ndarray, shape (2, 2)
        Rows the slope's a1² and the parabola's a2²·D²/3, each less its noise expectation but not
        clipped (unbiased, so that their average over frames is too: ``FrameMeasurer`` pools them);
        columns that value [1/s²] and its noise σ (√2 times the expectation).
    """
    design = np.column_stack([np.ones(t_s.size), t_s, t_s**2])
    cov = np.linalg.inv(design.T @ (design / var[:, None]))
    a = cov @ (design.T @ (log_amp / var))
    slope, curve = a[1] ** 2 - cov[1, 1], a[2] ** 2 - cov[2, 2]
    k = duration_s**2 / 3
    counted = curve if a[2] ** 2 > 9 * cov[2, 2] else 0.0
    terms = np.array([[slope, math.sqrt(2) * cov[1, 1]], [curve * k, math.sqrt(2) * k * cov[2, 2]]])
    return float(math.sqrt(max(slope, 0.0) + counted * k)), terms


def tone_track_eq9(
    x: np.ndarray, fs: float, *, f_max_hz: float, tone_hz: float, sound_speed_mps: float
) -> tuple[np.ndarray, int]:
    """Radial speed track from the tone's phase derivative (paper 000 eq 9).

    Parameters
    ----------
    x : numpy.ndarray, complex
        Tone baseband at rate fs.
    f_max_hz : float
        Low-pass cut-off v_max·f_pt/c [Hz].

    Returns
    -------
    v : numpy.ndarray, shape (len(x) − 1,)
        v̂ between consecutive samples [m/s]; v[k] belongs to t_k + 1/(2fs).
    settle : int
        Samples at either end spoiled by the low-pass (its half length).

    Notes
    -----
    v̂(kT) = c / (2π T f_pt) · arg(r̃(kT) r̃*((k−1)T)), after a low-pass with
    cut-off f_max = v_max f_pt / c (paper 000 eq 9, paper 002 §II.B).
    """
    half = max(1, int(math.ceil(2 * fs / f_max_hz)))
    taps = windowed_sinc_lowpass(2 * half + 1, min(f_max_hz, 0.45 * fs), fs, np.hamming(2 * half + 1))
    xf = np.convolve(x, taps)[half : half + len(x)]  # "same": the full convolution's centre (a frame's tone, short)
    v = sound_speed_mps * fs / (2 * np.pi * tone_hz) * np.angle(xf[1:] * np.conj(xf[:-1]))
    return v, half


def tone_segment(
    tone: np.ndarray, fs: float, t0_s: float, *, config: FrameConfig, t_start_s: float, scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tone baseband samples over the received frame, their times and envelope weights."""
    duration = config.frame_duration_s / scale
    n_lo = max(0, int(math.ceil((t_start_s - t0_s) * fs)))
    n_hi = min(len(tone), int(math.floor((t_start_s + duration - t0_s) * fs)) + 1)
    t = t0_s + np.arange(n_lo, n_hi) / fs
    w = tone_envelope(config, (t - t_start_s) * scale)
    return tone[n_lo:n_hi], t, w
