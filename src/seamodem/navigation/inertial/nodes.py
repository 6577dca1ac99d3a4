"""The nodes the inertial filter and its smoothers run on: IMU samples and frame arrivals on one time grid.

The nodes are the sorted union of the IMU sample times and the frame arrival
times (:func:`build_nodes`); position fixes (:func:`add_fixes`) and a
hydrophone array's bearings (:func:`add_bearings`) sit on the nearest nodes.
:meth:`Nodes.data` gives the kernels their arrays (:class:`~.records.NodeData`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .records import NodeData

__all__ = ["Nodes", "build_nodes", "add_fixes", "add_bearings"]


@dataclass(frozen=True, eq=False)
class Nodes:
    """The time grid the filter and the smoothers run on (see the module notes).

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Node times [s].
    dt_s : ndarray, shape (N,)
        Step from the previous node [s] (0 at node 0).
    omega, accel : ndarray, shape (N,)
        IMU gyro rate [rad/s] and acceleration [m/s²] applied over the step into each node.
    has_heading, heading, heading_var : ndarray, shape (N,)
        Heading measurement: present, reading [rad], variance [rad²].
    has_acoustic, meas, meas_var : ndarray, shapes (N,), (N, 2), (N, 2)
        Acoustic measurement: present, (range [m], v_r [m/s]), their variances.
    frame : ndarray, shape (N,), int64
        Index of the record at that node, −1 elsewhere.
    imu : ndarray, shape (N,), int64
        Index of the IMU sample at that node, −1 elsewhere.
    has_fix, fix, fix_var : ndarray, shapes (N,), (N, 2), (N,), optional
        Position fixes (:func:`add_fixes`): present, (x, y) [m], variance per axis [m²]; default none.
    has_bearing, bearing, bearing_var : ndarray, shape (N,), optional
        The beacon's body-frame azimuth from a hydrophone array (:func:`add_bearings`): present, azimuth
        [rad], variance [rad²]; default none.
    """

    t_s: np.ndarray
    dt_s: np.ndarray
    omega: np.ndarray
    accel: np.ndarray
    has_heading: np.ndarray
    heading: np.ndarray
    heading_var: np.ndarray
    has_acoustic: np.ndarray
    meas: np.ndarray
    meas_var: np.ndarray
    frame: np.ndarray
    imu: np.ndarray
    has_fix: np.ndarray = None
    fix: np.ndarray = None
    fix_var: np.ndarray = None
    has_bearing: np.ndarray = None
    bearing: np.ndarray = None
    bearing_var: np.ndarray = None

    def __post_init__(self):
        N = self.t_s.size
        if self.has_fix is None:
            object.__setattr__(self, "has_fix", np.zeros(N, dtype=bool))
            object.__setattr__(self, "fix", np.zeros((N, 2)))
            object.__setattr__(self, "fix_var", np.ones(N))
        if self.has_bearing is None:
            object.__setattr__(self, "has_bearing", np.zeros(N, dtype=bool))
            object.__setattr__(self, "bearing", np.zeros(N))
            object.__setattr__(self, "bearing_var", np.ones(N))

    def __len__(self) -> int:
        return self.t_s.size

    def data(self, *, has_heading=None, has_frame=None, has_bearing=None) -> NodeData:
        """The arrays the kernels read, optionally with other heading, frame or bearing selections.

        Parameters
        ----------
        has_heading, has_frame, has_bearing : ndarray, shape (N,), bool, optional
            Which headings, frames and bearings to use; default the nodes' own.

        Returns
        -------
        NodeData
            The nodes' arrays (not copied).
        """
        return NodeData(self.dt_s, self.omega, self.accel, self.has_heading if has_heading is None else has_heading,
                        self.heading, self.heading_var, self.has_acoustic if has_frame is None else has_frame,
                        self.meas, self.meas_var, self.has_fix, self.fix, self.fix_var,
                        self.has_bearing if has_bearing is None else has_bearing, self.bearing, self.bearing_var)


def build_nodes(imu_t, heading, omega, accel, frame_t, range_m, v_r_mps, range_var, v_r_var, *,
                heading_var, t_start=None) -> Nodes:
    """Merge IMU samples and frames into nodes sorted by time.

    A frame at the same time as an IMU sample shares its node. Frames before ``t_start`` (default the first
    IMU time) or after the last IMU sample are dropped by the caller
    (:func:`~seamodem.navigation.inertial.run_filter` reports them).

    Parameters
    ----------
    imu_t : array_like, shape (M,)
        IMU sample times [s], increasing.
    heading, omega, accel : array_like, shape (M,)
        Heading reading [rad] (NaN: no heading update at that sample), gyro rate [rad/s], acceleration [m/s²].
    frame_t : array_like, shape (K,)
        Frame arrival times [s].
    range_m, v_r_mps : array_like, shape (K,)
        Range [m] and closing speed [m/s] of each frame.
    range_var, v_r_var : float or array_like, shape (K,)
        Their variances [m², m²/s²].
    heading_var : float or array_like, shape (M,)
        Variance of the heading readings [rad²].
    t_start : float, optional
        Time of node 0 [s]; default the first IMU time.

    Returns
    -------
    Nodes
        The merged grid.
    """
    imu_t = np.asarray(imu_t, dtype=float)
    frame_t = np.asarray(frame_t, dtype=float)
    t0 = imu_t[0] if t_start is None else float(t_start)
    t_all = np.union1d(imu_t[imu_t >= t0], frame_t[frame_t >= t0])
    if t_all.size == 0 or t_all[0] > t0:
        t_all = np.r_[t0, t_all]
    N = t_all.size
    # rates over (t_{i-1}, t_i]: the first IMU sample at or after t_i (the last one past the end)
    k = np.minimum(np.searchsorted(imu_t, t_all, side="left"), imu_t.size - 1)
    omega_n = np.asarray(omega, dtype=float)[k]
    accel_n = np.asarray(accel, dtype=float)[k]
    dt = np.r_[0.0, np.diff(t_all)]
    imu_at = np.full(N, -1, dtype=np.int64)
    pos = np.searchsorted(t_all, imu_t)
    inside = (pos < N) & (imu_t >= t0)
    inside[inside] &= t_all[pos[inside]] == imu_t[inside]
    imu_at[pos[inside]] = np.flatnonzero(inside)
    head = np.full(N, np.nan)
    hvar = np.full(N, np.nan)
    hv = np.broadcast_to(np.asarray(heading_var, dtype=float), imu_t.shape)
    head[imu_at >= 0] = np.asarray(heading, dtype=float)[imu_at[imu_at >= 0]]
    hvar[imu_at >= 0] = hv[imu_at[imu_at >= 0]]
    has_heading = np.isfinite(head) & np.isfinite(hvar)
    frame_at = np.full(N, -1, dtype=np.int64)
    fpos = np.searchsorted(t_all, frame_t)
    finside = (frame_t >= t0) & (fpos < N)
    finside[finside] &= t_all[fpos[finside]] == frame_t[finside]
    frame_at[fpos[finside]] = np.flatnonzero(finside)
    meas = np.zeros((N, 2))
    mvar = np.ones((N, 2))
    sel = frame_at >= 0
    idx = frame_at[sel]
    meas[sel, 0] = np.asarray(range_m, dtype=float)[idx]
    meas[sel, 1] = np.asarray(v_r_mps, dtype=float)[idx]
    mvar[sel, 0] = np.broadcast_to(np.asarray(range_var, dtype=float), frame_t.shape)[idx]
    mvar[sel, 1] = np.broadcast_to(np.asarray(v_r_var, dtype=float), frame_t.shape)[idx]
    return Nodes(t_all, dt, omega_n, accel_n, has_heading, np.nan_to_num(head), np.nan_to_num(hvar, nan=1.0),
                 sel, meas, mvar, frame_at, imu_at)


def add_fixes(nodes: Nodes, t_s, x_m, y_m, sigma_m) -> Nodes:
    """Nodes with position fixes (e.g. GNSS at the surface) at the nodes nearest their times.

    A fix more than half an IMU step away from every node is dropped; the caller reports it.

    Parameters
    ----------
    nodes : Nodes
        The grid.
    t_s : float or array_like
        Fix times [s].
    x_m, y_m : float or array_like
        Fix positions [m].
    sigma_m : float or array_like
        Standard deviation of each axis [m].

    Returns
    -------
    Nodes
        A copy with the fixes.
    """
    t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
    has_fix, fix, fix_var = nodes.has_fix.copy(), nodes.fix.copy(), nodes.fix_var.copy()
    if t_s.size:
        k = np.clip(np.searchsorted(nodes.t_s, t_s), 1, len(nodes) - 1) if len(nodes) > 1 else np.zeros(t_s.size, int)
        if len(nodes) > 1:
            k = np.where(np.abs(nodes.t_s[k - 1] - t_s) <= np.abs(nodes.t_s[k] - t_s), k - 1, k)
        step = np.median(np.diff(nodes.t_s)) if len(nodes) > 1 else np.inf
        ok = np.abs(nodes.t_s[k] - t_s) <= 0.5 * step
        has_fix[k[ok]] = True
        fix[k[ok], 0] = np.asarray(x_m, dtype=float)[ok]
        fix[k[ok], 1] = np.asarray(y_m, dtype=float)[ok]
        fix_var[k[ok]] = np.broadcast_to(np.asarray(sigma_m, dtype=float) ** 2, t_s.shape)[ok]
    return replace(nodes, has_fix=has_fix, fix=fix, fix_var=fix_var)


def add_bearings(nodes: Nodes, azimuth_rad, sigma_rad) -> Nodes:
    """Nodes with the beacon's body-frame azimuth at the frames' nodes.

    Parameters
    ----------
    nodes : Nodes
        The grid.
    azimuth_rad : array_like, shape (K,)
        One azimuth [rad] per frame of the records :func:`build_nodes` was given, in that order (NaN: no
        bearing for that frame).
    sigma_rad : float or array_like, shape (K,)
        Its standard deviation [rad].

    Returns
    -------
    Nodes
        A copy with the bearings.
    """
    azimuth_rad = np.asarray(azimuth_rad, dtype=float)
    var = np.broadcast_to(np.asarray(sigma_rad, dtype=float) ** 2, azimuth_rad.shape)
    has, bearing, bearing_var = nodes.has_bearing.copy(), nodes.bearing.copy(), nodes.bearing_var.copy()
    at = np.flatnonzero(nodes.frame >= 0)
    idx = nodes.frame[at]
    ok = np.isfinite(azimuth_rad[idx]) & np.isfinite(var[idx]) & (var[idx] > 0)
    has[at[ok]] = True
    bearing[at[ok]] = azimuth_rad[idx[ok]]
    bearing_var[at[ok]] = var[idx[ok]]
    return replace(nodes, has_bearing=has, bearing=bearing, bearing_var=bearing_var)
