"""First arrival among unresolved paths: a sparse multipath fit of the pilot correlation.

A surface echo a fraction of a millisecond behind the direct path (shallow
water, long range) merges with it into one correlation peak, and a single-path
fit then lands between the two — tens of centimetres late when the echo is the
stronger. Here the Doppler-corrected pilot correlation around the detection,

    C(t) = Σ_n r(t_n) e^{−j2π f0 ε (t_n − t)} p*(t_n − t),

is modelled as a sum of shifted copies of the pilot's own autocorrelation,

    C(t) ≈ Σ_p B_p R(t − t_p),   R(Δ) ∝ Σ_d ρ_d rc(Δ − dT),

(ρ_d the pilot's aperiodic autocorrelation, rc the raised-cosine pulse that
SRRC ⊛ SRRC gives), with paths added greedily (largest residual relative to
the acceptance floor first, delay refined by dichotomy, all amplitudes by least
squares, then every delay refined again), starting from the single-path
estimate, until a new path is weaker than ``min_fraction`` of the strongest, or
than 3.5 deviations of the data sidelobes (D symbols after the earliest path the
template overlaps D unknown data symbols: std √D/Np of each path's amplitude).
The first arrival is the earliest path at least ``first_path_fraction`` of the strongest.

:func:`direct_path_doppler` then gives the first path's pilot Doppler: every
echo whose pilot overlaps the first path's (delay < Np·T) is searched for, and
all paths are fitted jointly to the pilot outputs, each echo with its own
first-order Doppler drift, so that the Doppler found is the first path's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from ..config import FrameConfig
from ..dsp import UniformTable
from .detect import pilot_template
from .doppler import dichotomy_max, matched_filter, table_read

__all__ = ["PathFit", "direct_path_index", "fit_paths", "find_echoes", "direct_path_doppler", "raised_cosine",
           "sidelobe_pull_s"]

#: pilot autocorrelation lags kept in the model (|ρ_d| ≪ Np beyond: well-chosen pilot)
_SIDELOBE_LAGS = 12
#: the precursor search's noise test: √ln(n/P) for the n ≈ (150 + 12)·1.4 independent complex lags it
#: searches and a false precursor P = 1e-5 per frame (a complex Gaussian's |z|² exceeds k²σ² with e^{−k²})
_PRECURSOR_NOISE_DEVIATIONS = math.sqrt(math.log(162 * 1.4 / 1e-5))


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


def direct_path_index(paths: PathFit) -> int:
    """The index of the direct path in a pilot fit's paths: the path nearest its ``first_s`` (after
    :func:`find_echoes`, which keeps the arrival fit's ``first_s``, not exactly the direct path's delay)."""
    return int(np.argmin(np.abs(np.asarray(paths.delays_s, dtype=float) - paths.first_s)))


#: table points per symbol of the pilot-correlation response R (linear interpolation error ≈ 5e-6 of R(0))
_RESPONSE_TABLE_RATE = 512


@lru_cache(maxsize=8)
def _response_table(rolloff: float, rho: tuple, half_extent_symbols: int) -> UniformTable:
    """u ↦ R(uT) = Σ_d ρ_d rc((u − d)T) for |u| ≤ half_extent, by linear interpolation in a table."""
    lags = np.arange(-_SIDELOBE_LAGS, _SIDELOBE_LAGS + 1)
    return UniformTable(
        lambda u: sum(r * raised_cosine(u - d, 1.0, rolloff) for d, r in zip(lags, rho)),
        half_extent_symbols,
        _RESPONSE_TABLE_RATE,
    )


@lru_cache(maxsize=8)
def _pilot_template(config: FrameConfig, fs: float, pilot_bytes: bytes) -> tuple[np.ndarray, float]:
    """:func:`~seamodem.receive.detect.pilot_template`, cached: a frame's arrival fit and its two
    echo searches use the same Doppler, hence the same template (read-only)."""
    template, tau_a = pilot_template(config, fs, np.frombuffer(pilot_bytes, dtype=complex))
    template.flags.writeable = False
    return template, tau_a


@njit(cache=True, nogil=True)
def _ls_residual_energy(store, index, corr):
    """min_b ‖corr − M b‖², M's real columns ``store[index]``, by the normal equations (Cholesky of MᵀM).

    The residual energy is stationary in b, so it agrees with :func:`numpy.linalg.lstsq`'s
    (SVD) to second order in the solve's rounding: the dichotomy on it takes the same steps
    (records identical, tests/receive/test_identical_records.py). Returns −1 when MᵀM is
    numerically singular (a Cholesky pivot below 1e-10 of its diagonal: delays within
    ~1e-5 symbol of each other), for the caller to fall back to ``lstsq``.
    """
    n = index.size
    m = corr.size
    gram = np.zeros((n, n))
    pr = np.zeros(n)
    pi = np.zeros(n)
    for a in range(n):
        ca = store[index[a]]
        sr = 0.0
        si = 0.0
        for k in range(m):
            sr += ca[k] * corr[k].real
            si += ca[k] * corr[k].imag
        pr[a] = sr
        pi[a] = si
        for b in range(a + 1):
            cb = store[index[b]]
            acc = 0.0
            for k in range(m):
                acc += ca[k] * cb[k]
            gram[a, b] = acc
            gram[b, a] = acc
    low = np.zeros((n, n))
    for j in range(n):
        d = gram[j, j]
        for p in range(j):
            d -= low[j, p] * low[j, p]
        if not d > 1e-10 * gram[j, j]:
            return -1.0
        low[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            acc = gram[i, j]
            for p in range(j):
                acc -= low[i, p] * low[j, p]
            low[i, j] = acc / low[j, j]
    for rhs in (pr, pi):  # L Lᵀ x = rhs, in place
        for i in range(n):
            acc = rhs[i]
            for p in range(i):
                acc -= low[i, p] * rhs[p]
            rhs[i] = acc / low[i, i]
        for i in range(n - 1, -1, -1):
            acc = rhs[i]
            for p in range(i + 1, n):
                acc -= low[p, i] * rhs[p]
            rhs[i] = acc / low[i, i]
    energy = 0.0
    for k in range(m):
        er = corr[k].real
        ei = corr[k].imag
        for a in range(n):
            c = store[index[a], k]
            er -= pr[a] * c
            ei -= pi[a] * c
        energy += er * er + ei * ei
    return energy


@lru_cache(maxsize=8)
def _aperiodic_autocorrelation(pilot_bytes: bytes) -> tuple[np.ndarray, np.ndarray]:
    """(lags, ρ_d = Σ_n a[n+d]·conj a[n]) of the pilot symbols, every lag."""
    a = np.frombuffer(pilot_bytes, dtype=complex)
    return np.arange(-(a.size - 1), a.size), np.correlate(a, a, mode="full")


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
    initial_delays_s=None,
    window_s: tuple[float, float] | None = None,
    noise_deviations: float = 3.5,
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
    initial_delays_s : array_like, optional
        Paths already known (default: ``t_start_s`` alone); new ones are added to them.
    window_s : (float, float), optional
        Candidate frame starts searched [s] (default ``t_start_s`` ± ``half_window_symbols``).
    noise_deviations : float
        The noise test's deviations (3.5 above).
    """
    T = config.symbol_period_s
    a = np.asarray(pilot, dtype=complex)
    n_p = len(a)
    # ρ_d for |d| ≤ _SIDELOBE_LAGS (real ±1 pilot: symmetric)
    rho = _aperiodic_autocorrelation(a.tobytes())[1][n_p - 1 - _SIDELOBE_LAGS: n_p + _SIDELOBE_LAGS].real
    # the received pilot is compressed by 1 + ε: a template at frame times τ_a + i(1 + ε)/fs
    # lies on the recording's grid; uncompressed, the fit would be τ_centroid·ε early (33 µs at 3 m/s)
    template, tau_a = _pilot_template(config, fs / (1 + eps), a.tobytes())
    tau_a /= 1 + eps
    T /= 1 + eps
    n_t = len(template)
    # template[0] on sample m ⇔ a frame starting at t0 + m/fs − τ_a (as in the detector)
    lo_s, hi_s = window_s if window_s is not None else (t_start_s - half_window_symbols * T,
                                                        t_start_s + half_window_symbols * T)
    m_lo = math.floor((lo_s + tau_a - t0_s) * fs)
    m_hi = math.ceil((hi_s + tau_a - t0_s) * fs)
    m = np.arange(max(m_lo, 0), min(m_hi, len(r) - n_t) + 1)
    if m.size == 0:
        return PathFit(delays_s=np.array([t_start_s]), amplitudes=np.ones(1, complex), first_s=t_start_s)
    t_n = t0_s + np.arange(m[0], m[-1] + n_t) / fs
    seg = r[m[0] : m[-1] + n_t] * np.exp(-2j * np.pi * config.carrier_hz * eps * (t_n - t_start_s))
    windows = np.lib.stride_tricks.sliding_window_view(seg, n_t)
    corr = windows @ np.conj(template)
    cand = t0_s + m / fs - tau_a

    # one path's response R(t − delay) at every candidate, interpolated in a table of
    # R(uT) = Σ_d ρ_d rc((u − d)T); cached (rows of ``store``), since the dichotomy moves one delay at a time
    rows: dict[float, int] = {}
    store = np.empty((16, cand.size))
    extent = (cand[-1] - cand[0]) / T + 2 * half_window_symbols + 4
    if window_s is not None:
        extent += (window_s[1] - window_s[0]) / T
    table = _response_table(float(config.rolloff), tuple(rho.tolist()), int(2 ** math.ceil(math.log2(extent))))

    def row(delay) -> int:
        nonlocal store
        key = float(delay)
        if key not in rows:
            if len(rows) == store.shape[0]:
                store = np.concatenate([store, np.empty_like(store)])
            store[len(rows)] = table_read(table, (cand - key) / T)
            rows[key] = len(rows)
        return rows[key]

    def model(delays):
        index = [row(d) for d in delays]  # before ``store`` is read: a new row may reallocate it
        return np.column_stack([store[i] for i in index])

    def solve(delays):
        mat = model(delays)
        b, *_ = np.linalg.lstsq(mat, corr, rcond=None)
        return b, float(np.sum(np.abs(corr - mat @ b) ** 2))

    def residual_energy(delays):
        """‖corr − M b‖² at the least-squares b (the dichotomy's score), compiled: see
        :func:`_ls_residual_energy`; ``lstsq`` when the columns are nearly collinear."""
        index = np.array([row(d) for d in delays], dtype=np.int64)
        energy = _ls_residual_energy(store, index, corr)
        return energy if energy >= 0 else solve(delays)[1]

    def refine(delays, i, width):
        def score(x):
            trial = list(delays)
            trial[i] = x
            return -residual_energy(trial)

        delays[i] = dichotomy_max(score, delays[i] - width, delays[i] + width, tol=1e-3 * T)

    # the single-path estimate is the first path; only a second path that passes the
    # test costs the joint refinement, so a clean frame pays for one trial
    noise_fraction = noise_deviations / math.sqrt(n_p * es_n0)
    delays = [float(t_start_s)] if initial_delays_s is None else [float(d) for d in initial_delays_s]
    amps, _ = solve(delays)
    threshold = max(min_fraction, noise_fraction)
    peak_response = float(table(0.0))  # R(0)

    def floor(amps, at_s):
        """Smallest amplitude a new path at ``at_s`` must have: ``threshold`` of the strongest, and
        3.5 deviations of the data sidelobes — D symbols after the earliest path, the template
        overlaps D unknown data symbols of every path, a correlation of std √D/Np each."""
        lag = np.clip((np.asarray(at_s) - min(delays)) / T, 0.0, n_p)
        return np.maximum(threshold * np.max(np.abs(amps)), 3.5 * np.sqrt(lag) / n_p * np.linalg.norm(amps))

    for _ in range(max_paths - len(delays)):
        resid = corr - model(delays) @ amps
        ratio = np.abs(resid) / (floor(amps, cand) * peak_response)
        if np.max(ratio) < 1:
            break  # nothing left that could be a path: spare the refinement
        trial = delays + [float(cand[int(np.argmax(ratio))])]
        refine(trial, len(trial) - 1, 1.0 / fs)
        b, _ = solve(trial)
        if abs(b[-1]) < floor(b[:-1], trial[-1]):
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
    es_n0: float | None = None,
    echo_drift: bool = True,
    max_echoes: int = 4,
) -> float:
    """Pilot Doppler ε of the first path: a joint least-squares fit of all paths to its pilot outputs.

    1. Echoes. Every path whose pilot overlaps the first path's (delay below
       Np·T, 23 ms for jmse2024) leaks into the first path's pilot outputs,
       not only those within the arrival fit's ± 12 symbols. So
       :func:`fit_paths` is run again, starting from ``paths``, over
       [earliest − T, first + Np·T]. Es/N0 is taken from the leading guard
       (:func:`_guard_es_n0`) unless ``es_n0`` is given.
    2. Model. The pilot outputs y_k at the first path's instants, with Doppler
       ``eps``, are y_k ≈ Σ_p A_p Σ_m a_m rc((k − m)T' − Δ_p), with
       Δ_p = t_p − t_1 (A_1 a_k for the first path). Each echo also gets a
       column u_k · Σ_m a_m rc(…), where u_k is the centred symbol time. This
       is the first-order term of its own Doppler: an echo arriving at another
       elevation has v_r cos θ_p, so it rotates by 2π f0 (ε_p − ε_1) t relative
       to the first path. The first path gets no such column, so its phase
       slope, the Doppler sought, is not absorbed.
    3. Doppler. A trial ε + d rotates the outputs, y_k e^{−j2π f0 d τ_k}, as in
       :func:`~seamodem.receive.doppler.fit_pilot`. The outputs are not
       recomputed: recomputing moves the symbol instants, and the unknown data
       symbols then leak in with a bias linear in d. d maximises the energy the
       model explains, ‖B Â(d)‖² = ‖Qᴴ y(d)‖² with B = QR. With one path this
       is |Σ a_k* y_k|², the single-path estimator.

    All amplitudes are refitted at every trial d. Echoes fitted once at the
    single-path Doppler and subtracted (the earlier method) keep their rotation
    at the wrong Doppler, and so pull ε back towards that starting value.
    Without the drift columns (``echo_drift=False``), the fit pools the echoes'
    Doppler: this has less noise when the echoes share the first path's
    Doppler (unresolved, grazing), but a bias of −40 mm/s with 2–5 % slower
    steep echoes (tests/receive/test_direct_doppler.py).
    """
    from .doppler import pilot_outputs

    a = np.asarray(pilot, dtype=complex)
    n_p = len(a)
    T = config.symbol_period_s / (1 + eps)
    y = pilot_outputs(r, fs, t0_s, config, paths.first_s, eps)
    paths = find_echoes(r, fs, t0_s, config=config, pilot=a, paths=paths, eps=eps, es_n0=es_n0,
                        max_echoes=max_echoes, first_outputs=y)
    lags = np.arange(-(n_p - 1), n_p) * T
    columns = [np.convolve(a, raised_cosine(lags - (d - paths.first_s), T, config.rolloff))[n_p - 1 : 2 * n_p - 1]
               for d in paths.delays_s]
    first = direct_path_index(paths)
    if echo_drift:
        t_rel = (np.arange(n_p) - (n_p - 1) / 2) / n_p  # symbol time over the pilot, centred, in pilot lengths
        columns += [columns[p] * t_rel for p in range(len(columns)) if p != first]
    basis = np.stack(columns, axis=1)
    q, _ = np.linalg.qr(basis)  # ‖B Â‖² = ‖Qᴴ y‖² for the least-squares Â
    qh = np.conj(q.T)
    tau = (config.n_guard + np.arange(n_p)) * T

    def explained(d):
        return float(np.sum(np.abs(qh @ (y * np.exp(-2j * np.pi * config.carrier_hz * d * tau))) ** 2))

    return eps + dichotomy_max(explained, -search, search, tol=1e-9)


