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
Two sweeps over the paths suffice: the paths interfere only through the
data's random cross-correlation once their delays differ by a symbol or more.

The standard deviation of each path's Doppler is the least-squares one from
the segments' phase residuals (it grows with whatever the model leaves:
unresolved or unfitted echoes, impulses, noise), never below the CRLB of a
known signal at the path's measured Es/N0 (Rife & Boorstyn, SPEC §6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from ..transmit.pulse import srrc_truncation_energy
from .doppler import _srrc_interp, matched_filter

__all__ = ["WholeFrameFit", "fit_whole_frame", "known_signal_velocity_crlb_mps"]


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
    n_reference : int
        Symbols used as the reference (known or confident).
    """

    delays_s: np.ndarray
    amplitudes: np.ndarray
    v_mps: np.ndarray
    accel_mps2: np.ndarray
    sigma_v_mps: np.ndarray
    crlb_v_mps: np.ndarray
    es_n0: np.ndarray
    n_reference: int


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


def _instants(config: FrameConfig, delay_s: float, eps: float, beta: float) -> np.ndarray:
    """Arrival of each symbol's pulse centre on a path: α(t) = τ_k solved to first order in the drift."""
    tau = (config.n_guard + np.arange(config.n_pilot + config.n_data)) * config.symbol_period_s
    half = config.frame_duration_s / 2
    d = tau / (1 + eps)
    return delay_s + (tau - 0.5 * beta * ((d - half) ** 2 - half**2)) / (1 + eps)


def _phase(config: FrameConfig, t_rel: np.ndarray, eps: float, beta: float) -> np.ndarray:
    """Carrier phase of a path at t − τ_p [rad] (module docstring)."""
    half = config.frame_duration_s / 2
    return 2 * np.pi * config.carrier_hz * (eps * t_rel + 0.5 * beta * ((t_rel - half) ** 2 - half**2))


