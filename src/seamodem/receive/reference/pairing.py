"""Pre/postamble pairs: the Doppler from two pings' measured spacing (:func:`pair_up`, :func:`pair_doppler`)."""

from __future__ import annotations

import math

from ..settings import MAX_ACCEL_MPS2
from .packets import assemble_packets
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
    """Group the chirps of every packet (pre/postamble pairs, trains) and set their packet Doppler (in place).

    Each ping's ridge coordinate r = t_a + g·ε is measured to its known-ε bound (≈ 1 µs), far better than
    t_a (its Doppler error slides it along the ridge). The chirps of a packet are grouped by their expected
    spacings over all detections (a global assignment: other pings between them and a missing chirp do not
    break a packet), and the packet's scale ε(T) = ε0 + ε1·T is fitted to all their ridge coordinates and
    their own ε's, with a uniform prior |a| ≤ ``max_accel_mps2`` on the acceleration
    (:mod:`~seamodem.receive.reference.packets`). Each chirp's arrival is its ridge coordinate at the
    packet's ε at its emission. A packet found incomplete warns naming the reference
    (:class:`~seamodem.receive.reference.packets.PacketWarning`).

    Parameters
    ----------
    found : list of FittedPing
        Fitted detections (any references; lone pings are left alone). A packet's chirps get
        ``role``, ``train_position``, ``offset_s``, ``eps_pair``, ``sigma_eps_pair``, ``t_pair_s`` and ``sigma_t_pair_s``.
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
    assemble_packets(found, eps_max=eps_max, max_accel_mps2=max_accel_mps2, sound_speed_mps=sound_speed_mps)