def sidelobe_pull_s(config: FrameConfig, pilot: np.ndarray, lags_s, amplitudes, *, eps: float = 0.0) -> float:
    """σ [s] of the pilot's arrival from echoes its fit does not model, through the pilot's sidelobes.

    The arrival fit (:func:`fit_paths`) models the pilot correlation near the first path with the
    pilot's autocorrelation to ±``_SIDELOBE_LAGS`` lags and the paths it found. An echo it did not
    model, b at Δ (one found later over the whole frame, typically beyond its ±12-symbol window),
    still reaches the direct peak through the pilot's aperiodic sidelobes (|ρ_d| ~ √Np at any lag)
    and pulls it by Re(b·R′(−Δ))/|R″(0)|, R(u) = Σ_d ρ_d rc(u − d) (u in symbols). Each echo's
    |b·R′(−Δ)|/|R″(0)| (its phase unknown: /√2, the RMS of the real part) adds in quadrature.
    On the corpus's impulsive family at 15 dB (a surface echo 0.82 at 19 symbols, a bottom echo 0.48
    at 73): pulls of 0.5–5 mm as the echo's lag moves, where the arrival's CRLB was 1.0 mm.

    Parameters
    ----------
    config : FrameConfig
        The frame (symbol period, roll-off).
    pilot : numpy.ndarray
        Pilot symbols.
    lags_s : array_like
        The unmodelled echoes' delays after the direct path [s].
    amplitudes : array_like
        Their amplitudes relative to the direct path's (|b|).
    eps : float
        The Doppler's time scale v/c (symbol period T/(1 + eps)).
    """
    lags_s, amplitudes = np.atleast_1d(np.asarray(lags_s, float)), np.abs(np.atleast_1d(amplitudes))
    if lags_s.size == 0:
        return 0.0
    lags, rho = _aperiodic_autocorrelation(np.asarray(pilot, dtype=complex).tobytes())
    T = config.symbol_period_s / (1 + eps)
    h = 1e-3  # [symbols]

    def response(u: np.ndarray) -> np.ndarray:
        return raised_cosine(u[:, None] - lags[None, :], 1.0, config.rolloff) @ rho

    curv = abs(complex(np.sum(response(np.array([h, -h]))) - 2 * response(np.array([0.0]))[0])) / h**2
    u = -lags_s / T
    slope = (response(u + h) - response(u - h)) / (2 * h)
    pull = amplitudes * np.abs(slope) / curv * T
    return float(math.sqrt(np.sum(pull**2) / 2))


