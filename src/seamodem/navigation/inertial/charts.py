"""The two charts of the position: Cartesian (x, y) and polar (ρ, β) about the beacon.

By default the filter carries the position as (ρ, β), horizontal distance and
bearing from the beacon, and switches to (x, y) only near the beacon (where a
Gaussian in (ρ, β) is no better than one in (x, y)): with centimetre ranges the
posterior is a thin arc of the range circle, which a Gaussian in (ρ, β) is and
a Cartesian ellipse is not. ``lay[4]`` of the state layout
(:attr:`~seamodem.navigation.inertial.config.InertialConfig.layout`) is the
chart a state is in (0 Cartesian, 1 polar); ``lay[3]`` is 1 when the polar
chart may be used at all.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["POLAR_ENTER", "POLAR_LEAVE", "wrap", "polar_jacobian", "cartesian", "convert_chart", "choose_chart",
           "to_internal", "to_cartesian"]

#: The polar chart is used while the position's standard deviation is below ρ/POLAR_ENTER (angular spread
#: 0.2 rad) and left above ρ/POLAR_LEAVE: near the beacon, where a Gaussian in (ρ, β) is no better than a
#: Gaussian in (x, y), the filter works in Cartesian states.
POLAR_ENTER = 5.0
POLAR_LEAVE = 4.0


@njit(cache=True, nogil=True)
def wrap(angle):
    """An angle wrapped to [−π, π].

    Parameters
    ----------
    angle : float
        Angle [rad].

    Returns
    -------
    float
        ``atan2(sin angle, cos angle)`` [rad].
    """
    return np.arctan2(np.sin(angle), np.cos(angle))


@njit(cache=True, nogil=True)
def polar_jacobian(rho, cos_beta, sin_beta):
    """J = ∂(x, y)/∂(ρ, β) of (x, y) = beacon + ρ (cos β, sin β).

    Callable from Python with arrays too (elementwise): :func:`to_cartesian` uses it for every polar node.

    Parameters
    ----------
    rho : float or ndarray
        Horizontal distance from the beacon [m].
    cos_beta, sin_beta : float or ndarray
        cos β and sin β of the bearing β from the beacon (computed once by the caller).

    Returns
    -------
    j00, j01, j10, j11 : float or ndarray
        ∂x/∂ρ = cos β, ∂x/∂β = −ρ sin β [m/rad], ∂y/∂ρ = sin β, ∂y/∂β = ρ cos β [m/rad].
    """
    return cos_beta, -rho * sin_beta, sin_beta, rho * cos_beta


@njit(cache=True, nogil=True)
def cartesian(z, lay, beacon):
    """(x, y) of a state in either chart.

    Parameters
    ----------
    z : ndarray, shape (n,)
        State in the chart ``lay[4]``.
    lay : ndarray, shape (5,), int64
        State layout and chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].

    Returns
    -------
    x, y : float
        Position [m].
    """
    if lay[4] == 0:
        return z[0], z[1]
    return beacon[0] + z[0] * np.cos(z[1]), beacon[1] + z[0] * np.sin(z[1])


@njit(cache=True, nogil=True)
def convert_chart(z, P, lay, beacon, chart, F):
    """Move state and covariance to ``chart`` (0 Cartesian, 1 polar) in place, and F ← J F (J its Jacobian).

    ``lay[4]`` is the current chart and is updated. First order in the covariance.

    Parameters
    ----------
    z : ndarray, shape (n,)
        State, changed in place.
    P : ndarray, shape (n, n)
        Covariance, changed in place.
    lay : ndarray, shape (5,), int64
        State layout; ``lay[4]`` set to ``chart``.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    chart : int
        Target chart, 0 Cartesian or 1 polar.
    F : ndarray, shape (2 or n, n)
        Its first two rows are multiplied by the change of coordinates' Jacobian.

    Returns
    -------
    None
    """
    if lay[4] == chart:
        return
    n = z.shape[0]
    if chart == 1:
        dx, dy = z[0] - beacon[0], z[1] - beacon[1]
        rho = max(np.sqrt(dx * dx + dy * dy), 1e-9)
        ux, uy = dx / rho, dy / rho
        z[0], z[1] = rho, np.arctan2(dy, dx)
        # J = ∂(ρ, β)/∂(x, y)
        j00, j01, j10, j11 = ux, uy, -uy / rho, ux / rho
    else:
        rho, beta = z[0], z[1]
        cb, sb = np.cos(beta), np.sin(beta)
        z[0], z[1] = beacon[0] + rho * cb, beacon[1] + rho * sb
        j00, j01, j10, j11 = polar_jacobian(rho, cb, sb)
    for k in range(n):
        a, b = P[0, k], P[1, k]
        P[0, k], P[1, k] = j00 * a + j01 * b, j10 * a + j11 * b
        a, b = F[0, k], F[1, k]
        F[0, k], F[1, k] = j00 * a + j01 * b, j10 * a + j11 * b
    for k in range(n):
        a, b = P[k, 0], P[k, 1]
        P[k, 0], P[k, 1] = j00 * a + j01 * b, j10 * a + j11 * b
    lay[4] = chart


@njit(cache=True, nogil=True)
def choose_chart(z, P, lay, beacon, F):
    """Switch chart by the position spread against the distance to the beacon (:data:`POLAR_ENTER`).

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        State and covariance, converted in place when the chart changes.
    lay : ndarray, shape (5,), int64
        State layout; ``lay[3]`` 0 keeps the Cartesian chart, ``lay[4]`` is the current chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].
    F : ndarray, shape (2 or n, n)
        Multiplied by the change of coordinates' Jacobian when the chart changes.

    Returns
    -------
    None
    """
    if lay[3] == 0:
        return
    if lay[4] == 1:
        rho = z[0]
        var = P[0, 0] + rho * rho * P[1, 1]
        if rho <= 0.0 or var * POLAR_LEAVE * POLAR_LEAVE > rho * rho:
            convert_chart(z, P, lay, beacon, np.int8(0), F)  # int8 as charts[i]: one compile
    else:
        dx, dy = z[0] - beacon[0], z[1] - beacon[1]
        if (P[0, 0] + P[1, 1]) * POLAR_ENTER * POLAR_ENTER < dx * dx + dy * dy:
            convert_chart(z, P, lay, beacon, np.int8(1), F)


@njit(cache=True, nogil=True)
def to_internal(z, P, lay, beacon):
    """A Cartesian (x, y, …) state and covariance to the chart the filter starts in, in place.

    Parameters
    ----------
    z, P : ndarray, shapes (n,), (n, n)
        Cartesian state and covariance, converted in place.
    lay : ndarray, shape (5,), int64
        State layout; ``lay[4]`` is set to the chosen chart.
    beacon : ndarray, shape (2,)
        Beacon position [m].

    Returns
    -------
    None
    """
    n = z.shape[0]
    lay[4] = 0
    choose_chart(z, P, lay, beacon, np.zeros((2, n)))


def to_cartesian(states, covariances, charts, beacon_xy):
    """States and covariances in the filter's charts → Cartesian (x, y, …) copies.

    Polar states map to x = x_b + ρ cos β, y = y_b + ρ sin β, their covariances by the Jacobian
    T = diag(:func:`polar_jacobian`, I) (first order: the ellipse of a curved posterior).

    Parameters
    ----------
    states : array_like, shape (N, n)
        States, node k in chart ``charts[k]``.
    covariances : array_like, shape (N, n, n)
        Their covariances.
    charts : ndarray, shape (N,), or None
        1 where a node's state is polar (ρ [m], β [rad]); None: all Cartesian.
    beacon_xy : array_like, shape (2,)
        Beacon position [m].

    Returns
    -------
    states : ndarray, shape (N, n)
        Cartesian states (x, y [m], …).
    covariances : ndarray, shape (N, n, n)
        Their covariances.
    """
    states = np.array(states, dtype=float)
    covariances = np.array(covariances, dtype=float)
    if charts is None or not np.any(charts):
        return states, covariances
    k = np.flatnonzero(charts == 1)
    b = np.asarray(beacon_xy, dtype=float)
    rho, beta = states[k, 0].copy(), states[k, 1].copy()
    cb, sb = np.cos(beta), np.sin(beta)
    states[k, 0] = b[0] + rho * cb
    states[k, 1] = b[1] + rho * sb
    J = np.zeros((k.size, 2, 2))
    J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1] = polar_jacobian(rho, cb, sb)
    c = covariances[k]
    c[:, :2, :] = np.einsum("kij,kjm->kim", J, c[:, :2, :])
    c[:, :, :2] = np.einsum("kmj,kij->kmi", c[:, :, :2], J)
    covariances[k] = c
    return states, covariances
