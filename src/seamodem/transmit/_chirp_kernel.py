"""Compiled received chirp replicas: q(t) = w(u) e^{j(φ(u) − 2π f_rx t)}, u = (1 + ε)(t − t_a), and ∂q/∂u.

One pass per sample instead of a dozen numpy passes (window, phase, exponential, derivative): the fine fit of
:mod:`seamodem.receive.reference` evaluates 30–40 replicas of ~1000 samples per ping, where numpy's per-call
overhead dominated (130–160 µs each). The formulas are those of
:func:`seamodem.transmit.replica._window`, ``_window_derivative`` and ``_chirp_phase`` (tested against them).
Imported lazily (numba stays out of the command line's import).
"""

from __future__ import annotations

import math

import numba

#: window codes of :func:`fill_chirp`
HANN, RECT, TUKEY = 0, 1, 2


@numba.njit(cache=True, nogil=True)
def fill_chirp(t, t_arrival, eps, carrier_hz, hfm, f0, rate_or_k, duration, window, taper, q, dq, with_derivative):
    """q[i] (and dq[i] = ∂q/∂u when ``with_derivative``) at times t[i]; ``rate_or_k``: the LFM's sweep rate
    [Hz/s] or the HFM's k [1/s] (f(u) = f0 + rate·u, or f0/(1 − k u))."""
    two_pi = 2.0 * math.pi
    for i in range(t.shape[0]):
        u = (1.0 + eps) * (t[i] - t_arrival)
        uc = min(max(u, 0.0), duration)
        if hfm:
            arg = max(1.0 - rate_or_k * uc, 1e-12)
            phase = -two_pi * f0 / rate_or_k * math.log(arg)
            f = f0 / arg
        else:
            phase = two_pi * (f0 * uc + 0.5 * rate_or_k * uc * uc)
            f = f0 + rate_or_k * uc
        x = u / duration
        w = 0.0
        dw = 0.0
        if 0.0 <= x <= 1.0:
            if window == HANN:
                s = math.sin(math.pi * x)
                w = s * s
                dw = math.pi * math.sin(two_pi * x)
            elif window == RECT:
                w = 1.0
            else:
                edge = min(x, 1.0 - x)
                w = 0.5 * (1.0 - math.cos(two_pi * min(edge, taper / 2) / taper))
                if edge < taper / 2:
                    dw = math.pi / taper * math.sin(two_pi * edge / taper) * (1.0 if x < 0.5 else -1.0)
        ang = phase - two_pi * carrier_hz * t[i]
        c, s = math.cos(ang), math.sin(ang)
        q[i] = complex(w * c, w * s)
        if with_derivative:
            # (w'/T + j2π f w) e^{jang}
            a, b = dw / duration, two_pi * f * w
            dq[i] = complex(a * c - b * s, a * s + b * c)
