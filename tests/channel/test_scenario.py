import math
from pathlib import Path

import numpy as np
import pytest

from seamodem.channel import build_model, load_scenario, parse_scenario
from seamodem.errors import ConfigError, InputFileError

EXAMPLES = sorted((Path(__file__).parents[2] / "examples" / "scenarios").glob("*.toml"))

GEOMETRY = {
    "mode": "geometry",
    "environment": {"sound_speed_mps": 1500.0, "water_depth_m": 20.0},
    "beacon": {"position_m": [0.0, 0.0, -5.0]},
    "vehicle": {"start_m": [100.0, 0.0, -5.0], "velocity_mps": [-1.0, 0.0, 0.0]},
}


def with_(base, section, **values):
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    if section is None:
        data.update(values)
    else:
        data.setdefault(section, {}).update(values)
    return data


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_example_scenarios_load(path):
    scenario = load_scenario(path)
    assert scenario.mode in ("geometry", "profile", "replay")
    assert scenario.to_dict()["mode"] == scenario.mode


def test_examples_cover_every_mode():
    assert {load_scenario(p).mode for p in EXAMPLES} == {"geometry", "profile", "replay"}


def test_mackenzie_default_sound_speed():
    s = parse_scenario(with_(GEOMETRY, "environment", sound_speed_mps=None, temperature_c=27.0, salinity_ppt=35.0,
                             sound_speed_depth_m=10.0))
    assert s.sound_speed_mps == pytest.approx(1539.09, abs=5e-3)


BAD = [
    (with_(GEOMETRY, "environment", water_depth_m=-5.0), "environment.water_depth_m"),
    (with_(GEOMETRY, "vehicle", start_m=[100.0, 0.0, 2.0]), "vehicle.start_m"),  # above the surface (z up)
    (with_(GEOMETRY, "vehicle", start_m=[100.0, 0.0, -25.0]), "vehicle.start_m"),  # below the bottom
    (with_(GEOMETRY, "beacon", position_m=[0.0, 0.0, 1.0]), "beacon.position_m"),
    (with_(GEOMETRY, "vehicle", velocity_mps=[1500.0, 0.0, 0.0]), "vehicle.velocity_mps"),
    (with_(GEOMETRY, "environment", temprature_c=12.0), "environment.temprature_c"),
    (with_(GEOMETRY, None, colour="blue"), "colour"),
    (with_(GEOMETRY, "noise", kind="pink"), "noise.kind"),
    (with_(GEOMETRY, "noise", kind="white"), "noise.snr_db"),
    (with_(GEOMETRY, "multipath", bottom_reflection=1.5), "multipath.bottom_reflection"),
    (with_(GEOMETRY, "vehicle", waypoints_m=[[0, 0, -1], [1, 1, -1]]), "vehicle"),
    ({"mode": "geometry", "environment": {"water_depth_m": 10.0}}, "beacon"),
    ({"mode": "sideways"}, "mode"),
    ({"mode": "profile", "doppler": {"components": [{"kind": "constant", "v_mps": 1.0, "speed": 2}]}},
     r"doppler.components\[0\].speed"),
    ({"mode": "profile", "doppler": {"components": [{"kind": "ramp", "v0_mps": 0, "v1_mps": 1, "t0_s": 2, "t1_s": 1}]}},
     r"doppler.components\[0\].t1_s"),
    ({"mode": "profile", "doppler": {"components": [{"kind": "constant", "v_mps": 1.0}]},
      "multipath": {"paths": [{"delay_s": -0.001, "gain": 0.5}]}}, r"multipath.paths\[0\].delay_s"),
]


@pytest.mark.parametrize("data,name", BAD, ids=[b[1] for b in BAD])
def test_bad_scenarios_name_the_key(data, name):
    with pytest.raises(ConfigError, match=f"^{name}") as info:
        parse_scenario(data)
    assert "\n" not in str(info.value)


def test_trajectory_leaving_the_water_during_the_recording():
    s = parse_scenario(with_(GEOMETRY, "vehicle", velocity_mps=[0.0, 0.0, 1.0]))  # rises 1 m/s from z = -5 m
    model = build_model(s, reference_frequency_hz=28e3)
    model.check_span(0.0, 4.0)
    with pytest.raises(ConfigError, match="above the surface"):
        model.check_span(0.0, 6.0)


def test_profile_speed_reaching_c_during_the_recording():
    s = parse_scenario({"mode": "profile", "doppler": {"components": [
        {"kind": "ramp", "v0_mps": 0.0, "v1_mps": 2000.0, "t0_s": 0.0, "t1_s": 100.0}]}})
    with pytest.raises(ConfigError, match="sound speed"):
        build_model(s, reference_frequency_hz=28e3).check_span(0.0, 10.0)


def test_track_file(tmp_path):
    (tmp_path / "track.csv").write_text("t_s,x_m,y_m,z_m\n0,0,0,-3\n5,5,0,-3\n10,10,1,-4\n")
    data = with_(GEOMETRY, "vehicle", start_m=None, velocity_mps=None, track_file="track.csv")
    data["vehicle"] = {"track_file": "track.csv"}
    (tmp_path / "s.toml").write_text("")
    s = parse_scenario(data, base_dir=tmp_path)
    model = build_model(s, reference_frequency_hz=28e3)
    assert model.trajectory.position(np.array([5.0]))[:, 0] == pytest.approx([5.0, 0.0, -3.0])
    model.check_span(0.0, 10.0)
    with pytest.raises(ConfigError, match="track_file"):
        model.check_span(0.0, 12.0)
    data["vehicle"] = {"track_file": "missing.csv"}
    with pytest.raises(InputFileError, match="missing.csv"):
        build_model(parse_scenario(data, base_dir=tmp_path), reference_frequency_hz=28e3)


def test_unknown_file_and_bad_toml(tmp_path):
    with pytest.raises(InputFileError, match="not found"):
        load_scenario(tmp_path / "nope.toml")
    (tmp_path / "bad.toml").write_text("mode = \n")
    with pytest.raises(InputFileError, match="not valid TOML"):
        load_scenario(tmp_path / "bad.toml")


def test_infinite_k_factor_round_trips_to_json():
    s = parse_scenario(with_(GEOMETRY, "fluctuation", doppler_spread_hz=1.0, direct_k_db=math.inf))
    assert s.to_dict()["fluctuation"]["direct_k_db"] == "inf"