def find_echoes(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    paths: PathFit,
    eps: float,
    es_n0: float | None = None,
    max_echoes: int = 4,
    first_outputs: np.ndarray | None = None,
) -> PathFit:
    """``paths`` with the echoes up to a pilot's length (Np·T) after the first path added.

    The arrival fit looks ± 12 symbols around the detection; echoes 2–20 ms late
    (deep water) lie beyond it, yet overlap the first path's pilot and, over the
    whole frame, its data. :func:`fit_paths` is run again from ``paths`` over
    [earliest − T, first + Np·T], with Es/N0 from the leading guard
    (:func:`_guard_es_n0`) unless ``es_n0`` is given.
    """
    from .doppler import pilot_outputs

    a = np.asarray(pilot, dtype=complex)
    n_p = len(a)
    T = config.symbol_period_s / (1 + eps)
    first_s = paths.first_s
    if es_n0 is None:
        y = pilot_outputs(r, fs, t0_s, config, first_s, eps) if first_outputs is None else first_outputs
        es_n0 = _guard_es_n0(r, fs, t0_s, config=config, pilot=a, y=y, first_s=first_s, eps=eps)
    found = fit_paths(r, fs, t0_s, config=config, pilot=a, t_start_s=first_s, eps=eps, es_n0=es_n0,
                      initial_delays_s=paths.delays_s, max_paths=len(paths.delays_s) + max_echoes,
                      window_s=(float(np.min(paths.delays_s)) - T, first_s + n_p * T))
    return PathFit(delays_s=found.delays_s, amplitudes=found.amplitudes, first_s=first_s)


