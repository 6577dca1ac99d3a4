"""The inertial filter's measurement updates and their gates.

Heading (ψ + b), position fix, body-frame bearing of the beacon and the iterated
acoustic (range, v_r) update, each in place on (z, P); the gated forms keep the
count of measurements gated in a row (:class:`~.records.FilterSettings`), and
:func:`floor_speed` projects the estimate onto a forward speed.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .charts import polar_jacobian, wrap
from .models import acoustic_model, innovation_cov

__all__ = ["update_heading", "floor_speed", "update_position", "update_bearing", "update_acoustic",
           "gated_acoustic", "gated_bearing"]


@njit(cache=True, nogil=True)
def update_heading(z, P, heading, var, ph):
    """Scalar update with ψ_meas = ψ + b, in place.

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place.
    heading : float
        Heading sensor reading [rad].
    var : float
        Its variance [rad²].
    ph : ndarray, shape (n,)
        Scratch.

    Returns
    -------
    float
        The normalised innovation squared.
    """
    n = z.shape[0]
    nu = wrap(heading - z[2] - z[4])
    for i in range(n):
        ph[i] = P[i, 2] + P[i, 4]
    s = ph[2] + ph[4] + var
    for i in range(n):
        z[i] += ph[i] / s * nu
    for i in range(n):
        for j in range(n):
            P[i, j] -= ph[i] * ph[j] / s
    return nu * nu / s


@njit(cache=True, nogil=True)
def floor_speed(z, P, v_floor):
    """Project the estimate onto v ≥ ``v_floor`` (the vehicle moves forward); returns whether it did.

    Range and v_r cannot tell a vehicle approaching its closest point to the beacon from one receding on the
    track reflected about that point with its speed negated: same ranges, same v_r, same heading. Where the
    data leave that open (metres of range noise near a closest approach) a Gaussian filter can slide onto the
    backward branch. The projection is the constrained estimate of minimum P⁻¹-distance (Simon & Chia 2002):
    z ← z + P[:, v] (v_floor − z_v) / P[v, v], which moves every state correlated with the speed (the
    position along the track) with it; P is kept.

    Parameters
    ----------
    z : ndarray, shape (n,)
        State (speed at index 3), moved in place.
    P : ndarray, shape (n, n)
        Covariance (unchanged).
    v_floor : float
        Speed floor [m/s]; −∞: none.

    Returns
    -------
    bool
        Whether the state was projected.
    """
    if not (z[3] < v_floor) or P[3, 3] <= 0.0:
        return False
    d = (v_floor - z[3]) / P[3, 3]
    for a in range(z.shape[0]):
        z[a] += P[a, 3] * d
    z[3] = v_floor
    return True


@njit(cache=True, nogil=True)
def update_position(z, P, lay, beacon, about, fix, var, ph):
    """Two scalar updates with a position fix (x, y) of variance ``var`` each (GNSS at the surface).

    The fix is linear in Cartesian states; in polar ones (x, y) = beacon + ρ(cos β, sin β) is linearized
    about ``about`` (the filter passes its own state, the batch smoother its nominal track).

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    about : ndarray, shape (n,)
        Linearization point (polar chart).
    fix : ndarray, shape (2,)
        Position fix (x, y) [m].
    var : float
        Variance of each axis [m²].
    ph : ndarray, shape (n,)
        Scratch.

    Returns
    -------
    None
    """
    n = z.shape[0]
    for axis in range(2):
        for i in range(n):
            ph[i] = 0.0
        if lay[4] == 0:
            nu = fix[axis] - z[axis]
            for i in range(n):
                ph[i] = P[i, axis]
            s = ph[axis] + var
        else:
            cb, sb = np.cos(about[1]), np.sin(about[1])
            h0 = beacon[0] + about[0] * cb if axis == 0 else beacon[1] + about[0] * sb
            j00, j01, j10, j11 = polar_jacobian(about[0], cb, sb)
            h_rho = j00 if axis == 0 else j10
            h_beta = j01 if axis == 0 else j11
            nu = fix[axis] - h0 - h_rho * (z[0] - about[0]) - h_beta * (z[1] - about[1])
            for i in range(n):
                ph[i] = P[i, 0] * h_rho + P[i, 1] * h_beta
            s = h_rho * ph[0] + h_beta * ph[1] + var
        for i in range(n):
            z[i] += ph[i] / s * nu
        for i in range(n):
            for j in range(n):
                P[i, j] -= ph[i] * ph[j] / s


@njit(cache=True, nogil=True)
def update_bearing(z, P, lay, beacon, about, azimuth, var, gate, force, ph):
    """Scalar update with the beacon's body-frame azimuth (a hydrophone array, issue 17); returns (NIS, used).

    h = wrap(atan2(y_b − y, x_b − x) − ψ) (:func:`.bearing.bearing_body`, level vehicle). In the polar chart
    atan2(y_b − y, x_b − x) = β + π, so h = wrap(β + π − ψ) is *linear* in the state (H = e_β − e_ψ): the
    bearing pins the rotation about the beacon that range, v_r and a biased heading leave free. In the
    Cartesian chart H = (dy/ρ², −dx/ρ², −1) with (dx, dy) = beacon − (x, y), linearized about ``about`` (the
    filter passes its own state, the batch smoother its nominal track). The innovation is wrapped; the
    update is skipped when its NIS exceeds ``gate`` (1 dof) unless ``force``.

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    about : ndarray, shape (n,)
        Linearization point.
    azimuth : float
        Measured body-frame azimuth of the beacon [rad].
    var : float
        Its variance [rad²].
    gate : float
        χ² (1 dof) threshold.
    force : bool
        Update even above the gate.
    ph : ndarray, shape (n,)
        Scratch.

    Returns
    -------
    nis : float
        Normalised innovation squared.
    used : bool
        Whether the update was made.
    """
    n = z.shape[0]
    for i in range(n):
        ph[i] = 0.0
    if lay[4] == 1:
        h0 = about[1] + np.pi - about[2]
        nu = wrap(azimuth - h0) - (z[1] - about[1]) + (z[2] - about[2])
        for i in range(n):
            ph[i] = P[i, 1] - P[i, 2]
        s = ph[1] - ph[2] + var
    else:
        dx, dy = beacon[0] - about[0], beacon[1] - about[1]
        r2 = dx * dx + dy * dy
        hx, hy = dy / r2, -dx / r2
        h0 = np.arctan2(dy, dx) - about[2]
        nu = wrap(azimuth - h0) - hx * (z[0] - about[0]) - hy * (z[1] - about[1]) + (z[2] - about[2])
        for i in range(n):
            ph[i] = P[i, 0] * hx + P[i, 1] * hy - P[i, 2]
        s = hx * ph[0] + hy * ph[1] - ph[2] + var
    nis = nu * nu / s
    if nis > gate and not force:
        return nis, False
    for i in range(n):
        z[i] += ph[i] / s * nu
    for i in range(n):
        for j in range(n):
            P[i, j] -= ph[i] * ph[j] / s
    return nis, True




@njit(cache=True, nogil=True)
def update_acoustic(z, P, lay, beacon, meas, var, use_range, use_vr, gate, iterations, force, work, Hw,
                     second_order):
    """Iterated EKF update with (range, v_r); returns (NIS at the prior, accepted).

    ``meas`` = (d, v_r), ``var`` their variances. The NIS is computed with the
    prior linearization; above ``gate`` the state is left unchanged unless
    ``force``. Gauss–Newton: z_{i+1} = z⁻ + K_i (y − h(z_i) − H_i (z⁻ − z_i)).

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    meas : ndarray, shape (2,)
        Range [m] and v_r [m/s].
    var : ndarray, shape (2,)
        Their variances [m², m²/s²].
    use_range, use_vr : bool
        Which rows.
    gate : float
        χ² threshold of the NIS.
    iterations : int
        Gauss–Newton iterations at most.
    force : bool
        Update even above the gate.
    work : ndarray, shape (5, n)
        Scratch rows.
    Hw : ndarray, shape (2, n)
        Scratch Jacobian.
    second_order : bool
        Cartesian chart: the range's second-order term.

    Returns
    -------
    nis : float
        NIS at the prior.
    accepted : bool
        Whether the state was updated.
    """
    n = z.shape[0]
    z_prior = work[0]
    zi = work[1]
    h = work[2]
    PHt0 = work[3]
    PHt1 = work[4]
    for i in range(n):
        z_prior[i] = z[i]
        zi[i] = z[i]
    nis = 0.0
    s00 = s01 = s11 = 0.0
    rows = 0
    var2 = 0.0
    for it in range(iterations):
        rows = acoustic_model(zi, lay, beacon, use_range, use_vr, h, Hw)
        # innovation of the linearized model about zi, evaluated for the prior
        nu0 = 0.0
        nu1 = 0.0
        # second-order term of the range (Hessian (I − uuᵀ)/r in x, y): the prior's spread across the
        # line of sight lengthens the expected range by σ_t²/(2r) and adds (σ_t²/r)²/2 to its variance
        dx, dy = zi[0] - beacon[0], zi[1] - beacon[1]
        rr = max(np.sqrt(dx * dx + dy * dy), 1e-6)
        tx, ty = -dy / rr, dx / rr
        st2 = tx * tx * P[0, 0] + 2.0 * tx * ty * P[0, 1] + ty * ty * P[1, 1]
        k_scale = 1.0 + (zi[lay[2]] if lay[2] >= 0 else 0.0)
        curved = second_order and lay[4] == 0  # polar: the range is linear in ρ
        bias2 = k_scale * st2 / (2.0 * rr) if curved else 0.0
        var2 = 0.5 * (k_scale * st2 / rr) ** 2 if curved else 0.0
        for r in range(rows):
            target = meas[0] if (use_range and r == 0) else meas[1]
            acc = target - h[r]
            if use_range and r == 0:
                acc -= bias2
            for j in range(n):
                acc -= Hw[r, j] * (z_prior[j] - zi[j])
            if r == 0:
                nu0 = acc
            else:
                nu1 = acc
        s00, s01, s11 = innovation_cov(P, Hw, rows, var[0] + var2 if use_range else var[1], var[1], PHt0, PHt1)
        if rows > 1:
            det = s00 * s11 - s01 * s01
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            w0 = i00 * nu0 + i01 * nu1
            w1 = i01 * nu0 + i11 * nu1
            if it == 0:
                nis = nu0 * w0 + nu1 * w1
        else:
            w0 = nu0 / s00
            w1 = 0.0
            if it == 0:
                nis = nu0 * w0
        if it == 0 and nis > gate and not force:
            return nis, False
        step = 0.0
        for i in range(n):
            new = z_prior[i] + PHt0[i] * w0 + PHt1[i] * w1
            step = max(step, abs(new - zi[i]))
            zi[i] = new
        if step < 1e-10:
            break
    # covariance with the Jacobian at the updated state, P − PHᵀ S⁻¹ H P, also after one iteration: measured
    # on 40 missions at σ_d = 1 mm it kept the filter nearer its errors than the prior's Jacobian (mean error
    # 1.96 vs 3.07 m, position NEES 1.2e4 vs 3.3e4)
    rows = acoustic_model(zi, lay, beacon, use_range, use_vr, h, Hw)
    s00, s01, s11 = innovation_cov(P, Hw, rows, var[0] + var2 if use_range else var[1], var[1], PHt0, PHt1)
    if rows > 1:
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    else:
        i00, i01, i11 = 1.0 / s00, 0.0, 0.0
    for i in range(n):
        for j in range(n):
            P[i, j] -= (PHt0[i] * (i00 * PHt0[j] + i01 * PHt1[j]) + PHt1[i] * (i01 * PHt0[j] + i11 * PHt1[j]))
    for i in range(n):
        z[i] = zi[i]
        for j in range(i + 1, n):
            m = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = m
            P[j, i] = m
    return nis, True


@njit(cache=True, nogil=True)
def gated_acoustic(z, P, lay, model, settings, meas, var, gated_run, ws):
    """The acoustic update with the gate's bookkeeping.

    Status 1 accepted, 2 gated (state unchanged), 3 accepted although above the gate because
    ``settings.gate_reset_after`` frames in a row were gated before it.

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    model : FilterModel
        Beacon and the rows used.
    settings : FilterSettings
        Gate, its reset, iterations, second-order term.
    meas, var : ndarray, shape (2,)
        Range [m] and v_r [m/s], their variances.
    gated_run : int
        Frames gated in a row before this one.
    ws : Workspace
        Scratch (``work``, ``H``).

    Returns
    -------
    nis : float
        NIS at the prior.
    status : int
        1, 2 or 3 as above.
    gated_run : int
        Frames gated in a row after this one.
    """
    force = gated_run >= settings.gate_reset_after
    nis, ok = update_acoustic(z, P, lay, model.beacon, meas, var, model.use_range, model.use_vr, settings.gate,
                              settings.iterations, force, ws.work, ws.H, settings.second_order)
    if not ok:
        return nis, 2, gated_run + 1
    return nis, (3 if (force and nis > settings.gate) else 1), 0


@njit(cache=True, nogil=True)
def gated_bearing(z, P, lay, model, settings, azimuth, var, gated_run, ws):
    """The bearing update with the gate's bookkeeping, as :func:`gated_acoustic`.

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, updated in place (linearized about z).
    lay : ndarray, shape (5,), int64
        State layout and chart.
    model : FilterModel
        The beacon.
    settings : FilterSettings
        ``gate_bearing`` and ``gate_reset_after``.
    azimuth : float
        Measured body-frame azimuth of the beacon [rad].
    var : float
        Its variance [rad²].
    gated_run : int
        Bearings gated in a row before this one.
    ws : Workspace
        Scratch (``ph``).

    Returns
    -------
    nis : float
        Normalised innovation squared.
    status : int
        1 used, 2 gated, 3 used although above the gate.
    gated_run : int
        Bearings gated in a row after this one.
    """
    force = gated_run >= settings.gate_reset_after
    nis, used = update_bearing(z, P, lay, model.beacon, z.copy(), azimuth, var, settings.gate_bearing, force, ws.ph)
    if not used:
        return nis, 2, gated_run + 1
    return nis, (3 if nis > settings.gate_bearing else 1), 0
