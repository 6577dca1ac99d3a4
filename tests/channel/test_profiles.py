import numpy as np
import pytest
from scipy.integrate import quad

from seamodem.channel import ConstantProfile, RampProfile, SampledProfile, SinusoidalProfile, SumProfile
from seamodem.errors import ConfigError

PROFILES = [
    ConstantProfile(1.3),
    RampProfile(-0.5, 2.0, 1.0, 4.0),
    SinusoidalProfile(0.3, 0.125, 0.7),
    SampledProfile(np.array([-1.0, 0.5, 2.0, 6.0]), np.array([0.2, -0.4, 1.0, 0.1])),
    SumProfile([ConstantProfile(1.0), ConstantProfile(-0.05, label="drift"), SinusoidalProfile(0.2, 0.1)]),
]


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: type(p).__name__)
def test_displacement_is_the_integral_of_speed(profile):
    # independent answer: adaptive quadrature of speed(t) from 0 (breakpoints given for the piecewise ones)
    for t in (-2.0, 0.0, 0.7, 3.3, 8.0):
        ref, _ = quad(lambda u: float(profile.speed(np.array([u]))[0]), 0.0, t, limit=200, points=None)
        assert profile.displacement(np.array([t]))[0] == pytest.approx(ref, abs=1e-9)


def test_bad_profiles():
    with pytest.raises(ConfigError, match="t1_s"):
        RampProfile(0.0, 1.0, 2.0, 1.0)
    with pytest.raises(ConfigError, match="frequency_hz"):
        SinusoidalProfile(1.0, 0.0)
    with pytest.raises(ConfigError, match="t_s"):
        SampledProfile(np.array([0.0, 0.0]), np.array([1.0, 2.0]))
