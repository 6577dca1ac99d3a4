"""State-space models of the papers, each with analytic Jacobians.

Every model offers ``transition(x, u, dt)``, ``transition_jacobian(x, u, dt)``,
``measure(x, kind)``, ``measurement_jacobian(x, kind)`` and ``angular(kind)``,
the interface :class:`~seamodem.navigation.ekf.ExtendedKalmanFilter` and
:class:`~seamodem.navigation.particle.ParticleFilter` consume. Positions are in
a local east-north frame [m]; headings are counter-clockwise from the x axis
[rad] (paper 000 Fig. 2); ``v_r`` is the closing speed (positive when the range
decreases, SPEC §1).

A measurement *kind* names a tuple of components; each component is a scalar
function of the state with its gradient, so a kind's Jacobian is built from
rows that are each checked once.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = [
    "Auv6Model",
    "Auv4Model",
    "Auv3Model",
    "ConstantVelocityModel",
    "closing_speed",
]


def closing_speed(x, y, psi, v, beacon_xy) -> np.ndarray:
    """Radial closing speed of a vehicle moving at speed ``v`` along heading ``psi`` [m/s].

    Parameters
    ----------
    x, y : float or array_like
        Vehicle position [m] (x east, y north).
    psi : float or array_like
        Heading ψ [rad], counter-clockwise from the x axis.
    v : float or array_like
        Speed over ground [m/s].
    beacon_xy : array_like, shape (2,)
        Beacon position (x_ref, y_ref) [m].

    Returns
    -------
    numpy.ndarray
        v_r [m/s], positive when closing; the inputs' broadcast shape.

    Notes
    -----
    v_r = −v·cos(atan2(y − y_ref, x − x_ref) − ψ) (paper 000 eq 13–15 and the second
    row of eq 20; the minus sign makes it positive when the range decreases).
    """
    bearing = np.arctan2(np.asarray(y) - beacon_xy[1], np.asarray(x) - beacon_xy[0])
    return -np.asarray(v) * np.cos(bearing - np.asarray(psi))


class _PlanarModel:
    """Shared components: horizontal range and closing speed to one beacon, and state picks.

    ``ix, iy`` are the indices of the position in the state; ``ipsi`` and ``iv``
    those of heading and speed (``None`` when the heading is an input).
    """

    ix, iy, ipsi, iv = 0, 1, None, None
    n: int
    kinds: dict[str, tuple[str, ...]]

    def __init__(self, beacon_xy):
        self.beacon_xy = np.asarray(beacon_xy, dtype=float)
        if self.beacon_xy.shape != (2,) or not np.all(np.isfinite(self.beacon_xy)):
            raise ConfigError("beacon_xy", f"must be two finite coordinates [m], got {beacon_xy!r}")

    def _component(self, x, name, heading=None):
        """Value and gradient of one scalar measurement component."""
        grad = np.zeros(self.n)
        dx, dy = x[self.ix] - self.beacon_xy[0], x[self.iy] - self.beacon_xy[1]
        if name == "range":
            r = np.hypot(dx, dy)
            grad[self.ix], grad[self.iy] = dx / r, dy / r  # paper 000 eq 22–23, A·(x − x_ref)
            return r, grad
        if name == "v_r":
            r2 = dx * dx + dy * dy
            psi = x[self.ipsi] if self.ipsi is not None else heading
            v = x[self.iv]
            c = np.arctan2(dy, dx) - psi
            b = v * np.sin(c) / r2  # paper 000 eq 23, B
            grad[self.ix], grad[self.iy] = -b * dy, b * dx
            if self.ipsi is not None:
                grad[self.ipsi] = -v * np.sin(c)
            grad[self.iv] = -np.cos(c)
            return -v * np.cos(c), grad
        index = self.state_index[name]
        grad[index] = 1.0
        return x[index], grad

    def _evaluate(self, x, kind, heading=None):
        try:
            names = self.kinds[kind]
        except KeyError:
            raise ConfigError("kind", f"must be one of {sorted(self.kinds)}, got {kind!r}") from None
        parts = [self._component(np.asarray(x, dtype=float), name, heading) for name in names]
        return np.array([p[0] for p in parts]), np.array([p[1] for p in parts])

    def measure(self, x, kind) -> np.ndarray:
        """Predicted measurement of ``kind`` at state ``x``."""
        return self._evaluate(x, kind)[0]

    def measurement_jacobian(self, x, kind) -> np.ndarray:
        """Jacobian of :meth:`measure`, shape (m, n)."""
        return self._evaluate(x, kind)[1]

    def angular(self, kind) -> np.ndarray:
        """Mask of components of ``kind`` that are angles (innovation wrapped)."""
        return np.array([name in ("psi", "theta_h") for name in self.kinds[kind]], dtype=bool)


class Auv6Model(_PlanarModel):
    """Paper 000's 6-state model z = (x, y, ψ, v, Ω, a).

    Parameters
    ----------
    beacon_xy : array_like, shape (2,)
        Beacon position (x_ref, y_ref) [m].

    Notes
    -----
    Transition: eq 7 with Jacobian eq 21; the input is unused because Ω and a are
    states observed by the IMU. Measurement kinds (components in eq 18's order):

    - ``"ahrs"``: (ψ, Ω, a), eq 20 second line, Jacobian eq 24;
    - ``"com"``: (d, v_r, ψ, Ω, a), eq 20 first line. Eq 22 prints these rows in
      the order ψ, Ω, a, d, v_r and repeats the Ω row where the a row belongs; the
      rows here are derived from eq 20 and checked against numerical derivatives;
    - ``"rosb"``: (d, ψ, Ω, a), the ROSB baseline (paper 000 Table 4): no v_r;
    - ``"range"``: (d,) and ``"v_r"``: (v_r,) alone, for asynchronous streams.
    """

    n = 6
    ipsi, iv = 2, 3
    state_names = ("x", "y", "psi", "v", "omega", "a")
    state_index = {name: i for i, name in enumerate(state_names)}
    kinds = {
        "ahrs": ("psi", "omega", "a"),
        "com": ("range", "v_r", "psi", "omega", "a"),
        "rosb": ("range", "psi", "omega", "a"),
        "range": ("range",),
        "v_r": ("v_r",),
    }

    def transition(self, z, u, dt) -> np.ndarray:
        x, y, psi, v, omega, a = z
        return np.array(
            [x + v * dt * np.cos(psi), y + v * dt * np.sin(psi), psi + dt * omega, v + dt * a, omega, a]
        )

    def transition_jacobian(self, z, u, dt) -> np.ndarray:
        psi, v = z[2], z[3]
        F = np.eye(6)
        F[0, 2], F[0, 3] = -v * dt * np.sin(psi), dt * np.cos(psi)
        F[1, 2], F[1, 3] = v * dt * np.cos(psi), dt * np.sin(psi)
        F[2, 4] = dt
        F[3, 5] = dt
        return F


class Auv4Model(_PlanarModel):
    """Paper 002's 4-state model z = (x, y, θ_h, v_p).

    Parameters
    ----------
    beacon_xy : array_like, shape (2,)
        Beacon position (x_ref, y_ref) [m].

    Attributes
    ----------
    n : int
        State dimension, 4: x, y [m], heading θ_h [rad], speed v_p [m/s].
    kinds : dict
        Measurement kind → its components, in order.

    Notes
    -----
    Transition eq 4 with Jacobian eq 8 (constant heading and speed between
    steps). Kinds: ``"com"`` = (d, θ_h, v_r) (eq 5, with v_r the closing speed
    v_p·cos(θ_b − θ_h) of eq 6–7 taken positive when closing), ``"rosb"`` =
    (d, θ_h), ``"heading"`` = (θ_h,).
    """

    n = 4
    ipsi, iv = 2, 3
    state_names = ("x", "y", "theta_h", "v_p")
    state_index = {name: i for i, name in enumerate(state_names)}
    state_index["psi"] = 2
    kinds = {"com": ("range", "theta_h", "v_r"), "rosb": ("range", "theta_h"), "heading": ("theta_h",)}

    def transition(self, z, u, dt) -> np.ndarray:
        x, y, th, v = z
        return np.array([x + v * np.cos(th) * dt, y + v * np.sin(th) * dt, th, v])

    def transition_jacobian(self, z, u, dt) -> np.ndarray:
        th, v = z[2], z[3]
        F = np.eye(4)
        F[0, 2], F[0, 3] = -v * dt * np.sin(th), dt * np.cos(th)
        F[1, 2], F[1, 3] = v * dt * np.cos(th), dt * np.sin(th)
        return F


class Auv3Model(_PlanarModel):
    """Paper 003's 3-state model z = (x, y, v); the heading θ_h (compass) is the input ``u``.

    Parameters
    ----------
    beacon_xy : array_like, shape (2,)
        Beacon position (x_ref, y_ref) [m].

    Attributes
    ----------
    n : int
        State dimension, 3: x, y [m], speed v [m/s].
    kinds : dict
        Measurement kind → its components, in order.

    Notes
    -----
    Transition eq 5, Jacobian eq 7; observation eq 6 with Jacobian eq 8. Kinds
    ``"both"`` = (d, v), ``"range"`` = (d,), ``"speed"`` = (v,): the paper's
    range-only, speed-only and combined filters.
    """

    n = 3
    iv = 2
    state_names = ("x", "y", "v")
    state_index = {name: i for i, name in enumerate(state_names)}
    kinds = {"both": ("range", "v"), "range": ("range",), "speed": ("v",)}

    def transition(self, z, u, dt) -> np.ndarray:
        heading = float(np.asarray(u).reshape(-1)[0])
        return np.array([z[0] + z[2] * np.cos(heading) * dt, z[1] + z[2] * np.sin(heading) * dt, z[2]])

    def transition_jacobian(self, z, u, dt) -> np.ndarray:
        heading = float(np.asarray(u).reshape(-1)[0])
        F = np.eye(3)
        F[0, 2], F[1, 2] = dt * np.cos(heading), dt * np.sin(heading)
        return F


class ConstantVelocityModel:
    """Paper 004's constant-velocity model z = (x, y, ẋ, ẏ) with ranges to several anchors.

    Parameters
    ----------
    anchors_xy : array_like, shape (n_anchors, 2)
        Anchor positions [m] in the horizontal plane.
    accel_psd : float
        Power spectral density of the white acceleration noise [m²/s³].

    Notes
    -----
    Eq 1 restricted to the plane: slant ranges are made horizontal first with the
    known depths (eq 10, :func:`seamodem.navigation.geometry.slant_to_horizontal`).
    A measurement kind is an anchor index; each range is fused on its own as it
    arrives (eq 5–9, sequential updates).
    """

    n = 4
    state_names = ("x", "y", "vx", "vy")

    def __init__(self, anchors_xy, *, accel_psd: float = 0.01):
        self.anchors_xy = np.atleast_2d(np.asarray(anchors_xy, dtype=float))
        if self.anchors_xy.shape[1] != 2 or not np.all(np.isfinite(self.anchors_xy)):
            raise ConfigError("anchors_xy", f"must be finite (n, 2) positions [m], got shape {self.anchors_xy.shape}")
        if not accel_psd > 0:
            raise ConfigError("accel_psd", f"must be > 0 m²/s³, got {accel_psd!r}")
        self.accel_psd = float(accel_psd)

    def transition(self, z, u, dt) -> np.ndarray:
        return self.transition_jacobian(z, u, dt) @ z

    def transition_jacobian(self, z, u, dt) -> np.ndarray:
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        return F

    def process_noise(self, dt: float) -> np.ndarray:
        """Discrete white-acceleration noise covariance over ``dt`` [s]."""
        q = self.accel_psd
        block = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        Q = np.zeros((4, 4))
        Q[np.ix_([0, 2], [0, 2])] = block
        Q[np.ix_([1, 3], [1, 3])] = block
        return Q

    def measure(self, z, kind) -> np.ndarray:
        return np.array([np.hypot(*(z[:2] - self.anchors_xy[int(kind)]))])

    def measurement_jacobian(self, z, kind) -> np.ndarray:
        d = z[:2] - self.anchors_xy[int(kind)]
        H = np.zeros((1, 4))
        H[0, :2] = d / np.hypot(*d)
        return H

    def angular(self, kind) -> np.ndarray:
        return np.zeros(1, dtype=bool)
