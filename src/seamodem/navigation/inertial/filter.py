"""The inertial filter's loop over the nodes (numba): predict, update, gate, floor, window re-linearization.

From node i − 1 to node i the state moves with the rates of the first IMU
sample at or after node i; a heading, an acoustic frame, a bearing and a
position fix may sit on any node, and are used in that order. The mission
kernel (:mod:`seamodem.navigation._inertial_mission`) runs the same steps with
the vehicle in the loop.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .charts import cartesian
from .kernels import relinearize_window, window_start
from .models import predict
from .records import Track, with_used, workspace
from .updates import floor_speed, gated_acoustic, gated_bearing, update_heading, update_position

__all__ = ["record_prior", "filter_nodes", "filter_span", "FilterOutput"]


@njit(cache=True, nogil=True)
def record_prior(k, z, P, F, lay, track):
    """Node k's prior into ``track``: state, covariance and F from node k − 1 in the history, the chart.

    ``track.states[k]`` and the posterior covariance slot hold the prior until the node's updates overwrite
    them.

    Parameters
    ----------
    k : int
        Node.
    z, P : ndarray, shapes (n,), (n, n)
        Prior state and covariance.
    F : ndarray, shape (n, n), or None
        Jacobian of the step into node k; None: identity (node 0).
    lay : ndarray, shape (5,), int64
        State layout; ``lay[4]`` is the node's chart.
    track : Track
        States, history and charts of the filter, written at node k.

    Returns
    -------
    None
    """
    states, history, charts = track.states, track.history, track.charts
    m = z.shape[0]
    charts[k] = lay[4]
    states[k] = z
    for a in range(m):
        history[k, a, 0] = z[a]
        for b in range(m):
            history[k, a, 1 + b] = P[a, b]
            history[k, a, m + 1 + b] = P[a, b]
            history[k, a, 2 * m + 1 + b] = (1.0 if a == b else 0.0) if F is None else F[a, b]


class FilterOutput(NamedTuple):
    """What the filter reports per node besides its states (:func:`filter_span` fills it).

    Parameters
    ----------
    nis, status, bearing_nis, bearing_status, online, windows : ndarray
        As :func:`filter_nodes` returns them.
    used_frame, used_bearing : ndarray, shape (N,), bool
        The frames and bearings the filter used (a window re-linearization reads them).
    """

    nis: np.ndarray
    status: np.ndarray
    bearing_nis: np.ndarray
    bearing_status: np.ndarray
    used_frame: np.ndarray
    used_bearing: np.ndarray
    online: np.ndarray
    windows: np.ndarray


@njit(cache=True, nogil=True)
def filter_span(i_begin, i_end, z, P, lay, model, settings, nodes, track, out, runs):
    """The filter over nodes ``i_begin`` … ``i_end − 1`` from (z, P) after node ``i_begin − 1``, in place.

    :func:`filter_nodes` runs it over every node; a follower (:class:`~seamodem.navigation.follow.FollowTracker`)
    runs it over the nodes each new record brings, on arrays that keep the last nodes (at least the
    re-linearization window before ``i_begin``): the same operations in the same order.

    Parameters
    ----------
    i_begin, i_end : int
        Nodes to run.
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance after node ``i_begin − 1`` (before node 0's measurements when ``i_begin`` is 0);
        left at node ``i_end − 1``'s posterior.
    lay : ndarray, shape (5,), int64
        State layout and the current chart (updated).
    model, settings, nodes
        As :func:`filter_nodes`.
    track : Track
        States, history and charts, written at the nodes run (and rewritten by a window re-linearization).
    out : FilterOutput
        Per-node output, written at the nodes run.
    runs : ndarray, shape (2,), int64
        Frames and bearings gated in a row so far (updated).

    Returns
    -------
    None
    """
    n = z.shape[0]
    states, history = track.states, track.history
    ws = workspace(n)
    nis_out, status, bearing_nis, bearing_status = out.nis, out.status, out.bearing_nis, out.bearing_status
    used_frame, used_bearing, online, windows = out.used_frame, out.used_bearing, out.online, out.windows
    used = with_used(nodes, used_frame, used_bearing)
    gated_run = runs[0]
    bearing_gated = runs[1]
    for i in range(i_begin, i_end):
        if i > 0:
            predict(z, P, lay, model, nodes.omega[i], nodes.accel[i], nodes.dt[i], ws)
            record_prior(i, z, P, ws.F, lay, track)
        else:
            record_prior(i, z, P, None, lay, track)
        if nodes.has_frame[i]:
            nis_out[i], status[i], gated_run = gated_acoustic(z, P, lay, model, settings, nodes.meas[i],
                                                              nodes.meas_var[i], gated_run, ws)
        if nodes.has_heading[i]:
            update_heading(z, P, nodes.heading[i], nodes.heading_var[i], ws.ph)
        if nodes.has_bearing[i]:
            bearing_nis[i], bearing_status[i], bearing_gated = gated_bearing(
                z, P, lay, model, settings, nodes.bearing[i], nodes.bearing_var[i], bearing_gated, ws)
        if nodes.has_fix[i]:
            update_position(z, P, lay, model.beacon, z.copy(), nodes.fix[i], nodes.fix_var[i], ws.ph)
        floor_speed(z, P, settings.v_floor)
        for a in range(n):
            states[i, a] = z[a]
            for b in range(n):
                history[i, a, n + 1 + b] = P[a, b]
        used_frame[i] = nodes.has_frame[i] and status[i] != 2
        used_bearing[i] = bearing_status[i] == 1 or bearing_status[i] == 3
        if settings.window_s > 0 and used_frame[i] and nis_out[i] > settings.window_nis:
            i0 = window_start(i, nodes.dt, settings.window_s)
            if i0 < i:
                windows[i] = relinearize_window(i0, i, track, lay, model, settings, used, z, P)
        online[i, 0], online[i, 1] = cartesian(z, lay, model.beacon)
    runs[0] = gated_run
    runs[1] = bearing_gated


def filter_nodes(z0, P0, lay, model, settings, nodes, history):
    """Run the filter over nodes; fill the posterior states and covariances.

    Plain Python around the compiled :func:`filter_span` (it only allocates): a jitted wrapper would re-optimize
    the whole compiled filter once more when numba's cache is cold (about 10 s).

    Parameters
    ----------
    z0, P0 : ndarray, shapes (n,), (n, n)
        Initial state and covariance at node 0 (before node 0's measurements), in the chart ``lay[4]``.
    lay : ndarray, shape (5,), int64
        State layout and the starting chart (copied).
    model : FilterModel
        Process noise density, beacon, acoustic rows.
    settings : FilterSettings
        Gates, iterations, window re-linearization (``window_s`` 0: never), speed floor (−∞: none).
    nodes : NodeData
        Steps, IMU rates and measurements of every node (``dt[0]`` ignored).
    history : ndarray, shape (N, n, 3n + 1)
        Work output: ``[:, :, 0]`` prior state, ``[:, :, 1:n+1]`` prior covariance, ``[:, :, n+1:2n+1]``
        posterior covariance, ``[:, :, 2n+1:3n+1]`` F from node i − 1 to i.

    Returns
    -------
    states : ndarray, shape (N, n)
        Posterior states.
    nis : ndarray, shape (N,)
        NIS of each acoustic node (NaN elsewhere).
    status : ndarray, shape (N,), int8
        0 no frame, 1 accepted, 2 gated, 3 accepted after ``gate_reset_after`` gates in a row.
    charts : ndarray, shape (N,), int8
        The chart of each node's state (0 Cartesian, 1 polar).
    bearing_nis, bearing_status : ndarray, shape (N,)
        NIS of each bearing (NaN elsewhere); 0 none, 1 used, 2 gated, 3 used although above the gate.
    online : ndarray, shape (N, 2)
        Cartesian position [m] each node had when the filter left it (real time); ``states`` differ where a
        later window re-linearized the node.
    windows : ndarray, shape (N,), int64
        Gauss–Newton iterations of the window re-linearized at each node (0: none).
    """
    N = nodes.dt.shape[0]
    n = z0.shape[0]
    lay = lay.copy()
    track = Track(np.empty((N, n)), history, np.zeros(N, dtype=np.int8))
    out = FilterOutput(np.full(N, np.nan), np.zeros(N, dtype=np.int8), np.full(N, np.nan), np.zeros(N, dtype=np.int8),
                       np.zeros(N, dtype=np.bool_), np.zeros(N, dtype=np.bool_), np.empty((N, 2)),
                       np.zeros(N, dtype=np.int64))
    z = z0.copy()
    P = P0.copy()
    filter_span(0, N, z, P, lay, model, settings, nodes, track, out, np.zeros(2, dtype=np.int64))
    return track.states, out.nis, out.status, track.charts, out.bearing_nis, out.bearing_status, out.online, out.windows
