"""Ground truth per frame, exactly as SPEC §1 defines it, and the in-band power of a frame.

For frame k emitted at t_e (its first sample, leading guard included) and
lasting T_F, on path p:

- true arrival t_a: the reception time of the frame start, the root of
  t − τ_p(t) = t_e (a contraction, |dτ/dt| = |v_r|/c < 1, solved by fixed-point
  iteration to 1e-13 s); the end of its reception t_b solves t − τ_p(t) = t_e + T_F;
- closing speed averaged over the reception [t_a, t_b]:
  v̄_r = −c (τ(t_b) − τ(t_a)) / (t_b − t_a) = c (T_F − D) / D, D = t_b − t_a.

Two clocks (see :class:`seamodem.channel.scenario.Clock`). The SPEC columns
are what an ideal receiver measures in the output recording, on its own clock:
``t_arrival_s`` = receiver time of the arrival, ``tof_s`` = t_arrival_s −
t_emit_s, ``range_m`` = c · tof_s, ``v_r_mps`` = c (T_F − D_rx)/D_rx with the
reception lasting D_rx = (1 + ppm·1e-6) D on the receiver clock. The ``*_true``
columns are the physical values: ``tof_true_s`` = t_a − t_e,
``range_true_m`` = c · tof_true_s (the slant range at reception),
``v_r_true_mps`` = v̄_r. With no clock error both sets are equal.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .model import ChannelModel

__all__ = ["arrival_times", "frame_truth", "in_band_power"]


def arrival_times(delay: Callable[[np.ndarray], np.ndarray], t_emit_s) -> np.ndarray:
    """Reception times t solving t − τ(t) = t_emit, for a delay function τ with |τ'| < 1.

    Parameters
    ----------
    delay : callable
        τ(t) [s] for an array of true times.
    t_emit_s : array_like
        Emission times [s].
    """
    te = np.asarray(t_emit_s, dtype=float)
    t = te + delay(te)
    for _ in range(200):
        t_next = te + delay(t)
        done = np.all(np.abs(t_next - t) <= 1e-13 * np.maximum(1.0, np.abs(t)))
        t = t_next
        if done:
            break
    return t


def frame_truth(model: ChannelModel, t_emit_s, frame_duration_s: float) -> list[dict]:
    """Truth of every frame: SPEC columns, their ``_true`` twins, and per-path details.

    Parameters
    ----------
    model : ChannelModel
    t_emit_s : array_like, shape (n_frames,)
        Emission time of each frame's first sample [s].
    frame_duration_s : float
        T_F [s].

    Returns
    -------
    list of dict
        One per frame (see the module docstring for the meaning of each key).
    """
    te = np.asarray(t_emit_s, dtype=float).reshape(-1)
    if te.size == 0:
        return []
    c = model.c
    rate = model.clock.rate
    per_path = []
    for p in range(model.n_paths):
        def tau(t, p=p):
            return model.delays(t)[p]

        ta = arrival_times(tau, te)
        tb = arrival_times(tau, te + frame_duration_s)
        d = tb - ta
        amp = model.amplitudes(ta, model.delays(ta))[p]
        per_path.append((ta, d, amp))
    rows = []
    for k in range(te.size):
        ta, d, _ = (v[k] for v in per_path[0])
        t_arr = float(model.clock.to_receiver(ta))
        d_rx = d * rate
        row = {
            "frame_index": k,
            "t_emit_s": float(te[k]),
            "t_arrival_s": t_arr,
            "tof_s": t_arr - float(te[k]),
            "range_m": c * (t_arr - float(te[k])),
            "v_r_mps": float(c * (frame_duration_s - d_rx) / d_rx),
            "t_arrival_true_s": float(ta),
            "tof_true_s": float(ta - te[k]),
            "range_true_m": float(c * (ta - te[k])),
            "v_r_true_mps": float(c * (frame_duration_s - d) / d),
            "reception_duration_s": float(d_rx),
            "paths": [
                {
                    "path": p,
                    "name": model.paths[p].name,
                    "t_arrival_s": float(model.clock.to_receiver(per_path[p][0][k])),
                    "tof_true_s": float(per_path[p][0][k] - te[k]),
                    "v_r_true_mps": float(c * (frame_duration_s - per_path[p][1][k]) / per_path[p][1][k]),
                    "amplitude": float(per_path[p][2][k]),
                }
                for p in range(model.n_paths)
            ],
        }
        rows.append(row)
    return rows


def in_band_power(x: np.ndarray, fs: float, band_hz: tuple[float, float]) -> float:
    """Power of ``x`` inside ``band_hz`` (SPEC §1 in-band power), Hann-windowed periodogram.

    P = 2 Σ_{f_k ∈ band} |X_k|² / (N Σ w²), X = rfft(w·x), w a Hann window of
    N = len(x) samples. A white noise of variance σ² gives 2σ²B/fs; a tone of
    amplitude A inside the band gives A²/2 (the window's sidelobes keep the
    out-of-band tone's leakage below −80 dB).

    Parameters
    ----------
    x : numpy.ndarray
        Real signal, shape ``(n_samples,)``.
    fs : float
        Sample rate [Hz].
    band_hz : tuple of float
        Band edges ``(low, high)`` [Hz], both included.

    Returns
    -------
    float
        In-band power [signal units²]; 0 for fewer than 2 samples.
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 2:
        return 0.0
    w = np.hanning(n)
    spectrum = np.abs(np.fft.rfft(w * x)) ** 2
    f = np.fft.rfftfreq(n, 1.0 / fs)
    inside = (f >= band_hz[0]) & (f <= band_hz[1])
    return float(2.0 * np.sum(spectrum[inside]) / (n * np.sum(w**2)))
