"""Paper 000's published filter tuning (eq 25), in one place.

The 6-state EKF of paper 000 (the Monte Carlo kernel, its pure-Python
reference, ``nav track --filter proposed|rosb`` and the demo's "paper 000 EKF")
is run with exactly these numbers, and every text that states them is made
from them (:func:`eq25_text`).

Notes
-----
Paper 000 eq 25 prints R = diag(1, 0.005, 0.005, 12, 0.2) for the rows ψ, Ω, a,
d, v_r of its eq 22; in eq 18's order (d, v_r, ψ, Ω, a) that is
:data:`EQ25_R_DIAG`. Q = Δt⁸ I₆ (eq 25), Δt the filter step [s].

Examples
--------
>>> EQ25_R_DIAG
(12.0, 0.2, 1.0, 0.005, 0.005)
>>> eq25_q(0.25)
1.52587890625e-05
>>> eq25_text()
'R = eq 25 (12 m², 0.2 m²/s², 1, 0.005, 0.005), Q = Δt⁸ I6'
"""

from __future__ import annotations

__all__ = ["EQ25_R", "EQ25_R_DIAG", "EQ25_ORDER", "eq25_q", "eq25_r_text", "eq25_text"]

#: R of paper 000 eq 25 by measurement kind (the kinds of :class:`~seamodem.navigation.models.Auv6Model`):
#: range [m²], v_r [m²/s²], heading ψ [rad²], turn rate Ω [rad²/s²], acceleration a [m²/s⁴].
EQ25_R = {"range": 12.0, "v_r": 0.2, "psi": 1.0, "omega": 0.005, "a": 0.005}

#: Eq 18's order of the measurements (d, v_r, ψ, Ω, a).
EQ25_ORDER = ("range", "v_r", "psi", "omega", "a")

#: R's diagonal in eq 18's order: ``MissionConfig.r_diag``'s default, the compiled kernel's ``r_diag``.
EQ25_R_DIAG = tuple(EQ25_R[k] for k in EQ25_ORDER)


def eq25_q(dt_s: float) -> float:
    """Process noise variance of every state per step of ``dt_s`` [s]: Δt⁸ (paper 000 eq 25, Q = Δt⁸ I₆)."""
    return dt_s**8


def eq25_r_text() -> str:
    """R's diagonal with units, as the summaries print it: ``(12 m², 0.2 m²/s², 1, 0.005, 0.005)``.

    ψ, Ω and a print without units, as the paper gives them (rad², rad²/s², m²/s⁴).
    """
    r = EQ25_R
    return f"({r['range']:g} m², {r['v_r']:g} m²/s², {r['psi']:g}, {r['omega']:g}, {r['a']:g})"


def eq25_text() -> str:
    """The filter's tuning in one phrase: ``R = eq 25 (...), Q = Δt⁸ I6``."""
    return f"R = eq 25 {eq25_r_text()}, Q = Δt⁸ I6"