def find_precursors(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    paths: PathFit,
    t_start_s: float,
    eps: float,
    es_n0: float,
    half_window_symbols: float = 12.0,
    max_precursors: int = 2,
) -> PathFit:
    """``paths`` with the paths up to a pilot's length (Np·T) *before* the arrival fit's window added.

    The detector locks on the strongest correlation peak, and the arrival fit
    looks ± 12 symbols around it. When the direct path is weaker than an echo
    over the pilot (impulses blanked in it, a fade) and the echo lies more
    than 12 symbols behind it (a bottom echo 2 ms late at 370 m in 27 m of
    water), the echo is taken as the direct path, metres off, with nothing in
    the fit to say so. :func:`fit_paths` is run again from ``paths`` over
    [arrival − Np·T, arrival + 12 T] with the same tests for a new path (a
    share of the strongest, 3.5 noise deviations); ``paths`` itself is
    returned when it finds none, so a frame without a precursor is measured
    as before. A precursor at least 0.3 of the strongest becomes the first
    path; a weaker one is left for the arrival's σ
    (:func:`~seamodem.receive.frame.earlier_path_gap_s`). The noise test counts
    the lags searched, (Np + 12)·(1 + α) independent complex lags against ±12
    symbols': :data:`_PRECURSOR_NOISE_DEVIATIONS` (4.1) instead of 3.5 keeps a
    noise peak below 1e-5 per frame (at 3.5 a single path at −2.8 dB took a
    noise peak 0.35 of it, 106 symbols early, as its arrival: the frame index
    slipped to the previous emission, 1.47 km off with σ 22 mm).
    """
    n_p = len(pilot)
    T = config.symbol_period_s / (1 + eps)
    found = fit_paths(r, fs, t0_s, config=config, pilot=pilot, t_start_s=t_start_s, eps=eps, es_n0=es_n0,
                      initial_delays_s=paths.delays_s, max_paths=len(paths.delays_s) + max_precursors,
                      window_s=(t_start_s - n_p * T, t_start_s + half_window_symbols * T),
                      noise_deviations=_PRECURSOR_NOISE_DEVIATIONS)
    if len(found.delays_s) == len(paths.delays_s):
        return paths
    return found


def _guard_es_n0(r, fs, t0_s, *, config: FrameConfig, pilot, y, first_s: float, eps: float) -> float:
    """Es/N0 of the first path: |A|² from its pilot outputs ``y``, the noise from the leading guard.

    The matched filter at the guard's symbol instants, from the frame start to 13
    symbols before the pilot, sees noise only: no later path reaches there, and
    earlier ones are within 12 symbols of the arrival. Infinite when the guard is
    too short (then only ``min_fraction`` limits the paths).
    """
    n_quiet = config.n_guard - 13
    if n_quiet < 4:
        return math.inf
    tau = np.arange(n_quiet) * config.symbol_period_s / (1 + eps)
    noise = matched_filter(r, fs, t0_s, first_s + tau, config=config, scale=1 + eps,
                           carrier_offset_hz=config.carrier_hz * eps, t_ref_s=first_s)
    power = float(np.mean(np.abs(noise) ** 2))
    gain = np.vdot(pilot, y) / len(pilot)
    return abs(gain) ** 2 / power if power > 0 else math.inf
