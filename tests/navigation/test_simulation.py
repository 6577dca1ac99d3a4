"""Trajectories, controller, vehicle model and geometry against closed forms."""

import numpy as np
import pytest

from seamodem.navigation.geometry import geodetic_to_local, local_to_geodetic, slant_to_horizontal
from seamodem.navigation.trajectories import Lemniscate, boustrophedon, waypoint_path
from seamodem.navigation.vehicle import feedback_command, vehicle_step


def test_boustrophedon_matches_table2():
    path = boustrophedon()
    assert path.length_m == pytest.approx(1567.0, abs=0.1)  # paper 000 §4.1.1: 1567 m
    assert path.duration_s == pytest.approx(1550.0, abs=0.1)  # Table 2: 1550 s
    s = path.sample(np.arange(0, path.duration_s, 0.5))
    assert s.position[:, 0].min() == pytest.approx(0) and s.position[:, 0].max() == pytest.approx(100)
    # Constant speed on the path (1567/1550 m/s), up to the last sample.
    np.testing.assert_allclose(np.hypot(*s.velocity.T), 1567.0796 / 1550.0787, rtol=1e-6)


@pytest.mark.parametrize(
    "path, t",
    [
        (boustrophedon(), np.linspace(200, 400, 299)),
        (Lemniscate(), np.linspace(0.3, 11.7, 200)),
        (waypoint_path([[0, 0], [10, 0], [10, 5]], 1.0), np.linspace(0.5, 14.5, 200)),
    ],
    ids=["boustrophedon", "lemniscate", "waypoints"],
)
def test_path_derivatives_match_finite_differences(path, t):
    h = 1e-4
    s, sp, sm = path.sample(t), path.sample(t + h), path.sample(t - h)
    # Central differences, error O(h²·jerk) ≈ 1e-8; away from segment joins where derivatives jump.
    ok = np.all(np.abs(sp.acceleration - sm.acceleration) < 1e-3, axis=1)
    np.testing.assert_allclose(((sp.position - sm.position) / (2 * h))[ok], s.velocity[ok], atol=1e-6)
    np.testing.assert_allclose(((sp.velocity - sm.velocity) / (2 * h))[ok], s.acceleration[ok], atol=1e-6)


def test_lemniscate_is_paper003_eq2():
    t = np.linspace(0, 12, 61)
    s = Lemniscate(a_m=0.6, omega_rad_s=1.0).sample(t)
    np.testing.assert_allclose(s.position[:, 0], 0.6 * np.sin(t) / (1 + np.cos(t) ** 2), atol=1e-15)
    np.testing.assert_allclose(s.position[:, 1], 0.6 * np.sin(t) * np.cos(t) / (1 + np.cos(t) ** 2), atol=1e-15)


def test_controller_zero_on_path_and_converges():
    # On a straight path at the desired speed, the command of eq 2 is zero.
    om, a = feedback_command(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.1, 1.0, 1.0)
    assert om == 0.0 and a == 0.0
    # Starting 5 m off a straight line, the closed loop (eq 2–4) converges to it.
    path = waypoint_path([[0, 0], [400, 0]], 1.0)
    x, y, psi, v = 0.0, 5.0, 0.0, 1.0
    dt = 0.05
    for k in range(4000):
        s = path.sample(np.array([k * dt]))
        om, a = feedback_command(x, y, psi, v, *s.position[0], *s.velocity[0], *s.acceleration[0], 0.1, 1.0, 1.0)
        x, y, psi, v = vehicle_step(x, y, psi, v, om, a, dt, 0.1, 3.0)
    # Critically damped at 1 rad/s: after 200 s the error is e^-200-small; 1 cm covers the Euler steps.
    assert abs(y) < 0.01 and abs(x - 200.0) < 0.01


def test_slant_to_horizontal_and_geodetic():
    assert slant_to_horizontal(5.0, 10.0, 6.0) == pytest.approx(3.0)  # 3-4-5 triangle
    assert slant_to_horizontal(1.0, 10.0, 0.0) == 0.0  # shorter than the depth difference
    east, north = geodetic_to_local(48.39243, -4.407295, 48.38243, -4.407295)
    # WGS-84 meridian arc M(φ)·Δφ at the mean latitude (was the sphere's a·Δφ = 1113.19 m before issue 12);
    # east is 0 up to the float64 rounding of Earth-centred coordinates (~1e-9 m).
    assert north == pytest.approx(1111.97854, abs=1e-4) and east == pytest.approx(0.0, abs=1e-9)
    lat, lon = local_to_geodetic(*geodetic_to_local(48.4, -4.3, 48.38243, -4.407295), 48.38243, -4.407295)
    assert lat == pytest.approx(48.4, abs=1e-12) and lon == pytest.approx(-4.3, abs=1e-12)
