"""Pre/postamble pairs: the Doppler from two pings' measured spacing (:func:`pair_up`, :func:`pair_doppler`)."""

from __future__ import annotations

import math

from ..settings import MAX_ACCEL_MPS2
from .records import FittedPing

__all__ = ["pair_doppler", "pair_up", "MAX_ACCEL_MPS2"]


def pair_doppler(
    t1_s: float, t2_s: float, sigma1_s: float, sigma2_s: float, *, spacing_s: float
) -> tuple[float, float]:
    """Doppler scale from the measured spacing of two pings emitted ``spacing_s`` apart.

    The received pair is compressed by 1 + ε (SPEC §1): Δ = T_sp/(1 + ε), so
    ε = T_sp/Δ − 1, σ_ε = (T_sp/Δ²)·√(σ1² + σ2²) (mean closing speed over the
    packet).

    Parameters
    ----------
    t1_s, t2_s : float
        The two pings' measured times (arrivals or ridge coordinates) [s].
    sigma1_s, sigma2_s : float
        Their σ's [s].
    spacing_s : float
        T_sp, their spacing at emission [s].

    Returns
    -------
    eps : float
        Doppler scale ε (mean over the packet).
    sigma_eps : float
        Its σ.

    Examples
    --------
    >>> eps, s = pair_doppler(1.0, 9.0 / (1 + 1e-3) + 1.0, 1e-6, 1e-6, spacing_s=9.0)
    >>> round(eps * 1e3, 9)
    1.0
    """
    delta = t2_s - t1_s
    eps = spacing_s / delta - 1
    return float(eps), float(spacing_s / delta**2 * math.hypot(sigma1_s, sigma2_s))


def pair_up(found: list[FittedPing], *, eps_max: float, max_accel_mps2: float = MAX_ACCEL_MPS2,
            sound_speed_mps: float = 1500.0) -> None:
    """Mark pre/postamble pairs of references with ``postamble_s`` and set their pair Doppler (in place).

    Each ping's ridge coordinate r = t_a + g·ε is measured to its known-ε bound (≈ 1 µs), far better than
    t_a (its Doppler error slides it along the ridge). With the Doppler changing over the packet,
    ε_pre = ε̄ − δ, ε_post = ε̄ + δ (δ = a·T_sp/(2c)), the ridge spacing is Δ + 2gδ, Δ = T_sp/(1 + ε̄) the
    arrivals' spacing. δ is estimated from the pings' own ε's, (ε̂_post − ε̂_pre)/2, shrunk towards 0 by a
    uniform prior |a| ≤ ``max_accel_mps2`` (best linear estimate; the pings' own ε's dominate when they
    are precise, the prior when they are not, as an HFM's). Then ε̄ = T_sp/(r_post − r_pre − 2gδ̃) − 1 with
    σ_ε̄ = (T_sp/Δ²)·√(σ_r,pre² + σ_r,post² + 4g²·var δ̃) (:func:`pair_doppler` for the spacing alone).
    Each ping's arrival on its ridge at its own ε̄ ∓ δ̃: t = r − g·(ε̄ ∓ δ̃).

    Parameters
    ----------
    found : list of FittedPing
        Fitted detections (any references; those without a postamble are left alone). Pairs get
        ``role``, ``eps_pair``, ``sigma_eps_pair``, ``t_pair_s`` and ``sigma_t_pair_s``.
    eps_max : float
        Largest |ε| searched (v_max/c): how far a pair's spacing may be from T_sp.
    max_accel_mps2 : float
        Largest radial acceleration over a packet [m/s²]; 0 states a constant speed.
    sound_speed_mps : float
        c [m/s].

    Returns
    -------
    None
        ``found``'s items are updated in place.
    """
    by_ref: dict[str, list[FittedPing]] = {}
    for f in found:
        if f.reference.postamble_s:
            by_ref.setdefault(f.reference.name, []).append(f)
    for items in by_ref.values():
        items.sort(key=lambda f: f.fit.t_arrival_s)
        i = 0
        while i < len(items) - 1:
            a, b = items[i], items[i + 1]
            sp = a.reference.postamble_s
            delta = b.fit.ridge_t_s - a.fit.ridge_t_s
            if abs(delta - sp) <= 2 * eps_max * sp + 0.01 * a.reference.duration_s:
                g = a.fit.ridge_slope_s
                var_prior = (max_accel_mps2 * sp / (2 * sound_speed_mps)) ** 2 / 3
                var_own = (a.fit.sigma_eps**2 + b.fit.sigma_eps**2) / 4
                gain = var_prior / (var_prior + var_own) if var_prior + var_own > 0 else 0.0
                half_change = gain * (b.fit.eps - a.fit.eps) / 2
                var_half = var_prior * var_own / (var_prior + var_own) if var_prior + var_own > 0 else 0.0
                spacing = delta - 2 * g * half_change
                eps, sigma = pair_doppler(
                    a.fit.ridge_t_s, a.fit.ridge_t_s + spacing,
                    a.fit.sigma_ridge_s, math.hypot(b.fit.sigma_ridge_s, 2 * g * math.sqrt(var_half)), spacing_s=sp,
                )
                a.role, b.role = "preamble", "postamble"
                for f, sign in ((a, -1.0), (b, 1.0)):
                    f.eps_pair, f.sigma_eps_pair = eps, sigma
                    # the ping's own ε moves its arrival along the ridge; the pair's ε puts it back (HFM coupling)
                    f.t_pair_s = f.fit.ridge_t_s - g * (eps + sign * half_change)
                    f.sigma_t_pair_s = math.hypot(f.fit.sigma_ridge_s, g * math.hypot(sigma, math.sqrt(var_half)))
                i += 2
            else:
                i += 1
