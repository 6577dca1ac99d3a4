"""Square-root raised-cosine (SRRC) pulse, continuous and sampled at any times.

The pulse is evaluated analytically at arbitrary instants, so a waveform can be
synthesised (and matched-filtered) exactly on a sample grid that is not an
integer multiple of the symbol rate (jmse2024: 15.02 samples per symbol).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.sparse

__all__ = ["srrc_pulse", "srrc_taps", "srrc_truncation_energy", "srrc_matrix"]


def srrc_pulse(t, symbol_period_s: float, rolloff: float) -> np.ndarray:
    """Untruncated SRRC pulse g(t) with unit energy, ∫ g² dt = 1.

    Parameters
    ----------
    t : array_like
        Times [s] relative to the pulse centre.
    symbol_period_s : float
        Symbol duration T [s].
    rolloff : float
        Roll-off α in [0, 1].

    Returns
    -------
    numpy.ndarray
        g(t) [1/√s], same shape as ``t``.

    Notes
    -----
    g(t) = [sin(π u (1 − α)) + 4 α u cos(π u (1 + α))] / [√T π u (1 − (4 α u)²)], u = t/T,
    with its limits at u = 0 and |u| = 1/(4α).
    """
    T = float(symbol_period_s)
    a = float(rolloff)
    u = np.asarray(t, dtype=float) / T
    out = np.empty_like(u)
    at_zero = np.abs(u) < 1e-12
    at_sing = (a > 0) & (np.abs(np.abs(u) - 1 / (4 * a if a > 0 else 1)) < 1e-9)
    regular = ~(at_zero | at_sing)
    ur = u[regular]
    num = np.sin(np.pi * ur * (1 - a)) + 4 * a * ur * np.cos(np.pi * ur * (1 + a))
    den = np.pi * ur * (1 - (4 * a * ur) ** 2)
    out[regular] = num / den
    out[at_zero] = 1 - a + 4 * a / np.pi
    if a > 0:
        out[at_sing] = (a / np.sqrt(2)) * (
            (1 + 2 / np.pi) * np.sin(np.pi / (4 * a)) + (1 - 2 / np.pi) * np.cos(np.pi / (4 * a))
        )
    return out / np.sqrt(T)


@lru_cache(maxsize=64)
def srrc_truncation_energy(rolloff: float, half_span_symbols: int) -> float:
    """Energy of the unit-energy SRRC inside |t| ≤ L·T (T = 1), L = half span.

    Computed by dense Simpson integration (4096 points per symbol); the truncated
    pulse is divided by the square root of this so that it has unit energy.
    """
    from scipy.integrate import simpson

    n = 4096 * half_span_symbols
    u = np.linspace(0.0, half_span_symbols, n + 1)
    g = srrc_pulse(u, 1.0, rolloff)
    return float(2 * simpson(g**2, x=u))


def _truncated(t, symbol_period_s, rolloff, span_symbols):
    half = span_symbols // 2
    g = srrc_pulse(t, symbol_period_s, rolloff) / np.sqrt(srrc_truncation_energy(float(rolloff), half))
    g[np.abs(np.asarray(t)) > half * symbol_period_s] = 0.0
    return g


def srrc_taps(samples_per_symbol: int, span_symbols: int, rolloff: float) -> np.ndarray:
    """Sampled, truncated SRRC filter with unit energy in discrete time.

    Parameters
    ----------
    samples_per_symbol : int
        Integer oversampling factor.
    span_symbols : int
        Even total span; the filter has ``span_symbols * samples_per_symbol + 1`` taps.
    rolloff : float
        Roll-off α.

    Returns
    -------
    numpy.ndarray, shape (span_symbols * samples_per_symbol + 1,)
        Symmetric taps with Σ h² = 1.
    """
    n = np.arange(-(span_symbols // 2) * samples_per_symbol, (span_symbols // 2) * samples_per_symbol + 1)
    h = _truncated(n / samples_per_symbol, 1.0, rolloff, span_symbols)
    return h / np.sqrt(np.sum(h**2))


def srrc_matrix(
    sample_times_s: np.ndarray,
    symbol_times_s: np.ndarray,
    *,
    symbol_period_s: float,
    rolloff: float,
    span_symbols: int,
) -> scipy.sparse.csr_matrix:
    """Sparse synthesis matrix G[n, k] = √T · g(t_n − t_k) of the truncated SRRC.

    ``G @ x`` is the complex baseband Σ_k x[k] √T g(t − t_k) sampled at
    ``sample_times_s``; with unit-power symbols its mean power is 1.
    ``G.conj().T @ r / (fs·T)`` is the matched filter sampled at the symbol
    times, exact whatever the ratio fs·T (the product of two signals band-limited
    to B < fs is sampled without aliasing).

    Parameters
    ----------
    sample_times_s : numpy.ndarray, shape (n_samples,)
        Uniformly spaced, increasing sample times [s].
    symbol_times_s : numpy.ndarray, shape (n_symbols,)
        Centre of each symbol's pulse [s]; any spacing.
    symbol_period_s, rolloff, span_symbols
        Pulse parameters, as in :func:`srrc_pulse`; the pulse is truncated to
        ±span/2 symbols and scaled to unit energy.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n_samples, n_symbols)
    """
    ts = np.asarray(sample_times_s, dtype=float)
    tk = np.asarray(symbol_times_s, dtype=float)
    if ts.size == 0 or tk.size == 0:
        return scipy.sparse.csr_matrix((ts.size, tk.size))
    dt = ts[1] - ts[0] if ts.size > 1 else 1.0
    half = (span_symbols // 2) * symbol_period_s
    first = np.clip(np.ceil((tk - half - ts[0]) / dt - 1e-9).astype(np.int64), 0, ts.size)
    last = np.clip(np.floor((tk + half - ts[0]) / dt + 1e-9).astype(np.int64) + 1, 0, ts.size)
    width = int(np.max(last - first)) if tk.size else 0
    rows = first[:, None] + np.arange(max(width, 0))[None, :]
    valid = rows < last[:, None]
    cols = np.broadcast_to(np.arange(tk.size)[:, None], rows.shape)
    rows, cols = rows[valid], cols[valid]
    values = np.sqrt(symbol_period_s) * _truncated(ts[rows] - tk[cols], symbol_period_s, rolloff, span_symbols)
    return scipy.sparse.csr_matrix((values, (rows, cols)), shape=(ts.size, tk.size))
