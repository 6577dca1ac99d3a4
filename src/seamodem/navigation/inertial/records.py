"""The structured arguments of the inertial filter's numba kernels.

The kernels take a few records instead of thirty loose arrays and numbers
(numba compiles a ``NamedTuple`` of arrays and scalars as a struct: no cost per
access):

- :class:`FilterModel`: what the motion and measurement models need beside the
  state (process noise density, beacon, which acoustic rows are used);
- :class:`FilterSettings`: the filter's choices (gates, iterations, window
  re-linearization, speed floor);
- :class:`NodeData`: the measurements on the nodes (the arrays of
  :class:`~seamodem.navigation.inertial.nodes.Nodes`);
- :class:`Track`: the filter's output per node (states, history, charts), which
  the window re-linearization rewrites;
- :class:`LinearPass`: the output of one linearized Kalman pass;
- :class:`Workspace`: the scratch arrays of one filter, made once by :func:`workspace`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = ["FilterModel", "FilterSettings", "NodeData", "Track", "LinearPass", "Workspace", "workspace",
           "node_window", "with_used"]


class FilterModel(NamedTuple):
    """Motion and measurement model constants of one filter run.

    Parameters
    ----------
    qd : ndarray, shape (n,)
        Diagonal process noise density per second, in state order [state unit²/s].
    beacon : ndarray, shape (2,)
        Beacon position (x, y) [m].
    use_range : bool
        The acoustic update has a range row.
    use_vr : bool
        The acoustic update has a v_r row.
    """

    qd: np.ndarray
    beacon: np.ndarray
    use_range: bool
    use_vr: bool


class FilterSettings(NamedTuple):
    """Gating, iterations, window re-linearization and speed floor of the filter kernels.

    Parameters
    ----------
    gate : float
        χ² threshold of an acoustic update (1 or 2 dof by its rows); ``inf``: no gate.
    gate_bearing : float
        χ² (1 dof) threshold of a bearing update.
    gate_reset_after : int
        After this many consecutive gated measurements the next one is accepted.
    iterations : int
        Gauss–Newton iterations of the acoustic update (1: plain EKF).
    second_order : bool
        Cartesian chart: the range's second-order term.
    window_s : float
        Length of the window re-linearized after an improbable frame [s]; 0: never.
    window_nis : float
        NIS above which a used frame triggers the window re-linearization.
    window_iterations : int
        Gauss–Newton iterations at most of a window re-linearization.
    v_floor : float
        Speed floor after each node's updates [m/s]; −∞: none.
    """

    gate: float
    gate_bearing: float
    gate_reset_after: int
    iterations: int
    second_order: bool
    window_s: float
    window_nis: float
    window_iterations: int
    v_floor: float


class NodeData(NamedTuple):
    """The nodes' steps and measurements as the kernels read them (arrays of length N).

    Parameters
    ----------
    dt : ndarray, shape (N,)
        Step from node i − 1 to node i [s] (``dt[0]`` unused).
    omega, accel : ndarray, shape (N,)
        Gyro rate [rad/s] and acceleration [m/s²] applied over the step into node i.
    has_heading, heading, heading_var : ndarray, shape (N,)
        Heading measurement per node: present, reading [rad], variance [rad²].
    has_frame, meas, meas_var : ndarray, shapes (N,), (N, 2), (N, 2)
        Acoustic measurement per node: present (or used), (range [m], v_r [m/s]), their variances.
    has_fix, fix, fix_var : ndarray, shapes (N,), (N, 2), (N,)
        Position fix per node: present, (x, y) [m], variance per axis [m²].
    has_bearing, bearing, bearing_var : ndarray, shape (N,)
        Body-frame azimuth of the beacon per node: present (or used), azimuth [rad], variance [rad²].
    """

    dt: np.ndarray
    omega: np.ndarray
    accel: np.ndarray
    has_heading: np.ndarray
    heading: np.ndarray
    heading_var: np.ndarray
    has_frame: np.ndarray
    meas: np.ndarray
    meas_var: np.ndarray
    has_fix: np.ndarray
    fix: np.ndarray
    fix_var: np.ndarray
    has_bearing: np.ndarray
    bearing: np.ndarray
    bearing_var: np.ndarray


class Track(NamedTuple):
    """The filter's output per node, rewritten by a window re-linearization.

    Parameters
    ----------
    states : ndarray, shape (N, n)
        Posterior state of each node, in its chart.
    history : ndarray, shape (N, n, 3n + 1)
        ``[:, :, 0]`` prior state, ``[:, :, 1:n+1]`` prior covariance, ``[:, :, n+1:2n+1]`` posterior
        covariance, ``[:, :, 2n+1:3n+1]`` the transition Jacobian F from node i − 1 to i.
    charts : ndarray, shape (N,), int8
        Chart of each node's state (0 Cartesian, 1 polar).
    """

    states: np.ndarray
    history: np.ndarray
    charts: np.ndarray


class LinearPass(NamedTuple):
    """Output of one linearized Kalman pass (:func:`~.kernels.linearized_pass`), what the RTS recursion needs.

    Parameters
    ----------
    post, P_post : ndarray, shapes (N, n), (N, n, n)
        Posterior states and covariances.
    prior, P_prior : ndarray, shapes (N, n), (N, n, n)
        Prior states and covariances.
    F : ndarray, shape (N, n, n)
        Jacobian of the step into each node (identity at node 0).
    """

    post: np.ndarray
    P_post: np.ndarray
    prior: np.ndarray
    P_prior: np.ndarray
    F: np.ndarray


class Workspace(NamedTuple):
    """Scratch arrays of one filter with n states (:func:`workspace`).

    Parameters
    ----------
    zp : ndarray, shape (n,)
        Predicted state.
    F, A, Pp : ndarray, shape (n, n)
        Step Jacobian, F·P, predicted covariance.
    ph : ndarray, shape (n,)
        P·hᵀ of a scalar update.
    work : ndarray, shape (5, n)
        Rows of the iterated acoustic update (prior, iterate, predicted rows, P·Hᵀ twice).
    H : ndarray, shape (2, n)
        Jacobian of the acoustic rows.
    """

    zp: np.ndarray
    F: np.ndarray
    A: np.ndarray
    Pp: np.ndarray
    ph: np.ndarray
    work: np.ndarray
    H: np.ndarray


@njit(cache=True, nogil=True)
def workspace(n):
    """The scratch arrays of a filter with ``n`` states.

    Parameters
    ----------
    n : int
        Number of states.

    Returns
    -------
    Workspace
        Uninitialized arrays, ``H`` zeroed.
    """
    return Workspace(np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty(n),
                     np.empty((5, n)), np.zeros((2, n)))


@njit(cache=True, nogil=True)
def node_window(nodes, i0, i1):
    """Nodes i0 … i1 − 1 of ``nodes`` (views, no copy).

    Parameters
    ----------
    nodes : NodeData
        Arrays of every node.
    i0, i1 : int
        First node and one past the last.

    Returns
    -------
    NodeData
        The slices.
    """
    return NodeData(nodes.dt[i0:i1], nodes.omega[i0:i1], nodes.accel[i0:i1], nodes.has_heading[i0:i1],
                    nodes.heading[i0:i1], nodes.heading_var[i0:i1], nodes.has_frame[i0:i1], nodes.meas[i0:i1],
                    nodes.meas_var[i0:i1], nodes.has_fix[i0:i1], nodes.fix[i0:i1], nodes.fix_var[i0:i1],
                    nodes.has_bearing[i0:i1], nodes.bearing[i0:i1], nodes.bearing_var[i0:i1])


@njit(cache=True, nogil=True)
def with_used(nodes, used_frame, used_bearing):
    """``nodes`` with the frames and bearings the filter used in place of those it was given.

    Parameters
    ----------
    nodes : NodeData
        Arrays of every node.
    used_frame, used_bearing : ndarray, shape (N,), bool
        Acoustic frames and bearings that were used (the arrays themselves, filled as the filter goes).

    Returns
    -------
    NodeData
        The same arrays but ``has_frame`` and ``has_bearing``.
    """
    return NodeData(nodes.dt, nodes.omega, nodes.accel, nodes.has_heading, nodes.heading, nodes.heading_var,
                    used_frame, nodes.meas, nodes.meas_var, nodes.has_fix, nodes.fix, nodes.fix_var, used_bearing,
                    nodes.bearing, nodes.bearing_var)
