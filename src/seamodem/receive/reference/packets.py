"""Reference packets as they are sent at sea: chirp trains before and after the data, grouped and fitted together.

A packet (:meth:`~seamodem.transmit.reference.ReferenceWaveform.packet`) is a preamble train of N chirps
``train_spacing_s`` apart and an optional postamble train ``postamble_s`` after it. Every chirp measures its
delay–Doppler *ridge coordinate* r = t_a + g·ε to its known-ε bound (≈ 1 µs), while its own ε is coarse (an LFM's
Doppler slides its arrival along the ridge). The chirps of one packet, emitted at known offsets T_j, pin down the
packet's time scale from their spacings.

Grouping (:func:`group_packets`) is a global assignment, not a walk over neighbours: every detection is tried as
every chirp of a packet; the other chirps are looked for where that hypothesis puts them (a window of
±ε_max·ΔT around each predicted time); the hypothesis explaining the most chirps (then the smallest misfit) is
kept, its detections are taken out, and so on. Other pings between the chirps of a packet and a missing chirp do
not break it.

Fit (:func:`fit_packet`): with ε(T) = ε0 + ε1·T over the packet (constant radial acceleration), the arrival of
the chirp emitted at T is t(T) = t0 + T/(1+ε0) − ε1·T²/(2(1+ε0)²) and its ridge coordinate r(T) = t(T) + g·ε(T).
The ridge coordinates r_j (σ_ridge) and the chirps' own ε̂_j (σ_ε) are the observations; a uniform prior
|a| ≤ ``max_accel_mps2`` on the acceleration (ε1 = a/c) keeps ε1 finite when the packet cannot measure it.
Weighted Gauss–Newton on (t0, ε0, ε1). Each chirp's arrival is then its own ridge coordinate moved to the
packet's ε at its emission: t_j = r_j − g·ε(T_j), σ² = σ_ridge,j² + g²·var ε(T_j); its Doppler c·ε(T_j).
"""

from __future__ import annotations

import heapq
import math
import warnings
from collections.abc import Sequence

import numpy as np

__all__ = ["PacketWarning", "group_packets", "fit_packet", "assemble_packets"]


class PacketWarning(UserWarning):
    """A declared packet part (postamble, a train's chirps) was not found."""


def _layout(ref):
    packet = ref.packet()
    offsets = np.array([p[0] for p in packet])
    return packet, offsets


def group_packets(found: Sequence, *, eps_max: float) -> list[list[tuple[int, object]]]:
    """The packets among one reference's fitted detections: lists of (chirp slot, detection).

    Parameters
    ----------
    found : sequence of FittedPing
        Detections of one reference (any order).
    eps_max : float
        Largest |ε| = v_max/c searched.

    Returns
    -------
    list of list of (int, FittedPing)
        Each packet's detections with their slot in :meth:`ReferenceWaveform.packet`, in slot order; a
        detection that fits no packet with another comes alone in slot 0 (or, when it cannot be the first
        chirp, in the slot that its neighbours leave most plausible).
    """
    if not found:
        return []
    ref = found[0].reference
    packet, offsets = _layout(ref)
    n_slots = len(offsets)
    items = sorted(found, key=lambda f: f.fit.ridge_t_s)
    r = np.array([f.fit.ridge_t_s for f in items])
    tol0 = 0.01 * ref.duration_s + 20e-6
    free = np.ones(len(items), bool)
    packets: list[list[tuple[int, object]]] = []
    if n_slots == 1:
        return [[(0, f)] for f in items]
    def hypothesis(i: int, s: int):
        """Slot → detection index when detection i is chirp s, and the misfit of the others' times."""
        members = {s: i}
        cost = 0.0
        for j in range(n_slots):
            if j == s:
                continue
            dt = offsets[j] - offsets[s]
            centre = r[i] + dt
            half = eps_max * abs(dt) + tol0
            lo, hi = np.searchsorted(r, [centre - half, centre + half])
            cand = [k for k in range(lo, hi) if free[k]]
            if cand:
                k = min(cand, key=lambda k: abs(r[k] - centre))
                members[j] = k
                cost += abs(r[k] - centre) / half
        return members, cost

    # lazy greedy: the hypothesis explaining most chirps (then the smallest misfit) first; one whose
    # detections were taken meanwhile is re-evaluated with what is left and queued again
    heap = []
    for i in range(len(items)):
        for s in range(n_slots):
            members, cost = hypothesis(i, s)
            if len(members) >= 2:
                heapq.heappush(heap, (-len(members), cost, i, s, members))
    while heap:
        neg, cost, i, s, members = heapq.heappop(heap)
        if not free[i]:
            continue
        if not all(free[k] for k in members.values()):
            members, cost = hypothesis(i, s)
            if len(members) >= 2:
                heapq.heappush(heap, (-len(members), cost, i, s, members))
            continue
        for k in members.values():
            free[k] = False
        packets.append([(sl, items[k]) for sl, k in sorted(members.items())])
    for k in np.flatnonzero(free):
        packets.append([(0, items[k])])
    packets.sort(key=lambda p: p[0][1].fit.ridge_t_s)
    return packets


