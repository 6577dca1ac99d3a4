"""Independent received frames: the analytic frame evaluated at warped times.

Nothing here goes through the project's channel code or ``srrc_matrix``: the
SRRC pulse is summed symbol by symbol at the warped local time

    α(t) = (t − t_a) + ∫_{t_a}^{t} v(u)/c du,   v(u) = v_a + a·(u − t_a),

(SPEC §1: s̃(t) = s(t + ∫ v_r/c)), so the frame start arrives at t_a and a
closing receiver (v > 0) hears the tone at f_pt(1 + v/c).
"""

from __future__ import annotations

import numpy as np

from seamodem.transmit.frame import Frame, build_frame, frame_symbol_times, tone_envelope
from seamodem.transmit.pulse import srrc_pulse, srrc_truncation_energy


def warped_time(t, t_arrival_s, v_mps, accel_mps2, sound_speed_mps):
    d = t - t_arrival_s
    return d + (v_mps * d + 0.5 * accel_mps2 * d**2) / sound_speed_mps


def baseband_at(frame: Frame, alpha: np.ndarray) -> np.ndarray:
    """Σ_k x_k √T g(α − t_k) with the truncated, unit-energy SRRC, by direct summation."""
    cfg = frame.config
    T = cfg.symbol_period_s
    half = cfg.srrc_span_symbols // 2
    norm = np.sqrt(srrc_truncation_energy(float(cfg.rolloff), half))
    tk = frame_symbol_times(cfg)
    x = frame.symbols
    nearest = np.floor(alpha / T).astype(np.int64) - cfg.n_guard
    out = np.zeros(alpha.shape, complex)
    for off in range(-half - 1, half + 2):
        k = nearest + off
        ok = (k >= 0) & (k < len(x))
        u = alpha[ok] - tk[k[ok]]
        g = srrc_pulse(u, T, cfg.rolloff) / norm
        g[np.abs(u) > half * T] = 0.0
        out[ok] += x[k[ok]] * np.sqrt(T) * g
    return out


def received_frame(
    frame: Frame,
    t_s: np.ndarray,
    *,
    t_arrival_s: float,
    v_mps: float = 0.0,
    accel_mps2: float = 0.0,
    sound_speed_mps: float = 1500.0,
    gain: float = 1.0,
) -> np.ndarray:
    """Real passband of one frame received at times ``t_s`` (model units × gain)."""
    cfg = frame.config
    alpha = warped_time(np.asarray(t_s, float), t_arrival_s, v_mps, accel_mps2, sound_speed_mps)
    inside = (alpha > -cfg.symbol_period_s * cfg.srrc_span_symbols) & (alpha < cfg.frame_duration_s + 1e-3)
    out = np.zeros(alpha.shape)
    a = alpha[inside]
    a_data = np.sqrt(2 * (1 - cfg.tone_power_share))
    a_tone = np.sqrt(2 * cfg.tone_power_share)
    data = a_data * np.real(baseband_at(frame, a) * np.exp(2j * np.pi * cfg.carrier_hz * a))
    tone = a_tone * tone_envelope(cfg, a) * np.cos(2 * np.pi * cfg.tone_hz * a)
    out[inside] = gain * (data + tone)
    return out


def awgn_sigma(config, snr_db: float, gain: float = 1.0) -> float:
    """Std of white noise per sample giving in-band SNR ``snr_db`` (SPEC §1).

    Data power P = gain²(1 − share); one-sided noise PSD N0 = 2σ²/fs; SNR = P/(N0·B).
    """
    p = gain**2 * (1 - config.tone_power_share)
    return float(np.sqrt(p * config.sample_rate_hz / (2 * config.bandwidth_hz * 10 ** (snr_db / 10))))


def multipath_recording(config, payloads, t_emit_s, tof_s, paths, *, v_mps: float, snr_db: float, rng,
                        tail_s: float = 0.6) -> np.ndarray:
    """One frame per payload emitted at ``t_emit_s`` and heard ``tof_s`` later along each of ``paths``
    ((extra delay [s], gain) pairs), at speed ``v_mps``, in white noise of in-band SNR ``snr_db`` (drawn
    from ``rng``); the recording runs ``tail_s`` past the last emission's period of 1 s."""
    t = np.arange(int((len(payloads) + tail_s) * config.sample_rate_hz)) / config.sample_rate_hz
    x = np.zeros(t.size)
    for k, payload in enumerate(payloads):
        frame = build_frame(config, payload)
        for delay, gain in paths:
            x += received_frame(frame, t, t_arrival_s=t_emit_s[k] + tof_s[k] + delay, v_mps=v_mps, gain=gain)
    return x + awgn_sigma(config, snr_db) * rng.standard_normal(t.size)
