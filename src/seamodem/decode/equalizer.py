"""Fractionally spaced decision-feedback equaliser with a second-order PLL.

Stojanovic, Catipovic & Proakis (1994): the feedforward filter sees the
Doppler-compensated samples (``sps`` per symbol, 2 by default) rotated by the
PLL phase estimate; the feedback filter cancels the post-cursor ISI of past
decisions; both are adapted jointly (RLS or NLMS), trained on the pilots and
then decision-directed. The PLL tracks the residual carrier phase left by the
Doppler compensation (paper 000 §3.4: "residual phase compensation").

Tuning guidance
---------------
- ``n_ff`` (feedforward taps, in samples) should span the channel's delay
  spread plus a few symbols, with ``ff_centre`` samples of anticausal part so
  that a first arrival weaker than a later one is still captured. For 3 ms of
  spread at 6.4 kBd and 2 samples/symbol: about 2·20 + 8 taps.
- ``n_fb`` (feedback taps, in symbols) should cover the post-cursor spread.
- RLS: ``forgetting`` λ in [0.99, 0.9995]; effective memory 1/(1 − λ) symbols,
  which should be ≥ 10× the number of taps N or the tap noise eats the output
  SNR (64 taps at λ = 0.995 lost 9 dB against λ = 0.999 in a jmse2024 test).
  Converges in ~2N symbols, hence 150 pilots for up to ~70 taps. Costs O(N²)
  per symbol.
- NLMS: ``step`` μ in [0.01, 0.1]; O(N) per symbol but slower convergence:
  needs more training than 150 pilots give for long filters.
- PLL: ``pll_kp`` ≈ 0.01–0.05 and ``pll_ki`` ≈ kp²/4 (critically damped);
  0 and 0 disable it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..transmit.modulation import constellation

__all__ = ["DfeSettings", "DfeResult", "dfe_equalize", "mmse_dfe_taps"]


@dataclass(frozen=True, kw_only=True)
class DfeSettings:
    """Equaliser parameters (see the module docstring for guidance).

    Attributes
    ----------
    sps : int
        Input samples per symbol of the feedforward filter, ≥ 1.
    n_ff : int
        Feedforward taps [samples], ≥ 1.
    ff_centre : int
        Anticausal feedforward taps [samples], in [0, n_ff); the tap initialised to 1.
    n_fb : int
        Feedback taps [symbols], ≥ 0.
    algorithm : {"rls", "nlms"}
        Adaptation algorithm.
    forgetting : float
        RLS forgetting factor λ, in (0, 1].
    step : float
        NLMS step size μ, in (0, 2).
    pll_kp, pll_ki : float
        Proportional and integral gains of the PLL; 0 and 0 disable it.
    rls_delta : float
        RLS initialisation: the inverse correlation matrix starts at I/δ.
    """

    sps: int = 2
    n_ff: int = 24
    ff_centre: int = 8
    n_fb: int = 8
    algorithm: str = "rls"
    forgetting: float = 0.999
    step: float = 0.05
    pll_kp: float = 0.02
    pll_ki: float = 1e-4
    rls_delta: float = 1e-2

    def __post_init__(self):
        from ..errors import ConfigError

        if self.algorithm not in ("rls", "nlms"):
            raise ConfigError("algorithm", f"must be 'rls' or 'nlms', got {self.algorithm!r}")
        if self.sps < 1 or self.n_ff < 1 or self.n_fb < 0:
            raise ConfigError("n_ff", f"need sps >= 1, n_ff >= 1, n_fb >= 0, got {self.sps}, {self.n_ff}, {self.n_fb}")
        if not 0 <= self.ff_centre < self.n_ff:
            raise ConfigError("ff_centre", f"must be in [0, n_ff = {self.n_ff}), got {self.ff_centre}")
        if not 0 < self.forgetting <= 1:
            raise ConfigError("forgetting", f"must be in (0, 1], got {self.forgetting}")
        if not 0 < self.step < 2:
            raise ConfigError("step", f"must be in (0, 2), got {self.step}")


@dataclass(frozen=True)
class DfeResult:
    """Equaliser output.

    Attributes
    ----------
    soft : numpy.ndarray, shape (n_symbols,)
        Equaliser outputs z_k (before decision).
    decisions : numpy.ndarray, shape (n_symbols,)
        Training symbols, then hard decisions.
    phase : numpy.ndarray, shape (n_symbols,)
        PLL phase estimate [rad].
    taps : numpy.ndarray, shape (n_ff + n_fb,)
        Final joint tap vector w (z = wᴴu, u = [rotated samples, past decisions]).
    noise_var : float
        Mean |z − decision|² over the decision-directed part.
    """

    soft: np.ndarray
    decisions: np.ndarray
    phase: np.ndarray
    taps: np.ndarray
    noise_var: float

    @property
    def snr_db(self) -> float:
        """Output SNR, 10·log10(1/noise_var) for unit-energy symbols [dB]."""
        return float(10 * np.log10(1 / max(self.noise_var, 1e-12)))


@njit(cache=True, nogil=True)
def _dfe(x, sps, n_sym, train, n_train, n_ff, ff_centre, n_fb, use_rls, lam, mu, kp, ki, delta, points):
    n = n_ff + n_fb
    w = np.zeros(n, dtype=np.complex128)
    w[ff_centre] = 1.0
    # P (Hermitian, n × n) as real and imaginary planes, updated with exactly the floating-point
    # operations complex arithmetic does (bit-identical results), so that the loops vectorise
    Pr = np.eye(n) / delta
    Pim = np.zeros((n, n))
    Pur = np.zeros(n)
    Pui = np.zeros(n)
    ur = np.zeros(n)
    ui = np.zeros(n)
    u = np.zeros(n, dtype=np.complex128)
    Pu = np.zeros(n, dtype=np.complex128)
    g = np.zeros(n, dtype=np.complex128)
    past = np.zeros(max(n_fb, 1), dtype=np.complex128)
    soft = np.empty(n_sym, dtype=np.complex128)
    dec = np.empty(n_sym, dtype=np.complex128)
    phase = np.empty(n_sym)
    theta = 0.0
    integ = 0.0
    for k in range(n_sym):
        rot = np.exp(-1j * theta)
        start = sps * k - ff_centre
        for i in range(n_ff):
            j = start + i
            u[i] = x[j] * rot if 0 <= j < x.size else 0.0
        for i in range(n_fb):
            u[n_ff + i] = past[i]
        z = 0.0j
        p = 0.0j
        for i in range(n):
            z += np.conj(w[i]) * u[i]
        for i in range(n_ff):
            p += np.conj(w[i]) * u[i]
        if k < n_train:
            d = train[k]
        else:
            best = 0
            bd = 1e300
            for m in range(points.size):
                dd = abs(z - points[m])
                if dd < bd:
                    bd = dd
                    best = m
            d = points[best]
        e = d - z
        if use_rls:
            # P is Hermitian, so uᴴP = (Pu)ᴴ: one matrix-vector product, then a rank-one downdate in place
            for i in range(n):
                ur[i] = u[i].real
                ui[i] = u[i].imag
            # Pu = P u, two rows at a time (independent accumulators; each row summed in the same order)
            i0 = 0
            while i0 + 2 <= n:
                sr0 = 0.0
                si0 = 0.0
                sr1 = 0.0
                si1 = 0.0
                for j in range(n):
                    sr0 += Pr[i0, j] * ur[j] - Pim[i0, j] * ui[j]
                    si0 += Pr[i0, j] * ui[j] + Pim[i0, j] * ur[j]
                    sr1 += Pr[i0 + 1, j] * ur[j] - Pim[i0 + 1, j] * ui[j]
                    si1 += Pr[i0 + 1, j] * ui[j] + Pim[i0 + 1, j] * ur[j]
                Pur[i0] = sr0
                Pui[i0] = si0
                Pur[i0 + 1] = sr1
                Pui[i0 + 1] = si1
                i0 += 2
            for i in range(i0, n):
                sr = 0.0
                si = 0.0
                for j in range(n):
                    sr += Pr[i, j] * ur[j] - Pim[i, j] * ui[j]
                    si += Pr[i, j] * ui[j] + Pim[i, j] * ur[j]
                Pur[i] = sr
                Pui[i] = si
            denom = lam
            for i in range(n):
                Pu[i] = complex(Pur[i], Pui[i])
                denom += np.real(np.conj(u[i]) * Pu[i])
            for i in range(n):
                g[i] = Pu[i] / denom
                w[i] += g[i] * np.conj(e)
            for i in range(n):
                gr = g[i].real
                gim = g[i].imag
                for j in range(n):
                    # P[i, j] = (P[i, j] − g[i] conj(Pu[j])) / λ, part by part
                    Pr[i, j] = (Pr[i, j] - (gr * Pur[j] + gim * Pui[j])) / lam
                    Pim[i, j] = (Pim[i, j] - (gim * Pur[j] - gr * Pui[j])) / lam
        else:
            norm = 1e-9
            for i in range(n):
                norm += np.real(np.conj(u[i]) * u[i])
            for i in range(n):
                w[i] += mu * u[i] * np.conj(e) / norm
        # phase detector on the feedforward output, then a proportional-integral loop
        err = np.imag(p * np.conj(d))
        integ += ki * err
        theta += kp * err + integ
        soft[k] = z
        dec[k] = d
        phase[k] = theta
        for i in range(n_fb - 1, 0, -1):
            past[i] = past[i - 1]
        if n_fb > 0:
            past[0] = d
    return soft, dec, phase, w


def dfe_equalize(
    x: np.ndarray,
    training: np.ndarray,
    n_symbols: int,
    modulation: str,
    settings: DfeSettings = DfeSettings(),
) -> DfeResult:
    """Equalise ``n_symbols`` symbols from fractionally spaced samples.

    Parameters
    ----------
    x : numpy.ndarray, complex
        Doppler-compensated, matched-filtered baseband with ``settings.sps``
        samples per symbol; x[sps·k] is symbol k's instant on the reference path.
    training : numpy.ndarray, complex
        Known first symbols (the pilots).
    n_symbols : int
        Symbols to produce (training + data).
    modulation : {"bpsk", "qpsk", "8psk"}
        Constellation of the decision-directed part.
    settings : DfeSettings

    Returns
    -------
    DfeResult
    """
    s = settings
    x = np.ascontiguousarray(x, dtype=np.complex128)
    train = np.ascontiguousarray(training, dtype=np.complex128)
    # every argument typed as the kernel's one signature (a PLL gain given as 0 would compile a second one)
    soft, dec, phase, w = _dfe(
        x, int(s.sps), int(n_symbols), train, train.size, int(s.n_ff), int(s.ff_centre), int(s.n_fb),
        s.algorithm == "rls", float(s.forgetting), float(s.step), float(s.pll_kp), float(s.pll_ki),
        float(s.rls_delta), constellation(modulation).astype(np.complex128),
    )
    dd = slice(train.size, None)
    noise_var = float(np.mean(np.abs(soft[dd] - dec[dd]) ** 2)) if n_symbols > train.size else float("nan")
    return DfeResult(soft, dec, phase, w, noise_var)


def mmse_dfe_taps(h: np.ndarray, settings: DfeSettings, noise_var: float) -> np.ndarray:
    """Wiener (MMSE) joint taps w = R⁻¹p for a known fixed channel, correct past decisions.

    The independent reference for the adaptive equaliser.

    Parameters
    ----------
    h : numpy.ndarray, complex
        Channel impulse response at the fractional spacing: x[n] = Σ_m h[m] s[(n − m)/sps]
        over the symbol instants n − m ≡ 0 (mod sps), plus white noise of variance ``noise_var``.
    settings : DfeSettings
    noise_var : float
        Per-sample complex noise variance.

    Returns
    -------
    numpy.ndarray, shape (n_ff + n_fb,)
    """
    s = settings
    # symbol k is at sample sps·k; the FF window covers samples sps·k − centre + i
    lo = -(s.n_ff + h.size) // s.sps - 2
    hi = s.n_fb + (s.n_ff + h.size) // s.sps + 2
    idx = np.arange(-hi, -lo + 1)  # symbol offsets j: s[k + j]
    A = np.zeros((s.n_ff + s.n_fb, idx.size), dtype=complex)
    for i in range(s.n_ff):
        n = -s.ff_centre + i  # sample offset from sps·k
        for col, j in enumerate(idx):
            m = n - s.sps * j
            if 0 <= m < h.size:
                A[i, col] = h[m]
    for i in range(s.n_fb):
        A[s.n_ff + i, np.flatnonzero(idx == -(i + 1))[0]] = 1.0
    noise = np.zeros(s.n_ff + s.n_fb)
    noise[: s.n_ff] = noise_var
    R = A @ A.conj().T + np.diag(noise)
    p = A[:, np.flatnonzero(idx == 0)[0]]
    return np.linalg.solve(R, p)
