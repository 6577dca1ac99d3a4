"""The smoothing kernels: Rauch–Tung–Striebel gains and backward pass, a linearized Kalman pass, a window's Gauss–Newton.

One Gauss–Newton step on the whole track (or a window of it) is one Kalman
filter of the model linearized about the current track (:func:`linearized_pass`)
followed by a Rauch–Tung–Striebel pass (:func:`rts_gains`, :func:`rts_backward`):
the iterated extended Kalman smoother. The batch and fixed-lag smoothers
(:mod:`.smoothers`) and the filter's window re-linearization
(:func:`relinearize_window`) share them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .charts import convert_chart, wrap
from .models import acoustic_model, motion, process_polar, propagate_cov
from .records import LinearPass, node_window, workspace
from .updates import update_bearing, update_heading, update_position

__all__ = ["rts_gains", "rts_backward", "linearized_pass", "window_start", "relinearize_window"]


@njit(cache=True, nogil=True)
def rts_gains(post, P_post, prior, P_prior, F):
    """C_k = P⁺_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹ for k = 0…N−2 (row N−1 zero).

    Parameters
    ----------
    post, P_post : ndarray, shapes (N, n), (N, n, n)
        Posterior states and covariances.
    prior, P_prior : ndarray, shapes (N, n), (N, n, n)
        Prior states and covariances.
    F : ndarray, shape (N, n, n)
        Jacobian of the step into each node.

    Returns
    -------
    ndarray, shape (N, n, n)
        The smoother gains.
    """
    N, n = post.shape
    C = np.zeros((N, n, n))
    for k in range(N - 1):
        # P⁻_{k+1} Cᵀ = F_{k+1} P⁺_k
        Ct = np.linalg.solve(P_prior[k + 1], F[k + 1] @ P_post[k])
        C[k] = Ct.T
    return C



@njit(cache=True, nogil=True)
def rts_backward(post, P_post, prior, P_prior, C):
    """The Rauch–Tung–Striebel backward pass with the gains of :func:`rts_gains`.

    Parameters
    ----------
    post, P_post : ndarray, shapes (N, n), (N, n, n)
        Posterior states and covariances.
    prior, P_prior : ndarray, shapes (N, n), (N, n, n)
        Prior states and covariances.
    C : ndarray, shape (N, n, n)
        Smoother gains.

    Returns
    -------
    xs : ndarray, shape (N, n)
        Smoothed states.
    Ps : ndarray, shape (N, n, n)
        Smoothed covariances.
    """
    N, n = post.shape
    xs = post.copy()
    Ps = P_post.copy()
    for k in range(N - 2, -1, -1):
        xs[k] = post[k] + C[k] @ (xs[k + 1] - prior[k + 1])
        Pk = P_post[k] + C[k] @ (Ps[k + 1] - P_prior[k + 1]) @ C[k].T
        Ps[k] = 0.5 * (Pk + Pk.T)
    return xs, Ps


@njit(cache=True, nogil=True)
def linearized_pass(nominal, z0, P0, lay, charts, model, nodes, out):
    """Kalman filter of the model linearized about ``nominal`` (one Gauss–Newton step, forward half).

    ``charts`` (N,) is the filter's chart per node (0 Cartesian, 1 polar): ``nominal[i]`` is in chart
    ``charts[i]``; where the chart changes, the step's Jacobian carries the change of coordinates.

    Parameters
    ----------
    nominal : ndarray, shape (N, n)
        Linearization track, node i in chart ``charts[i]``.
    z0, P0 : ndarray, shapes (n,), (n, n)
        Prior at node 0 (before its measurements), in chart ``charts[0]``.
    lay : ndarray, shape (5,), int64
        State layout (copied; its chart follows ``charts``).
    charts : ndarray, shape (N,), int8
        Chart per node.
    model : FilterModel
        Process noise density, beacon, acoustic rows.
    nodes : NodeData
        Steps and the measurements to use (``has_frame``, ``has_bearing``: those the filter used).
    out : LinearPass
        Output: posteriors, priors and step Jacobians of every node.

    Returns
    -------
    None
    """
    N, n = nominal.shape
    lay = lay.copy()
    no_cov = np.zeros((n, n))
    z = z0.copy()
    P = P0.copy()
    ws = workspace(n)
    fx, F, A, Pp, ph, h, H = ws.zp, ws.F, ws.A, ws.Pp, ws.ph, ws.work[2], ws.H
    qd, beacon, use_range, use_vr = model.qd, model.beacon, model.use_range, model.use_vr
    dt, omega, accel = nodes.dt, nodes.omega, nodes.accel
    has_heading, heading, heading_var = nodes.has_heading, nodes.heading, nodes.heading_var
    use_frame, meas, meas_var = nodes.has_frame, nodes.meas, nodes.meas_var
    has_fix, fix, fix_var = nodes.has_fix, nodes.fix, nodes.fix_var
    use_bearing, bearing, bearing_var = nodes.has_bearing, nodes.bearing, nodes.bearing_var
    post, P_post, prior, P_prior, F_all = out.post, out.P_post, out.prior, out.P_prior, out.F
    H = np.zeros((2, n))
    for i in range(N):
        if i > 0:
            lay[4] = charts[i - 1]
            motion(nominal[i - 1], lay, omega[i], accel[i], dt[i], fx, F)
            convert_chart(fx, no_cov, lay, beacon, charts[i], F)
            if charts[i] == 1 and charts[i - 1] == 0:
                # back to polar: arctan2's β on the branch of this node's nominal (β is continuous within a polar
                # stretch and may differ by 2π from arctan2 after a Cartesian one)
                fx[1] = nominal[i, 1] + wrap(fx[1] - nominal[i, 1])
            for a in range(n):
                acc = fx[a]
                for b in range(n):
                    acc += F[a, b] * (z[b] - nominal[i - 1, b])
                ph[a] = acc
            propagate_cov(P, F, qd, dt[i], A, Pp)
            lay[4] = charts[i]
            process_polar(Pp, nominal[i], lay, qd, dt[i])
            for a in range(n):
                z[a] = ph[a]
                for b in range(n):
                    P[a, b] = Pp[a, b]
        else:
            for a in range(n):
                for b in range(n):
                    F[a, b] = 1.0 if a == b else 0.0
        lay[4] = charts[i]
        for a in range(n):
            prior[i, a] = z[a]
            for b in range(n):
                P_prior[i, a, b] = P[a, b]
                F_all[i, a, b] = F[a, b]
        if use_frame[i]:
            rows = acoustic_model(nominal[i], lay, beacon, use_range, use_vr, h, H)
            for r in range(rows):
                target = meas[i, 0] if (use_range and r == 0) else meas[i, 1]
                var = meas_var[i, 0] if (use_range and r == 0) else meas_var[i, 1]
                nu = target - h[r]
                for b in range(n):
                    nu -= H[r, b] * (z[b] - nominal[i, b])
                s = var
                for a in range(n):
                    acc = 0.0
                    for b in range(n):
                        acc += P[a, b] * H[r, b]
                    ph[a] = acc
                    s += H[r, a] * acc
                for a in range(n):
                    z[a] += ph[a] / s * nu
                for a in range(n):
                    for b in range(n):
                        P[a, b] -= ph[a] * ph[b] / s
        if has_heading[i]:
            # the heading row is linear: the same update as the filter's, angle wrapped about the nominal
            update_heading(z, P, nominal[i, 2] + nominal[i, 4] + wrap(heading[i] - nominal[i, 2] - nominal[i, 4]),
                           heading_var[i], ph)
        if use_bearing[i]:
            update_bearing(z, P, lay, beacon, nominal[i], bearing[i], bearing_var[i], np.inf, np.bool_(True), ph)
        if has_fix[i]:
            update_position(z, P, lay, beacon, nominal[i], fix[i], fix_var[i], ph)
        for a in range(n):
            post[i, a] = z[a]
            for b in range(n):
                P_post[i, a, b] = P[a, b]


@njit(cache=True, nogil=True)
def window_start(i, dt, window_s):
    """First node of the window of at most ``window_s`` seconds that ends at node i.

    Parameters
    ----------
    i : int
        Last node of the window.
    dt : ndarray, shape (N,)
        Step into each node [s].
    window_s : float
        Window length at most [s].

    Returns
    -------
    int
        The first node.
    """
    i0 = i
    span = 0.0
    while i0 > 0 and span + dt[i0] <= window_s + 1e-9:
        span += dt[i0]
        i0 -= 1
    return i0


@njit(cache=True, nogil=True)
def relinearize_window(i0, i, track, lay, model, settings, nodes, z, P):
    """Gauss–Newton over nodes i0 … i from the prior at node i0: the batch smoother's step on a window.

    One linearization per step cannot take back a wrong turn. A frame whose innovation is improbable under
    the filter's own prior (``InertialConfig.window_probability``) says the filter may have taken one, and
    re-linearizing the last ``window_s`` about their smoothed track lets the frames inside agree on one
    track. The prior at node i0 (``track.history``) holds none of the window's measurements, so node i's new
    state still uses nothing after node i.

    Parameters
    ----------
    i0, i : int
        First and last node of the window.
    track : Track
        The filter's states, history and charts; the window's nodes are replaced by the last forward pass
        (posteriors and priors of one linear pass, as the Rauch–Tung–Striebel smoothers need them).
    lay : ndarray, shape (5,), int64
        State layout.
    model : FilterModel
        Process noise density, beacon, acoustic rows.
    settings : FilterSettings
        ``window_iterations``: Gauss–Newton iterations at most.
    nodes : NodeData
        Steps and the measurements the filter used (``has_frame``, ``has_bearing``).
    z, P : ndarray, shapes (n,), (n, n)
        Set to node i's new posterior.

    Returns
    -------
    int
        The Gauss–Newton iterations, or 0 when they did not converge within ``settings.window_iterations``
        (nothing then changes: the filter keeps its own state).
    """
    states, history, charts = track.states, track.history, track.charts
    L = i - i0 + 1
    n = z.shape[0]
    out = LinearPass(np.empty((L, n)), np.empty((L, n, n)), np.empty((L, n)), np.empty((L, n, n)),
                     np.empty((L, n, n)))
    post, P_post, prior, P_prior, F_all = out.post, out.P_post, out.prior, out.P_prior, out.F
    z0 = history[i0, :, 0].copy()
    P0 = np.ascontiguousarray(history[i0, :, 1:n + 1])
    nominal = states[i0:i + 1].copy()
    window = node_window(nodes, i0, i + 1)
    iterations = 0
    for it in range(1, settings.window_iterations + 1):
        linearized_pass(nominal, z0, P0, lay, charts[i0:i + 1], model, window, out)
        try:
            C = rts_gains(post, P_post, prior, P_prior, F_all)
        except Exception:  # a singular prior: Gauss–Newton has left the region where the model holds
            return 0
        xs, _ = rts_backward(post, P_post, prior, P_prior, C)
        step = np.max(np.abs(xs - nominal))
        nominal = xs
        if step < 1e-6:
            iterations = it
            break
    if iterations == 0 or not np.all(np.isfinite(post)):
        return 0
    for j in range(L):
        k = i0 + j
        for a in range(n):
            states[k, a] = post[j, a]
            if j > 0:
                history[k, a, 0] = prior[j, a]
            for b in range(n):
                if j > 0:
                    history[k, a, 1 + b] = P_prior[j, a, b]
                    history[k, a, 2 * n + 1 + b] = F_all[j, a, b]
                history[k, a, n + 1 + b] = P_post[j, a, b]
    for a in range(n):
        z[a] = post[L - 1, a]
        for b in range(n):
            P[a, b] = P_post[L - 1, a, b]
    return iterations
