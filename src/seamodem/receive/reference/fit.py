"""The fine fit of one detection: arrival, Doppler scale, paths, E/N0 and σ's (:func:`fit_reference`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...transmit.reference import ReferenceBound, Replica, reference_crlb
from .detect import ReferenceDetection, replica_samples
from .paths import ECHO_WINDOW_S, ECHO_Z, EARLY_WINDOW_S, EARLY_Z, FIRST_PATH_FRACTION, PathFitter

__all__ = ["ReferenceFit", "fit_reference", "DOPPLER_THRESHOLD", "MISFIT_LIMIT", "NOISE_GAP_S", "NOISE_WINDOW_S"]

#: a Doppler CRLB above this fraction of v_max/c means the ping cannot measure its Doppler (σ_ε is then v_max/c)
DOPPLER_THRESHOLD = 0.1
#: a fit whose residual exceeds this many times the noise has its Doppler (and place on the ridge) untrusted
MISFIT_LIMIT = 4.0
#: noise level window before the arrival, after a gap [s]
NOISE_GAP_S, NOISE_WINDOW_S = 0.005, 0.05


@dataclass(frozen=True)
class ReferenceFit:
    """Fine arrival time, Doppler scale and their bounds for one detection (:func:`fit_reference`).

    Parameters
    ----------
    t_arrival_s : float
        Reception time of the reference's first sample, first path [s].
    eps : float
        Doppler scale ε = v_r/c.
    gain : complex
        Complex amplitude A (baseband units).
    e_n0 : float
        Measured E/N0 (linear).
    snr_db : float
        In-band SNR over [f_low, f_high] during the reference [dB].
    sigma_t_s, sigma_eps : float
        CRLB at the measured E/N0 × the misfit inflation √χ² × the fitted echoes' inflation (the
        multi-path Fisher matrix over the direct path's alone); σ_ε is v_max/c when that exceeds
        :data:`DOPPLER_THRESHOLD`·v_max/c; σ_t = √(σ_ridge² + g²σ_ε²) (the joint CRLB when σ_ε is).
    ridge_t_s, sigma_ridge_s : float
        The delay–Doppler ridge coordinate t_a + g·ε (g the reference's ridge slope) and its σ (the known-ε bound):
        what two pings' spacing is measured with.
    misfit : float
        χ² of the residual per sample over the noise level (≈ 1: noise only).
    ridge_slope_s : float
        g of the reference (:class:`~seamodem.transmit.reference.ReferenceBound`).
    n_paths : int
        Paths fitted: the direct one and the echoes found beside it.
    """

    t_arrival_s: float
    eps: float
    gain: complex
    e_n0: float
    snr_db: float
    sigma_t_s: float
    sigma_eps: float
    ridge_t_s: float
    sigma_ridge_s: float
    misfit: float
    ridge_slope_s: float = 0.0
    n_paths: int = 1


def fit_reference(
    r: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    replica: Replica,
    carrier_hz: float,
    detection: ReferenceDetection,
    search_eps: float,
    noise_bandwidth_hz: float,
    eps_max: float,
    bound: ReferenceBound | None = None,
) -> ReferenceFit:
    """Maximum-likelihood (t_a, ε) around a coarse detection.

    Parameters
    ----------
    r : numpy.ndarray, complex
        Baseband at carrier ``carrier_hz``; r[n] at t0 + n/fs.
    fs : float
        Baseband sample rate [Hz].
    t0_s : float
        Time of ``r[0]`` [s].
    replica : Replica
        The reference's replica.
    carrier_hz : float
        Mixing frequency of the baseband [Hz].
    detection : ReferenceDetection
        The coarse detection: start lag and scale bin.
    search_eps : float
        Half-width of the ε dichotomy (the bank spacing).
    noise_bandwidth_hz : float
        The front end's ∫|H|² df [Hz], to turn the baseband noise variance into N0.
    eps_max : float
        Largest |ε| searched (v_max/c).
    bound : ReferenceBound, optional
        :func:`~seamodem.transmit.reference.reference_crlb` of the replica (computed if not given).

    Returns
    -------
    ReferenceFit
        Arrival of the first path [s], ε, gain, E/N0, SNR, σ's, ridge coordinate, misfit and paths.
    """
    bound = reference_crlb(replica) if bound is None else bound
    g = bound.ridge_slope_s
    dur = replica.duration_s
    limit = 1.05 * eps_max
    # a ridge longer than the main lobe over ±limit (a chirp): the detection may sit anywhere along it
    ridge_s = abs(g) * 2 * limit
    scan = ridge_s > 1.0 / replica.reference.bandwidth_hz
    reach = ridge_s if scan else 0.0
    lo = max(0, int(math.floor((detection.t_start_s - EARLY_WINDOW_S - reach - 2 / fs - t0_s) * fs)))
    hi = min(len(r), int(math.ceil((detection.t_start_s + dur * 1.01 + ECHO_WINDOW_S + reach + 2 / fs - t0_s) * fs)) + 1)
    x = r[lo:hi]
    t = t0_s + np.arange(lo, hi) / fs
    path = PathFitter(replica, t, carrier_hz, fs, g, limit)
    echoes: list = []
    noise = _noise_level(r, fs, t0_s, detection.t_start_s, dur / (1 + detection.eps)) if scan else None
    if scan and noise is not None:
        # a chirp's ε from the joint likelihood of its paths (see PathFitter.scan_paths)
        times, amps, eps = path.scan_paths(x, detection.t_start_s, detection.eps, noise)
    else:
        ta, eps = path.fit(x, detection.t_start_s, detection.eps, search_eps, grid=True)
        noise = _noise_level(r, fs, t0_s, ta, dur / (1 + eps))
        times, amps = np.array([ta]), None
        if noise is not None:
            # echoes overlapping the ping leak through the replica's sidelobes and pull the direct path: the
            # paths are the replica's significant peaks around the fit (an earlier one is the first arrival)
            times, amps, _ = path.paths_at(x, path.peaks(x, ta, eps, noise), eps)
            if len(times) == 1 or np.min(times) >= ta - 3.0 / replica.reference.bandwidth_hz:
                found = path.early_path(x, times, eps, noise)
                if found is not None:
                    times, amps = found
    if amps is None:
        q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
        gain = np.vdot(q, x) / float(np.real(np.vdot(q, q)))
    else:
        # paths too weak to matter are dropped; the first arrival is the earliest of FIRST_PATH_FRACTION of
        # the strongest; every path is then polished on the others' residual (SAGE)
        eq_s = float(np.sum(np.abs(replica_samples(replica, fs, carrier_hz, eps)) ** 2))
        strongest = int(np.argmax(np.abs(amps)))
        keep = np.abs(amps) ** 2 * eq_s / noise >= np.where(times < times[strongest], EARLY_Z, ECHO_Z)
        keep[strongest] = True
        order = np.argsort(times[keep])
        times, amps = times[keep][order], amps[keep][order]
        first = int(np.flatnonzero(np.abs(amps) >= FIRST_PATH_FRACTION * np.max(np.abs(amps)))[0])
        paths = [[float(tp), eps, complex(ap), replica.scaled(t, t_arrival_s=float(tp), eps=eps, carrier_hz=carrier_hz)]
                 for tp, ap in zip(times, amps)]
        ta, eps, gain, q = paths.pop(first)
        echoes = paths
        if not echoes and scan:  # the joint Gauss–Newton polish of what the dichotomy's tolerance left
            ta, eps = path.fit(x, ta, eps, 0.0, grid=False)
    if echoes:
        for _ in range(3):
            others = sum(e[2] * e[3] for e in echoes)
            ta_before = ta
            ta, eps = path.fit(x - others, ta, eps, 0.0, grid=False)
            q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
            gain = np.vdot(q, x - others) / float(np.real(np.vdot(q, q)))
            for k, e in enumerate(echoes):
                rest = x - gain * q - sum(o[2] * o[3] for m, o in enumerate(echoes) if m != k)
                te, ee = path.fit(rest, e[0], e[1], 0.0, grid=False)
                qe = replica.scaled(t, t_arrival_s=te, eps=ee, carrier_hz=carrier_hz)
                echoes[k] = [te, ee, np.vdot(qe, rest) / float(np.real(np.vdot(qe, qe))), qe]
            if abs(ta - ta_before) * fs < 0.01:  # the direct path no longer moves: the paths are separated
                break
        x = x - sum(e[2] * e[3] for e in echoes)
    q = replica.scaled(t, t_arrival_s=ta, eps=eps, carrier_hz=carrier_hz)
    eq = float(np.real(np.vdot(q, q)))
    gain = np.vdot(q, x) / eq
    noise = _noise_level(r, fs, t0_s, ta, dur / (1 + eps))
    inside = np.abs(q) > 0.1 * np.max(np.abs(q))
    resid = x - gain * q
    if noise is None:
        noise = float(np.mean(np.abs(resid[inside]) ** 2))
    # a noiseless recording: keep the figures finite (E/N0 then about 120 dB)
    noise = max(noise, 1e-12 * abs(gain) ** 2 * float(np.mean(np.abs(q[inside]) ** 2)))
    misfit = float(np.mean(np.abs(resid[inside]) ** 2) / max(noise, np.finfo(float).tiny))
    # E/N0: E = ½|A|² Σ|q|²/fs (passband energy), N0 = σ²_bb / (2 ENBW)
    e_n0 = abs(gain) ** 2 * eq / fs * noise_bandwidth_hz / max(noise, np.finfo(float).tiny)
    band = replica.reference.bandwidth_hz
    snr_db = 10 * math.log10(max(e_n0 / (band * dur / (1 + eps)), 1e-30))
    _, s_e, s_ridge = bound.at(e_n0)
    inflate = math.sqrt(max(1.0, misfit))
    k_e, k_ridge = path.echo_inflation(ta, eps, gain, [(e[0], e[1], e[2]) for e in echoes]) if echoes else (1.0, 1.0)
    s_e, s_ridge = s_e * inflate * k_e, s_ridge * inflate * k_ridge
    if s_e > DOPPLER_THRESHOLD * eps_max or misfit > MISFIT_LIMIT:
        # below the Doppler threshold (an HFM at moderate SNR), the likelihood hardly varies along the ridge
        # within ±v_max: the ML lands anywhere in the search range and the CRLB no longer describes its error;
        # likewise when the fitted paths leave much more than noise (unresolved echoes), the ping's place on its
        # ridge is not to be trusted
        s_e = max(s_e, eps_max)
    return ReferenceFit(
        t_arrival_s=float(ta),
        eps=float(eps),
        gain=complex(gain),
        e_n0=float(e_n0),
        snr_db=snr_db,
        sigma_t_s=math.hypot(s_ridge, g * s_e),
        sigma_eps=s_e,
        ridge_t_s=float(ta + g * eps),
        sigma_ridge_s=s_ridge,
        misfit=misfit,
        ridge_slope_s=g,
        n_paths=1 + len(echoes),
    )


def _noise_level(r, fs, t0_s, ta, duration_s) -> float | None:
    """Median-based baseband noise variance just before the arrival, else just after the reference."""
    for a, b in (
        (ta - NOISE_GAP_S - NOISE_WINDOW_S, ta - NOISE_GAP_S),
        (ta + duration_s + 0.03, ta + duration_s + 0.03 + NOISE_WINDOW_S),
    ):
        lo, hi = int(math.ceil((a - t0_s) * fs)), int(math.floor((b - t0_s) * fs))
        if lo >= 0 and hi <= len(r) and hi - lo >= 0.8 * NOISE_WINDOW_S * fs:
            return float(np.median(np.abs(r[lo:hi]) ** 2) / math.log(2))
    return None
