import numpy as np
import pytest

from seamodem.channel import (
    absorption_gain,
    rough_surface_gain,
    sound_speed_mackenzie,
    spreading_gain,
    thorp_absorption_db_per_km,
)


def test_mackenzie_published_check_value():
    # Mackenzie (1981) gives c(25 °C, 35 ‰, 1000 m) = 1550.744 m/s, to the mm/s
    assert sound_speed_mackenzie(25.0, 35.0, 1000.0) == pytest.approx(1550.744, abs=5e-4)


def test_mackenzie_spec_check_value():
    # SPEC §6 quotes c(27 °C, 35 ‰, 10 m) = 1539.09 m/s (two decimals)
    assert sound_speed_mackenzie(27.0, 35.0, 10.0) == pytest.approx(1539.09, abs=5e-3)


def test_mackenzie_vectorised_and_monotonic_in_temperature():
    c = sound_speed_mackenzie(np.array([5.0, 10.0, 20.0]), 35.0, 10.0)
    assert c.shape == (3,) and np.all(np.diff(c) > 0)


def test_thorp_spec_value_and_low_frequency_limit():
    assert thorp_absorption_db_per_km(28e3) == pytest.approx(7.39, abs=5e-3)  # SPEC §6, two decimals
    assert thorp_absorption_db_per_km(0.0) == pytest.approx(0.003)  # the formula's constant term


def test_losses():
    assert spreading_gain(100.0, 2.0) == pytest.approx(0.01)  # spherical: amplitude 1/r
    assert spreading_gain(100.0, 1.0) == pytest.approx(0.1)  # cylindrical: 1/sqrt(r)
    assert 20 * np.log10(absorption_gain(1000.0, 7.39)) == pytest.approx(-7.39)
    assert rough_surface_gain(28e3, 0.0, 0.5, 1500.0) == 1.0
    k = 2 * np.pi * 28e3 / 1500.0
    assert rough_surface_gain(28e3, 0.01, 0.3, 1500.0) == pytest.approx(np.exp(-2 * (k * 0.01 * 0.3) ** 2))
