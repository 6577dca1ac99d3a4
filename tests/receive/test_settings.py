"""ReceiverSettings and Emissions: validated on construction, and the clock arithmetic batch relies on."""

import dataclasses
import math

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.receive import Emissions, ReceiverSettings


@pytest.mark.parametrize(
    "field, value",
    [
        ("sound_speed_mps", 0.0),
        ("sound_speed_mps", math.nan),
        ("v_max_mps", -1.0),
        ("false_alarms_per_hour", 0.0),
        ("clock_offset_s", math.inf),
        ("turnaround_s", -0.1),
        ("turbo_passes", 0),
        ("turbo_passes", 2.0),
        ("decode", "yes"),
        ("follow_track", 1),
    ],
)
def test_a_bad_setting_is_a_config_error_naming_it(field, value):
    with pytest.raises(ConfigError) as err:
        ReceiverSettings(**{field: value})
    # the message names the parameter (without its unit suffix) and the value given
    assert str(err.value).startswith(field.removesuffix("_mps").removesuffix("_s")) and repr(value) in str(err.value)


def test_settings_are_frozen_keyword_only_and_round_trip_through_a_dict():
    s = ReceiverSettings(sound_speed_mps=1480.0, turnaround_s=0.5, decode=True)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.v_max_mps = 3.0
    with pytest.raises(TypeError):
        ReceiverSettings(1480.0)
    assert ReceiverSettings(**s.to_dict()) == s and s.two_way and not ReceiverSettings().two_way


@pytest.mark.parametrize(
    "emissions", [Emissions(start_s=0.5, period_s=3.0), Emissions(times_s=np.array([0.5, 3.5, 6.5, 9.5]))]
)
def test_shifted_emissions_name_the_same_frames_on_a_segment_clock(emissions):
    t0 = 4.25
    shifted = emissions.shifted(t0)
    for t in (0.6, 3.49, 3.5, 7.0, 9.9):
        k, t_emit = emissions.frame_for(t)
        k2, t_emit2 = shifted.frame_for(t - t0)
        assert k == k2 and t_emit == pytest.approx(t_emit2 + t0, abs=1e-12)
        assert emissions.time_of(k) == t_emit
    assert emissions.frame_for(0.4) == (-1, emissions.frame_for(0.4)[1]) and math.isnan(emissions.time_of(-1))
    assert emissions.shifted(0) is emissions
