"""The travel-time table against the tracer it is built from, both ways."""

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.water import SoundSpeedProfile
from seamodem.water.rays import RayTracer
from seamodem.water.table import TravelTimeTable

THERMOCLINE = SoundSpeedProfile([0.0, 15.0, 35.0], [1530.0, 1530.0, 1490.0])


@pytest.fixture(scope="module")
def table():
    tracer = RayTracer(THERMOCLINE, water_depth_m=60.0)
    return tracer, TravelTimeTable(tracer, 25.0, np.arange(2.0, 8.01, 0.5), np.arange(40.0, 1100.1, 10.0))


def test_between_the_nodes_the_table_is_the_tracer(table):
    tracer, tab = table
    rng = np.random.default_rng(3)
    z, r = rng.uniform(2.0, 8.0, 12), rng.uniform(50.0, 1000.0, 12)
    exact = np.array([tracer.eigenrays(25.0, zi, ri)[0].travel_time_s for zi, ri in zip(z, r)])
    # Hermite with exact slopes on 10 m × 0.5 m cells: measured ≈ 6 ns; 50 ns is 75 µm of range
    np.testing.assert_allclose(tab.travel_time(z, r), exact, rtol=0, atol=5e-8)
    # and back: the range whose travel time is the tracer's, to 0.1 mm (measured 10 µm)
    np.testing.assert_allclose(tab.horizontal_range(z, exact), r, rtol=0, atol=1e-4)


def test_off_the_table_is_nan(table):
    _, tab = table
    assert np.isnan(tab.travel_time(5.0, 2000.0)) and np.isnan(tab.travel_time(20.0, 500.0))
    assert np.isnan(tab.horizontal_range(5.0, 10.0))


def test_a_reflected_path_and_a_single_depth():
    tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=40.0)
    ranges = np.arange(100.0, 301.0, 10.0)
    tab = TravelTimeTable(tracer, 25.0, [5.0], ranges, path="surface")
    np.testing.assert_allclose(tab.time_s[0], np.hypot(ranges, 30.0) / 1500.0, rtol=0, atol=1e-12)
    # between nodes 10 m apart the cubic Hermite error bound h^4 max(d4t/dR4) / 384 is 1.8 ns here (2.7 µm of range)
    assert float(tab.travel_time(5.0, 155.0)) == pytest.approx(np.hypot(155.0, 30.0) / 1500.0, abs=2e-9)


def test_grids_must_increase():
    tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=40.0)
    with pytest.raises(ConfigError, match="increase"):
        TravelTimeTable(tracer, 25.0, [5.0, 4.0], [100.0, 200.0])
    with pytest.raises(ConfigError, match="positive"):
        TravelTimeTable(tracer, 25.0, [5.0], [0.0, 200.0])
