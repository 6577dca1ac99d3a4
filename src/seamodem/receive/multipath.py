"""First arrival among unresolved paths: a sparse multipath fit of the pilot correlation.

A surface echo a fraction of a millisecond behind the direct path (shallow
water, long range) merges with it into one correlation peak, and a single-path
fit then lands between the two — tens of centimetres late when the echo is the
stronger. Here the Doppler-corrected pilot correlation around the detection,

    C(t) = Σ_n r(t_n) e^{−j2π f0 ε (t_n − t)} p*(t_n − t),

is modelled as a sum of shifted copies of the pilot's own autocorrelation,

    C(t) ≈ Σ_p B_p R(t − t_p),   R(Δ) ∝ Σ_d ρ_d rc(Δ − dT),

(ρ_d the pilot's aperiodic autocorrelation, rc the raised-cosine pulse that
SRRC ⊛ SRRC gives), with paths added greedily (largest residual first, delay
refined by dichotomy, all amplitudes by least squares, then every delay
refined again), starting from the single-path estimate, until a new path is
weaker than ``min_fraction`` of the strongest. The first arrival is the earliest path at least
``first_path_fraction`` of the strongest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from .detect import pilot_template
from .doppler import dichotomy_max

__all__ = ["PathFit", "fit_paths", "raised_cosine"]

#: pilot autocorrelation lags kept in the model (|ρ_d| ≪ Np beyond: well-chosen pilot)
_SIDELOBE_LAGS = 12


def raised_cosine(x: np.ndarray, symbol_period_s: float, rolloff: float) -> np.ndarray:
    """Raised-cosine pulse rc(x) = sinc(x/T) cos(π α x/T) / (1 − (2 α x/T)²), rc(0) = 1."""
    u = np.asarray(x, dtype=float) / symbol_period_s
    den = 1 - (2 * rolloff * u) ** 2
    near = np.abs(den) < 1e-8
    safe = np.where(near, 1.0, den)
    out = np.sinc(u) * np.cos(np.pi * rolloff * u) / safe
    # limit at |u| = 1/(2α): (π/4) sinc(1/(2α))
    return np.where(near, np.pi / 4 * np.sinc(1 / (2 * rolloff)) if rolloff > 0 else 0.0, out)


@dataclass(frozen=True)
class PathFit:
    """Paths found in the pilot correlation.

    Attributes
    ----------
    delays_s : numpy.ndarray
        Frame-start arrival time of each path [s], increasing.
    amplitudes : numpy.ndarray, complex
        Their complex amplitudes (relative units).
    first_s : float
        The first arrival [s].
    """

    delays_s: np.ndarray
    amplitudes: np.ndarray
    first_s: float


def fit_paths(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_start_s: float,
    eps: float,
    es_n0: float = math.inf,
    half_window_symbols: float = 12.0,
    max_paths: int = 3,
    min_fraction: float = 0.15,
    first_path_fraction: float = 0.3,
) -> PathFit:
    """Sparse multipath fit of the pilot correlation within ± a few symbols of ``t_start_s``.

    Parameters
    ----------
    r : numpy.ndarray, complex
        Data-band baseband, r[n] at t0 + n/fs.
    pilot : numpy.ndarray
        Pilot symbols.
    t_start_s : float
        Single-path estimate of the frame start [s].
    eps : float
        Doppler v/c (its carrier offset f0·ε is removed first).
    es_n0 : float
        Measured Es/N0 of the pilot (linear). A new path must also stand
        3.5 noise deviations above zero: the correlation noise relative to a
        path's peak is 1/√(Np·Es/N0), and a complex Gaussian exceeds 3.5 σ
        with probability e^{−12} per lag; without it, noise peaks pass for
        early paths at SNR ≲ 0 dB.
    """
    T = config.symbol_period_s
    a = np.asarray(pilot, dtype=complex)
    n_p = len(a)
    lags = np.arange(-_SIDELOBE_LAGS, _SIDELOBE_LAGS + 1)
    rho = np.array([np.vdot(a[: n_p - abs(d)], a[abs(d) :]).real for d in lags])  # real ±1 pilot: symmetric
    # the received pilot is compressed by 1 + ε: a template at frame times τ_a + i(1 + ε)/fs
    # lies on the recording's grid; uncompressed, the fit would be τ_centroid·ε early (33 µs at 3 m/s)
    template, tau_a = pilot_template(config, fs / (1 + eps), a)
    tau_a /= 1 + eps
    T /= 1 + eps
    n_t = len(template)
    # template[0] on sample m ⇔ a frame starting at t0 + m/fs − τ_a (as in the detector)
    m_lo = math.floor((t_start_s - half_window_symbols * T + tau_a - t0_s) * fs)
    m_hi = math.ceil((t_start_s + half_window_symbols * T + tau_a - t0_s) * fs)
    m = np.arange(max(m_lo, 0), min(m_hi, len(r) - n_t) + 1)
    if m.size == 0:
        return PathFit(delays_s=np.array([t_start_s]), amplitudes=np.ones(1, complex), first_s=t_start_s)
    t_n = t0_s + np.arange(m[0], m[-1] + n_t) / fs
    seg = r[m[0] : m[-1] + n_t] * np.exp(-2j * np.pi * config.carrier_hz * eps * (t_n - t_start_s))
    windows = np.lib.stride_tricks.sliding_window_view(seg, n_t)
    corr = windows @ np.conj(template)
    cand = t0_s + m / fs - tau_a

    def model(delays):
        d = cand[:, None, None] - np.asarray(delays)[None, :, None] - lags[None, None, :] * T
        return np.sum(rho * raised_cosine(d, T, config.rolloff), axis=2)

    def solve(delays):
        mat = model(delays)
        b, *_ = np.linalg.lstsq(mat, corr, rcond=None)
        return b, float(np.sum(np.abs(corr - mat @ b) ** 2))

    def refine(delays, i, width):
        def score(x):
            trial = list(delays)
            trial[i] = x
            return -solve(trial)[1]

        delays[i] = dichotomy_max(score, delays[i] - width, delays[i] + width, tol=1e-3 * T)

    # the single-path estimate is the first path; only a second path that passes the
    # test costs the joint refinement, so a clean frame pays for one trial
    noise_fraction = 3.5 / math.sqrt(n_p * es_n0)
    delays = [float(t_start_s)]
    amps, _ = solve(delays)
    threshold = max(min_fraction, noise_fraction)
    peak_response = float(np.sum(rho * raised_cosine(lags * T, T, config.rolloff)))  # R(0)
    for _ in range(max_paths - 1):
        resid = corr - model(delays) @ amps
        if np.max(np.abs(resid)) < threshold * np.max(np.abs(amps)) * peak_response:
            break  # nothing left that could be a path: spare the refinement
        trial = delays + [float(cand[int(np.argmax(np.abs(resid)))])]
        refine(trial, len(trial) - 1, 1.0 / fs)
        b, _ = solve(trial)
        if abs(b[-1]) < threshold * np.max(np.abs(b)):
            break
        delays = trial
        for i in range(len(delays)):
            refine(delays, i, 0.5 / fs)
        amps, _ = solve(delays)
    order = np.argsort(delays)
    delays_s, amps = np.asarray(delays)[order], amps[order]
    strong = np.abs(amps) >= first_path_fraction * np.max(np.abs(amps))
    return PathFit(delays_s=delays_s, amplitudes=amps, first_s=float(delays_s[np.argmax(strong)]))


def direct_path_doppler(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    paths: PathFit,
    eps: float,
    search: float,
) -> float:
    """Pilot Doppler ε of the first path, the echoes' pilot interference removed.

    The pilots' matched-filter outputs at the first path's instants hold, besides
    A_1 a_k, each echo's pilot seen through the raised cosine:
    y_k = Σ_p A_p Σ_m a_m rc((k − m)T − Δ_p). The A_p are fitted by least squares,
    the echoes subtracted, and ε refined by dichotomy on the cleaned outputs as
    in :func:`~seamodem.receive.doppler.fit_pilot` (within ε ± ``search``).
    """
    from .doppler import _pilot_outputs  # the pilot-output helper is private to doppler

    T = config.symbol_period_s / (1 + eps)
    a = np.asarray(pilot, dtype=complex)
    n_p = len(a)
    y = _pilot_outputs(r, fs, t0_s, config, paths.first_s, eps)
    lags = np.arange(-(n_p - 1), n_p) * T
    columns = [np.convolve(a, raised_cosine(lags - (d - paths.first_s), T, config.rolloff))[n_p - 1 : 2 * n_p - 1]
               for d in paths.delays_s]
    basis = np.stack(columns, axis=1)
    amps, *_ = np.linalg.lstsq(basis, y, rcond=None)
    first = int(np.argmin(np.abs(paths.delays_s - paths.first_s)))
    echoes = np.delete(np.arange(len(paths.delays_s)), first)
    weighted = np.conj(a) * (y - basis[:, echoes] @ amps[echoes])
    tau = (config.n_guard + np.arange(n_p)) * T
    delta = dichotomy_max(
        lambda d: abs(weighted @ np.exp(-2j * np.pi * config.carrier_hz * d * tau)), -search, search, tol=1e-9
    )
    return eps + delta
