"""Turbo equalisation: a soft-interference-cancelling MMSE equaliser exchanging extrinsic LLRs with the BCJR decoder.

Pass 0 is the adaptive DFE (:func:`dfe_equalize`): its PLL phase track removes
the residual carrier phase; its soft outputs are demapped and decoded. Each
further pass (Tüchler, Koetter & Singer 2002, with the time-invariant
"approximate" MMSE filter):

1. a fractionally spaced channel h is estimated by least squares over the whole
   frame from the pilots and the re-encoded decoder decisions, on samples
   derotated by the DFE's phase track; the residual gives the noise variance σ²;
2. the decoder's extrinsic LLRs on the coded bits (interleaved and scrambled
   back to on-air order) give soft symbols s̄ and their mean variance v̄;
3. for each symbol, ŝ_k = fᴴ(x_k − H s̄ + h₀ s̄_k), f = (v̄ H Hᴴ + (1 − v̄) h₀h₀ᴴ + σ² I)⁻¹ h₀,
   so that ŝ_k = μ s_k + w, μ = fᴴh₀, var(w) = μ − μ²; its extrinsic LLRs go to
   the decoder.

Every pass's LLRs take each symbol's own noise variance (:func:`symbol_noise_var`):
the frame's, measured robustly, or the symbol's own error power where that is
larger, so that a symbol an impulse hit (a click below the blanker's threshold,
or a stretch the blanker zeroed) does not pull the decoder with the confidence
of a clean one.

BPSK and QPSK (Gray, one bit per real dimension) are supported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from ..errors import ConfigError
from ..transmit.coding import encode_info, interleaver_permutation, parse_info_block, pn9_sequence
from ..transmit.modulation import bits_to_symbols, constellation, nearest_labels
from .bcjr import bcjr_decode
from .demap import soft_demap
from .equalizer import DfeResult, DfeSettings, dfe_equalize
from .payload import DecodedPayload, code_order_llr

__all__ = ["TurboResult", "turbo_equalize", "estimate_channel", "symbol_noise_var"]

#: A-priori LLR given to the known zero fill bits after the code's tail.
_FILL_LLR = 20.0


@dataclass(frozen=True)
class TurboResult:
    """Outcome of turbo equalisation.

    Attributes
    ----------
    decoded : DecodedPayload
        Result of the last pass run.
    crc_by_pass : tuple of bool
        CRC outcome after each pass (pass 0 = DFE only); stops at the first success.
    dfe : DfeResult
        The pass-0 equaliser's outputs (soft symbols, PLL phase, output SNR).
    """

    decoded: DecodedPayload
    crc_by_pass: tuple[bool, ...]
    dfe: DfeResult

    @property
    def passes(self) -> int:
        return len(self.crc_by_pass)


def _convolution_matrix(symbols: np.ndarray, n_samples: int, sps: int, n_taps: int, centre: int) -> np.ndarray:
    """A[n, m] = s[k] where sps·k = n + centre − m: x = A h is the channel output."""
    up = np.zeros(sps * symbols.size, complex)
    up[::sps] = symbols
    idx = np.arange(n_samples)[:, None] + centre - np.arange(n_taps)[None, :]
    valid = (idx >= 0) & (idx < up.size)
    return np.where(valid, up[np.clip(idx, 0, up.size - 1)], 0)


def estimate_channel(x: np.ndarray, symbols: np.ndarray, sps: int, n_taps: int, centre: int) -> tuple[np.ndarray, float]:
    """Least-squares fractionally spaced channel: x[sps·k − centre + m] ≈ Σ_k h[m] s[k].

    Returns
    -------
    h : numpy.ndarray, shape (n_taps,)
    noise_var : float
        Mean squared residual per sample.
    """
    A = _convolution_matrix(symbols, x.size, sps, n_taps, centre)
    h, *_ = np.linalg.lstsq(A, x, rcond=None)
    return h, float(np.mean(np.abs(x - A @ h) ** 2))


def _air_bits_llr(code_extrinsic: np.ndarray, config: FrameConfig) -> np.ndarray:
    n = config.n_coded_bits
    code = np.full(n, _FILL_LLR)
    code[: code_extrinsic.size] = code_extrinsic
    return code[interleaver_permutation(n)] * (1.0 - 2.0 * pn9_sequence(n))


def _soft_symbols(llr_air: np.ndarray, modulation: str) -> np.ndarray:
    t = np.tanh(np.clip(llr_air, -30, 30) / 2)
    if modulation == "bpsk":
        return t.astype(complex)
    return (t[0::2] + 1j * t[1::2]) / np.sqrt(2)


#: a symbol whose error power is beyond this many times its noise variance gets its own error power over it
#: as its variance (a complex Gaussian's |e|² exceeds 3σ² in e⁻³ ≈ 5 % of symbols, by little)
OUTLIER_SCALE = 3.0


def symbol_noise_var(y: np.ndarray, modulation: str) -> np.ndarray:
    """Each equalised symbol's noise variance for the demapper.

    The frame's variance σ̂² = median|y − ŷ|² / ln 2 (ŷ the nearest constellation point: a complex
    Gaussian's variance, which a few symbols hit by impulses do not move, where the mean does), or the
    symbol's own |y − ŷ|² / :data:`OUTLIER_SCALE` where that is larger: a symbol an impulse hit has its
    LLRs shrunk towards erasure instead of pulling the decoder (Huber-like). On the corpus's failing
    recordings at ≥ 8 dB (docs/performance.md), clicks: 4 → 8 and 6 → 10 frames of 10 decoded.

    Examples
    --------
    >>> y = np.array([1.1, -0.9, 1.0, 0.8, -1.2, 4.0]) + 0j  # the last: an impulse
    >>> np.round(symbol_noise_var(y, "bpsk"), 3)
    array([0.036, 0.036, 0.036, 0.036, 0.036, 3.   ])
    """
    y = np.asarray(y, dtype=complex)
    if y.size == 0:
        return np.zeros(0)
    err2 = np.abs(y - constellation(modulation)[nearest_labels(y, modulation)]) ** 2
    return np.maximum(float(np.median(err2)) / math.log(2.0), err2 / OUTLIER_SCALE)


def _decode(llr_air: np.ndarray, config: FrameConfig):
    info_llr, extrinsic = bcjr_decode(code_order_llr(llr_air, config), config.n_info_bits)
    info = (info_llr < 0).astype(np.uint8)
    payload, ok = parse_info_block(info, config)
    return DecodedPayload(payload, ok, info), extrinsic


def turbo_equalize(
    x: np.ndarray,
    pilots: np.ndarray,
    config: FrameConfig,
    *,
    settings: DfeSettings = DfeSettings(),
    passes: int = 4,
    channel_taps: int | None = None,
    window: int | None = None,
    per_symbol_noise: bool = True,
) -> TurboResult:
    """Equalise and decode one frame, iterating until the CRC passes or ``passes`` are spent.

    Parameters
    ----------
    x : numpy.ndarray, complex
        Doppler-compensated, matched-filtered samples, ``settings.sps`` per symbol,
        x[sps·k] at symbol k (k = 0: first pilot), as for :func:`dfe_equalize`.
    pilots : numpy.ndarray, complex, shape (n_pilot,)
    config : FrameConfig
        Frame whose ``n_data`` symbols follow the pilots (BPSK or QPSK).
    settings : DfeSettings
        Pass-0 equaliser; its ``n_ff`` and ``ff_centre`` also set the SIC window
        and the channel estimate's span unless given.
    passes : int
        Maximum passes, ≥ 1 (1 = DFE only).
    channel_taps, window : int, optional
        Length of the estimated channel and of the SIC filter, in samples.
    per_symbol_noise : bool
        Each symbol's LLRs with its own noise variance (:func:`symbol_noise_var`, default); False: one
        variance for the frame (the DFE's mean error power, the SIC's var(w)/μ²), as before.
    """
    if config.modulation not in ("bpsk", "qpsk"):
        raise ConfigError("modulation", f"turbo equalisation supports bpsk and qpsk, got {config.modulation!r}")
    if passes < 1:
        raise ConfigError("passes", f"must be >= 1, got {passes}")
    sps = settings.sps
    n_sym = config.n_pilot + config.n_data
    x = np.asarray(x, dtype=complex)[: sps * n_sym + settings.n_ff]
    dfe = dfe_equalize(x, pilots, n_sym, config.modulation, settings)
    data = dfe.soft[config.n_pilot :]
    llr_air = soft_demap(data, symbol_noise_var(data, config.modulation) if per_symbol_noise else dfe.noise_var,
                         config.modulation)
    decoded, extrinsic = _decode(llr_air, config)
    history = [decoded.crc_ok]
    if decoded.crc_ok or passes == 1:
        return TurboResult(decoded, tuple(history), dfe)

    centre = settings.ff_centre
    n_taps = channel_taps or settings.n_ff
    n_win = window or settings.n_ff
    phase = np.repeat(dfe.phase, sps)
    phase = np.pad(phase, (0, max(0, x.size - phase.size)), mode="edge")[: x.size]
    derot = x * np.exp(-1j * phase)
    # The window and the channel estimate share the same centre, so window sample i of symbol k
    # sees symbol k + j through h[i − sps·j]: offsets j from −(n_taps − 1)/sps to (n_win − 1)/sps.
    offsets = np.arange(-((n_taps - 1) // sps), -(-(n_win - 1) // sps) + 1)
    win_idx = sps * np.arange(n_sym)[:, None] - centre + np.arange(n_win)[None, :]
    win_ok = (win_idx >= 0) & (win_idx < derot.size)
    X = np.where(win_ok, derot[np.clip(win_idx, 0, derot.size - 1)], 0)
    for _ in range(passes - 1):
        reference = np.concatenate([pilots, bits_to_symbols(encode_info(decoded.info_bits, config), config.modulation)])
        h, noise_var = estimate_channel(derot, reference, sps, n_taps, centre)
        Hw = np.zeros((n_win, offsets.size), complex)
        for col, j in enumerate(offsets):
            m = np.arange(n_win) - sps * j
            ok = (m >= 0) & (m < n_taps)
            Hw[ok, col] = h[m[ok]]
        h0 = Hw[:, np.flatnonzero(offsets == 0)[0]]
        means = np.concatenate([pilots, _soft_symbols(_air_bits_llr(extrinsic, config), config.modulation)])
        v_bar = float(np.mean(1 - np.abs(means[config.n_pilot :]) ** 2))
        cov = v_bar * Hw @ Hw.conj().T + (1 - v_bar) * np.outer(h0, h0.conj()) + max(noise_var, 1e-9) * np.eye(n_win)
        f = np.linalg.solve(cov, h0)
        mu = float(np.real(np.vdot(f, h0)))
        k_idx = np.arange(n_sym)[:, None] + offsets[None, :]
        k_ok = (k_idx >= 0) & (k_idx < n_sym)
        S = np.where(k_ok, means[np.clip(k_idx, 0, n_sym - 1)], 0)
        est = (X - S @ Hw.T + np.outer(means, h0)) @ f.conj()
        var_w = max(mu - mu * mu, 1e-9)
        data = est[config.n_pilot :] / mu
        llr_air = soft_demap(data, symbol_noise_var(data, config.modulation) if per_symbol_noise else var_w / mu**2,
                             config.modulation)
        decoded, extrinsic = _decode(llr_air, config)
        history.append(decoded.crc_ok)
        if decoded.crc_ok:
            break
    return TurboResult(decoded, tuple(history), dfe)