def fit_packet(chirps: list[tuple[int, object]], *, sound_speed_mps: float, max_accel_mps2: float) -> dict:
    """Fit one packet's time scale and its chirps' arrivals (see the module's docstring).

    Parameters
    ----------
    chirps : list of (int, FittedPing)
        The packet's detections with their slots (:func:`group_packets`), at least two.
    sound_speed_mps : float
        c [m/s], for the acceleration prior.
    max_accel_mps2 : float
        Largest radial acceleration over the packet [m/s²] (uniform prior).

    Returns
    -------
    dict
        ``eps0``, ``eps1`` (ε at the first chirp's emission and its rate [1/s]), ``cov`` (3 × 3 covariance of
        t0, ε0, ε1), ``eps_mean`` and ``sigma_eps_mean`` (the packet's mean compression over its span: what
        its spacings measure best), and per chirp ``eps``, ``sigma_eps`` (ε at the chirp's emission: the
        acceleration's uncertainty included), ``t``, ``sigma_t`` (arrays in the order given).
    """
    ref = chirps[0][1].reference
    _, offsets = _layout(ref)
    T = np.array([offsets[s] for s, _ in chirps])
    fits = [f.fit for _, f in chirps]
    r = np.array([f.ridge_t_s for f in fits])
    sr = np.array([max(f.sigma_ridge_s, 1e-9) for f in fits])
    e = np.array([f.eps for f in fits])
    se = np.array([max(f.sigma_eps, 1e-12) for f in fits])
    g = fits[0].ridge_slope_s
    var_e1 = (max_accel_mps2 / sound_speed_mps) ** 2 / 3
    free = [0, 1, 2] if var_e1 > 0 else [0, 1]  # max_accel 0 states a constant speed: ε1 = 0
    # start from the scale of the two chirps farthest apart (distinct slots: distinct emission offsets)
    a, b = int(np.argmin(T)), int(np.argmax(T))
    eps0 = float((T[b] - T[a]) / (r[b] - r[a]) - 1)
    basis = np.column_stack([np.zeros_like(T), np.ones_like(T), T])  # ε(T_j) = basis_j · (t0, ε0, ε1)
    p = np.array([float(np.mean(r - T / (1 + eps0) - g * eps0)), eps0, 0.0])
    for _ in range(8):
        t0, eps0, eps1 = p
        q = 1 + eps0
        model_r = t0 + T / q - eps1 * T**2 / (2 * q**2) + g * (eps0 + eps1 * T)
        jr = np.column_stack([np.ones_like(T), -T / q**2 + eps1 * T**2 / q**3 + g, -T**2 / (2 * q**2) + g * T])
        J = np.vstack([jr / sr[:, None], basis / se[:, None]])
        res = np.concatenate([(r - model_r) / sr, (e - (eps0 + eps1 * T)) / se])
        if var_e1 > 0:  # the acceleration prior as one more observation of ε1 (= 0)
            J = np.vstack([J, [0.0, 0.0, 1 / math.sqrt(var_e1)]])
            res = np.concatenate([res, [-eps1 / math.sqrt(var_e1)]])
        J = J[:, free]
        info = J.T @ J
        step = np.zeros(3)
        step[free] = np.linalg.solve(info, J.T @ res)
        p = p + step
        if abs(step[1]) < 1e-14 and abs(step[0]) < 1e-11:
            break
    cov = np.zeros((3, 3))
    cov[np.ix_(free, free)] = np.linalg.inv(info)
    t0, eps0, eps1 = p
    eps_j = eps0 + eps1 * T
    var_eps_j = np.einsum("ij,jk,ik->i", basis, cov, basis)
    t_j = r - g * eps_j
    sigma_t = np.sqrt(sr**2 + g**2 * var_eps_j)
    mid = np.array([0.0, 1.0, 0.5 * (T.min() + T.max())])  # the mean of ε(T) over the packet's span
    return dict(eps0=float(eps0), eps1=float(eps1), cov=cov, eps=eps_j, sigma_eps=np.sqrt(var_eps_j), t=t_j,
                sigma_t=sigma_t, eps_mean=float(mid @ p), sigma_eps_mean=float(math.sqrt(mid @ cov @ mid)))