def _synthesize(n: int, fs: float, t0_s: float, *, config: FrameConfig, symbols, instants, scale: float) -> np.ndarray:
    """Σ_k x_k g₁((t_n − t_k)/T')/√E on the grid t_n = t0 + n/fs, without the carrier phase."""
    T = config.symbol_period_s / scale
    n_half = config.srrc_span_symbols // 2
    width = int(math.ceil(2 * n_half * T * fs)) + 2
    first = np.ceil((instants - n_half * T - t0_s) * fs - 1e-9).astype(np.int64)
    idx = first[:, None] + np.arange(width)[None, :]
    u = (t0_s + idx / fs - instants[:, None]) / T
    g = _srrc_interp(u, float(config.rolloff), n_half) * (np.abs(u) <= n_half)
    g /= math.sqrt(srrc_truncation_energy(float(config.rolloff), n_half))
    ok = (idx >= 0) & (idx < n)
    values = (g * symbols[:, None])[ok]
    where = idx[ok]
    return np.bincount(where, values.real, minlength=n) + 1j * np.bincount(where, values.imag, minlength=n)


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
    sweeps: int = 2,
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
        Passes over the paths (one when there is a single path). In the first,
        each path's matched filter runs twice: the Doppler found moves the
        symbol instants.
    """
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
    t_grid = t0_s + np.arange(len(bb)) / fs
    lo = max(0, int((delays[0] - t0_s) * fs) - config.srrc_span_symbols * int(fs * config.symbol_period_s + 1))
    hi = min(len(bb), int((delays[-1] + config.frame_duration_s - t0_s) * fs) + 1)
    seg_bb, seg_t, seg_t0 = bb[lo:hi], t_grid[lo:hi], t0_s + lo / fs
    models = np.zeros((n_paths, hi - lo), complex)
    # segments of equal reference-symbol counts
    edges = np.linspace(0, n_ref, n_segments + 1).round().astype(int)
    seg_of = np.searchsorted(edges, np.arange(n_ref), side="right") - 1

    def model(p):
        inst = _instants(config, delays[p], eps[p], beta[p])
        shape = _synthesize(hi - lo, fs, seg_t0, config=config, symbols=x, instants=inst, scale=1 + eps[p])
        return amps[p] * shape * np.exp(1j * _phase(config, seg_t - delays[p], eps[p], beta[p]))

    def outputs(p, r):
        """Symbols stripped matched-filter outputs z_k of path p, drift phase removed."""
        inst = _instants(config, delays[p], eps[p], beta[p])[ref_idx]
        y = matched_filter(r, fs, seg_t0, inst, config=config, scale=1 + eps[p],
                           carrier_offset_hz=f0 * eps[p], t_ref_s=delays[p])
        extra = _phase(config, inst - delays[p], 0.0, beta[p])
        return y * np.exp(-1j * extra) * np.conj(x[ref_idx]), inst

    sigma_b = np.full(n_paths, math.inf)
    # a lone path has nothing to alternate with: one sweep; later sweeps start close, one pass each
    for sweep in range(sweeps if n_paths > 1 else 1):
        for p in range(n_paths):
            others = models.sum(axis=0) - models[p]
            r = seg_bb - others
            for _ in range(2 if sweep == 0 else 1):
                z, inst = outputs(p, r)
                zs = np.bincount(seg_of, z.real, n_segments) + 1j * np.bincount(seg_of, z.imag, n_segments)
                counts = np.bincount(seg_of, minlength=n_segments).astype(float)
                ts = np.bincount(seg_of, inst, n_segments) / counts - (delays[p] + config.frame_duration_s / 2)
                phi = np.unwrap(np.angle(zs))
                w = np.abs(zs) ** 2 / counts  # ∝ segment SNR: phase variance 1/(2·SNR)
                design = np.column_stack([np.ones(n_segments), ts, ts**2])
                sw = np.sqrt(w)
                coef, *_ = np.linalg.lstsq(design * sw[:, None], phi * sw, rcond=None)
                resid = phi - design @ coef
                dof = n_segments - 3
                s2 = float(np.sum(w * resid**2) / dof)
                cov = s2 * np.linalg.inv(design.T @ (design * w[:, None]))
                sigma_b[p] = math.sqrt(cov[1, 1])
                eps[p] += coef[1] / (2 * np.pi * f0)
                beta[p] += coef[2] / (np.pi * f0)
            # the amplitude from the last outputs, less the phase the update added to the model
            # (c1·(t − τ_p) + c2·((t − t_c)² − (D/2)²)); the update moves the instants by a hair
            half = config.frame_duration_s / 2
            tk = inst - (delays[p] + half)
            amps[p] = np.mean(z * np.exp(-1j * (coef[1] * (tk + half) + coef[2] * (tk**2 - half**2))))
            models[p] = model(p)
    # noise per matched-filter output from the residual of all paths, at the first path's instants
    resid = seg_bb - models.sum(axis=0)
    inst = _instants(config, delays[0], eps[0], beta[0])[ref_idx]
    noise = matched_filter(resid, fs, seg_t0, inst, config=config, scale=1 + eps[0],
                           carrier_offset_hz=f0 * eps[0], t_ref_s=delays[0])
    noise_var = max(float(np.mean(np.abs(noise) ** 2)), np.finfo(float).tiny)
    es_n0 = np.abs(amps) ** 2 / noise_var
    crlb = known_signal_velocity_crlb_mps(config, es_n0, n_ref, sound_speed_mps=c)
    sigma_ls = c * sigma_b / (2 * np.pi * f0)
    return WholeFrameFit(
        delays_s=delays,
        amplitudes=amps.copy(),
        v_mps=eps * c,
        accel_mps2=beta * c,
        sigma_v_mps=np.maximum(sigma_ls, crlb),
        crlb_v_mps=crlb,
        es_n0=es_n0,
        n_reference=int(n_ref),
    )
