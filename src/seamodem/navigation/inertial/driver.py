"""The inertial filter's driver: one filter run over the nodes, and what it leaves (:class:`FilterRun`).

:func:`run_filter` converts the Cartesian start to the filter's chart, builds
the kernels' records (:func:`filter_model`, :func:`filter_settings`) and runs
:func:`~.filter.filter_nodes`; :class:`FilterRun` gives its states Cartesian
(:func:`~.charts.to_cartesian`) and keeps what the smoothers need.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import ConfigError
from .charts import to_cartesian, to_internal
from .config import WINDOW_ITERATIONS, InertialConfig
from .filter import filter_nodes
from .nodes import Nodes
from .records import FilterModel, FilterSettings

__all__ = ["FilterRun", "run_filter", "chart_nees", "filter_model", "filter_settings"]


def filter_model(config: InertialConfig, beacon_xy, *, use_range: bool = True, use_vr: bool = True,
                 qd=None) -> FilterModel:
    """The kernels' model record of a configuration.

    Parameters
    ----------
    config : InertialConfig
        The filter's configuration.
    beacon_xy : array_like, shape (2,)
        Beacon position [m].
    use_range, use_vr : bool
        Rows of the acoustic update.
    qd : ndarray, shape (n,), optional
        Process noise density [state unit²/s]; default ``config.process_density``.

    Returns
    -------
    FilterModel
    """
    return FilterModel(config.process_density if qd is None else qd, np.asarray(beacon_xy, dtype=float),
                       bool(use_range), bool(use_vr))


def filter_settings(config: InertialConfig, *, use_range: bool = True, use_vr: bool = True) -> FilterSettings:
    """The kernels' settings record of a configuration: gates, iterations, window, speed floor.

    Parameters
    ----------
    config : InertialConfig
        The filter's configuration.
    use_range, use_vr : bool
        Rows of the acoustic update (its gate and window threshold have as many degrees of freedom).

    Returns
    -------
    FilterSettings
    """
    dof = 2 if (use_vr and use_range) else 1
    window_s, window_nis = config.window(dof)
    return FilterSettings(float(config.gate[dof - 1]), float(config.gate[0]), int(config.gate_reset_after),
                          int(config.iterations), bool(config.second_order), float(window_s), float(window_nis),
                          WINDOW_ITERATIONS, float(config.speed_floor))


@dataclass(eq=False)
class FilterRun:
    """A filter pass over nodes: posterior states, covariances, and what each frame did.

    ``states`` and ``covariances`` are Cartesian (x, y, ψ, v, b, …) whatever coordinates the filter ran
    in; ``internal_states`` and ``internal_covariances`` are the filter's own (polar (ρ, β, …) when
    ``config.polar``; ``charts`` says which, per node: 0 Cartesian, 1 polar). Where a window was re-linearized
    (``windows`` > 0 at its last node, ``config.window_s``), the states of its nodes are the re-linearized pass;
    ``online_xy`` (N, 2) keeps the position each node had in real time. ``status`` per node: 0 no frame, 1 accepted, 2 gated (not used), 3 accepted after a
    run of gated frames (the gate was reset). ``nis`` per node (NaN without a frame); ``bearing_status`` and
    ``bearing_nis`` the same for the array's bearings (:func:`add_bearings`). ``history`` keeps
    what the smoothers need (priors, covariances, transition Jacobians), in the filter's coordinates.
    ``z0``, ``P0`` are the Cartesian start given to :func:`run_filter`; ``internal_z0``, ``internal_P0`` the
    same in the chart of node 0.

    Parameters
    ----------
    nodes : Nodes
        The grid the filter ran on.
    config : InertialConfig
        Its configuration.
    beacon_xy : ndarray, shape (2,)
        Beacon position [m].
    use_vr : bool
        Whether the acoustic updates used v_r.
    internal_states : ndarray, shape (N, n)
        Posterior states in the filter's charts.
    history : ndarray, shape (N, n, 3n + 1)
        Priors, covariances and transition Jacobians (:func:`~.filter.filter_nodes`).
    nis, status : ndarray, shape (N,)
        NIS and status of each node's frame.
    z0, P0, has_heading, charts, internal_z0, internal_P0, bearing_nis, bearing_status, online_xy, windows
        As described above.
    """

    nodes: Nodes
    config: InertialConfig
    beacon_xy: np.ndarray
    use_vr: bool
    internal_states: np.ndarray
    history: np.ndarray
    nis: np.ndarray
    status: np.ndarray
    z0: np.ndarray = field(repr=False, default=None)
    P0: np.ndarray = field(repr=False, default=None)
    has_heading: np.ndarray = field(repr=False, default=None)
    charts: np.ndarray = field(repr=False, default=None)
    internal_z0: np.ndarray = field(repr=False, default=None)
    internal_P0: np.ndarray = field(repr=False, default=None)
    bearing_nis: np.ndarray = field(repr=False, default=None)
    bearing_status: np.ndarray = field(repr=False, default=None)
    online_xy: np.ndarray = field(repr=False, default=None)
    windows: np.ndarray = field(repr=False, default=None)
    _cartesian: tuple = field(repr=False, default=None)

    @property
    def internal_covariances(self) -> np.ndarray:
        n = self.internal_states.shape[1]
        return np.ascontiguousarray(self.history[:, :, n + 1:2 * n + 1])

    def _cart(self):
        if self._cartesian is None:
            self._cartesian = to_cartesian(self.internal_states, self.internal_covariances, self.charts,
                                           self.beacon_xy)
        return self._cartesian

    @property
    def states(self) -> np.ndarray:
        return self._cart()[0]

    @property
    def covariances(self) -> np.ndarray:
        return self._cart()[1]

    @property
    def prior_states(self) -> np.ndarray:
        return np.ascontiguousarray(self.history[:, :, 0])

    @property
    def prior_covariances(self) -> np.ndarray:
        n = self.internal_states.shape[1]
        return np.ascontiguousarray(self.history[:, :, 1:n + 1])

    @property
    def transitions(self) -> np.ndarray:
        n = self.internal_states.shape[1]
        return np.ascontiguousarray(self.history[:, :, 2 * n + 1:3 * n + 1])


def chart_nees(run: "FilterRun", truth_xy) -> np.ndarray:
    """Position NEES (2 dof) of each node in the filter's own chart: (x, y), or (ρ, β) about the beacon.

    This is the consistency of what the filter claims. In Cartesian coordinates (``run.covariances``) the
    ellipse of a polar node is the tangent of a curved posterior and is not meant to hold the truth to σ_d
    across it.

    Parameters
    ----------
    run : FilterRun
        A filter pass.
    truth_xy : array_like, shape (N, 2)
        True position at each node [m].

    Returns
    -------
    ndarray, shape (N,)
        The normalised estimation error squared of the position, per node.
    """
    truth_xy = np.asarray(truth_xy, dtype=float)
    e = run.internal_states[:, :2].copy()
    polar = run.charts == 1
    d = truth_xy - run.beacon_xy
    e[polar, 0] -= np.hypot(d[polar, 0], d[polar, 1])
    e[polar, 1] = np.angle(np.exp(1j * (e[polar, 1] - np.arctan2(d[polar, 1], d[polar, 0]))))
    e[~polar] -= truth_xy[~polar]
    return np.einsum("ki,kij,kj->k", e, np.linalg.inv(run.internal_covariances[:, :2, :2]), e)



def run_filter(nodes: Nodes, config: InertialConfig, *, beacon_xy, z0, P0, use_vr: bool = True,
               use_range: bool = True, start_from_first_heading: bool = True, use_bearing: bool = True) -> FilterRun:
    """The inertial filter over ``nodes`` from the Cartesian (z0, P0) at node 0.

    Parameters
    ----------
    nodes : Nodes
        The grid (:func:`~.nodes.build_nodes`).
    config : InertialConfig
        The filter's configuration.
    beacon_xy : array_like, shape (2,)
        Beacon position [m].
    z0, P0 : array_like, shapes (n,), (n, n)
        Cartesian start (x, y [m], ψ [rad], v [m/s], b [rad], …) and its covariance.
    use_vr, use_range : bool
        Rows of the acoustic update.
    start_from_first_heading : bool
        (z0, P0) already hold node 0's heading reading (:meth:`InertialConfig.initial` with
        ``heading_from_sensor``), so node 0's heading update is skipped.
    use_bearing : bool
        Use the bearings on the nodes (:func:`~.nodes.add_bearings`).

    Returns
    -------
    FilterRun
        States, covariances and what each frame did.
    """
    z0 = np.array(z0, dtype=float)
    P0 = np.array(P0, dtype=float)
    n = config.n_states
    if z0.shape != (n,) or P0.shape != (n, n):
        raise ConfigError("z0", f"must have {n} states for this configuration, got shapes {z0.shape}, {P0.shape}")
    beacon = np.asarray(beacon_xy, dtype=float)
    lay = config.layout
    zi, Pi = z0.copy(), P0.copy()
    to_internal(zi, Pi, lay, beacon)
    history = np.empty((len(nodes), n, 3 * n + 1))
    has_heading = nodes.has_heading.copy()
    if start_from_first_heading:
        has_heading[0] = False
    has_bearing = nodes.has_bearing & bool(use_bearing)
    states, nis, status, charts, b_nis, b_status, online, windows = filter_nodes(
        zi, Pi, lay, filter_model(config, beacon, use_range=use_range, use_vr=use_vr),
        filter_settings(config, use_range=use_range, use_vr=use_vr),
        nodes.data(has_heading=has_heading, has_bearing=has_bearing), history)
    return FilterRun(nodes, config, beacon, use_vr, states, history, nis, status, z0, P0, has_heading, charts, zi, Pi,
                     b_nis, b_status, online_xy=online, windows=windows)