def assemble_packets(found: list, *, eps_max: float, max_accel_mps2: float, sound_speed_mps: float) -> None:
    """Group every reference's detections into packets and fit them; fill each detection's packet fields in place.

    Detections of references with a single ping are left as they are. For the others: ``role`` and
    ``train_position`` from the slot, ``offset_s`` (emission offset from the packet's first chirp), the
    packet's mean ε and its σ (``eps_pair``, ``sigma_eps_pair``), its ε at the chirp (``eps_chirp``,
    ``sigma_eps_chirp``), and the arrival at that ε (``t_pair_s``, ``sigma_t_pair_s``). Packets whose
    declared postamble (or, with no postamble, whose train) is not complete are reported once per
    reference by a :class:`PacketWarning` naming it.
    """
    by_ref: dict[str, list] = {}
    for f in found:
        if len(f.reference.packet()) > 1:
            by_ref.setdefault(f.reference.name, []).append(f)
    for name, items in by_ref.items():
        ref = items[0].reference
        packet, offsets = _layout(ref)
        incomplete = 0
        groups = group_packets(items, eps_max=eps_max)
        for group in groups:
            for slot, f in group:
                _, role, position = packet[slot]
                f.role, f.train_position, f.offset_s = role, position, float(offsets[slot])
            if len(group) < len(packet):
                incomplete += 1
            if len(group) < 2:
                f = group[0][1]
                f.role = "ping"
                continue
            res = fit_packet(group, sound_speed_mps=sound_speed_mps, max_accel_mps2=max_accel_mps2)
            for (slot, f), eps, s_eps, t, s_t in zip(group, res["eps"], res["sigma_eps"], res["t"], res["sigma_t"]):
                f.eps_pair, f.sigma_eps_pair = res["eps_mean"], res["sigma_eps_mean"]
                f.eps_chirp, f.sigma_eps_chirp = float(eps), float(s_eps)
                f.t_pair_s, f.sigma_t_pair_s = float(t), float(s_t)
        if incomplete:
            missing = "postamble" if ref.postamble_s else "train"
            warnings.warn(f"reference {name}: {incomplete} of {len(groups)} packets incomplete (declared "
                          f"{len(packet)} chirps with a {missing}; some not found)", PacketWarning, stacklevel=2)
