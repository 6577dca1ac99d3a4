"""Doppler compensation of a frame's symbols (paper 000 eq 10–11, SPEC §4.4).

The matched filter is sampled at the Doppler-warped symbol instants and the
carrier phase that the Doppler adds is removed:

    t̂_k = t̂_{k−1} + T (1 − v̂_r(kT)/c),    φ̂_k = φ̂_{k−1} + 2π f0 T v̂_r(kT)/c,
    ŷ[k] = r̃(t̂_k) e^{−jφ̂_k},

with v̂_r the tone's speed track (or a constant). The code uses the exact steps
T/(1 + v/c) and 2π f0 (t̂_k − t̂_{k−1}) v/c, equal to eq 10–11 to first order
in v/c; the first-order phase is 2π f0 T_F (v/c)² = 0.2 rad short at the end of a
300 ms frame at 3 m/s, enough to tilt an 8PSK constellation. The symbols are then divided
by the complex gain fitted on the pilots, so that they come out on the unit
constellation, ready for the equaliser (issue 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from .doppler import matched_filter

__all__ = ["CompensatedFrame", "compensate_frame", "echo_contributions"]


@dataclass(frozen=True)
class CompensatedFrame:
    """A frame's matched-filter outputs after Doppler compensation.

    Attributes
    ----------
    symbols : numpy.ndarray, shape (n_pilot + n_data,), complex
        ŷ[k] / Â: pilots then data, on the unit constellation.
    times_s : numpy.ndarray, shape (n_pilot + n_data,)
        t̂_k, the instants where the matched filter was sampled [s].
    phases_rad : numpy.ndarray, shape (n_pilot + n_data,)
        φ̂_k removed from each symbol [rad].
    gain : complex
        Â, the pilots' least-squares complex gain.
    raw : numpy.ndarray, complex
        Matched filter at the nominal instants t_a + (Ng + k)T, no compensation,
        divided by its own pilot gain (for comparison plots).
    """

    symbols: np.ndarray
    times_s: np.ndarray
    phases_rad: np.ndarray
    gain: complex
    raw: np.ndarray


def compensate_frame(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_start_s: float,
    sound_speed_mps: float,
    v_mps: float | None = None,
    track_t_s: np.ndarray | None = None,
    track_v_mps: np.ndarray | None = None,
) -> CompensatedFrame:
    """Doppler-compensated symbols of one frame (eq 10–11).

    Parameters
    ----------
    bb : numpy.ndarray, complex
        Data-band baseband, bb[n] at t0 + n/fs [s].
    pilot : numpy.ndarray
        Pilot symbols (for the common gain and phase).
    t_start_s : float
        Reception time of the frame start [s].
    v_mps : float, optional
        Constant closing speed over the frame [m/s] ...
    track_t_s, track_v_mps : numpy.ndarray, optional
        ... or a speed track (e.g. the eq 9 track), held at its ends.

    Returns
    -------
    CompensatedFrame
    """
    if v_mps is None and track_v_mps is None:
        raise ValueError("give v_mps or a speed track (track_t_s, track_v_mps)")
    T = config.symbol_period_s
    n = config.n_pilot + config.n_data
    c = sound_speed_mps
    if track_v_mps is None:
        v_of = lambda t: np.full(np.shape(t), float(v_mps))  # noqa: E731
    else:
        v_of = lambda t: np.interp(t, track_t_s, track_v_mps)  # noqa: E731
    # eq 10–11 to second order in v/c: each step lasts T/(1 + v/c) of receiver time and
    # turns the carrier by 2π f0 (that duration)·v/c; eq 11's T·v/c is 0.2 rad short over
    # a 300 ms frame at 3 m/s. v is read at the previous instant: one pass on the nominal
    # grid, then one on the warped grid.
    t_hat = t_start_s + (config.n_guard + np.arange(n)) * T
    for _ in range(2):
        v = v_of(np.concatenate([[t_start_s], t_hat[:-1]]))
        steps = np.concatenate([[config.n_guard * T], np.full(n - 1, T)]) / (1 + v / c)
        t_hat = t_start_s + np.cumsum(steps)
    phases = 2 * np.pi * config.carrier_hz * np.cumsum(steps * v / c)
    y = matched_filter(bb, fs, t0_s, t_hat, config=config) * np.exp(-1j * phases)
    pilots = np.asarray(pilot, dtype=complex)
    gain = complex(np.conj(pilots) @ y[: config.n_pilot] / config.n_pilot)
    raw = matched_filter(bb, fs, t0_s, t_start_s + (config.n_guard + np.arange(n)) * T, config=config)
    raw_gain = np.conj(pilots) @ raw[: config.n_pilot] / config.n_pilot
    return CompensatedFrame(symbols=y / gain, times_s=t_hat, phases_rad=phases, gain=gain, raw=raw / raw_gain)


def echo_contributions(
    n_samples: int,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    symbols: np.ndarray,
    fit,
    paths,
    sound_speed_mps: float,
) -> tuple[int, np.ndarray]:
    """Sum of the chosen paths' synthesized contributions to the data baseband, from a whole-frame fit.

    Each path p of ``fit`` (:class:`~seamodem.receive.wholeframe.WholeFrameFit`) is
    rebuilt as in the fit's own model (module :mod:`~seamodem.receive.wholeframe`):
    the frame's ``symbols`` as SRRC pulses at the instants its delay, Doppler and
    drift give, its time scale exact, times its complex gain and carrier phase.

    Parameters
    ----------
    n_samples : int
        Length of the baseband bb[n] at t0 + n/fs [s] the contributions are for.
    symbols : numpy.ndarray, complex, shape (n_pilot + n_data,)
        Pilots then the data symbols (decided or known).
    fit : WholeFrameFit
    paths : sequence of int
        Indices of the paths (in ``fit``) to synthesize.

    Returns
    -------
    lo : int
        First baseband index the contributions cover.
    contribution : numpy.ndarray, complex
        Σ_p s_p[n] for n in [lo, lo + len).
    """
    from .wholeframe import FrameSegment, path_phase, symbol_instants

    c = sound_speed_mps
    span = config.srrc_span_symbols * int(fs * config.symbol_period_s + 1)
    delays = np.asarray(fit.delays_s, dtype=float)
    lo = max(0, int((float(delays.min()) - t0_s) * fs) - span)
    hi = min(n_samples, int((float(delays.max()) + config.frame_duration_s - t0_s) * fs) + span)
    if hi <= lo:
        return lo, np.zeros(0, complex)
    seg = FrameSegment(hi - lo, fs, t0_s + lo / fs, config=config)
    x = np.asarray(symbols, dtype=complex)
    total = np.zeros(hi - lo, complex)
    for p in paths:
        eps, beta, tau = fit.v_mps[p] / c, fit.accel_mps2[p] / c, delays[p]
        shape = seg.synthesize(x, symbol_instants(config, tau, eps, beta), scale=1 + eps)
        total += fit.amplitudes[p] * shape * np.exp(1j * path_phase(config, seg.t_s - tau, eps, beta))
    return lo, total
