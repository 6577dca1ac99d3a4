"""[water] in a geometry scenario: the paths are traced rays, delays and per-path Doppler from the rays."""

import numpy as np
import pytest

from seamodem.channel.model import GeometryModel, RayTracedModel, build_model
from seamodem.channel.scenario import load_scenario, parse_scenario
from seamodem.errors import ConfigError
from seamodem.water import RayTracer, SoundSpeedProfile

THERMOCLINE = {"depth_m": [0.0, 15.0, 35.0], "c_mps": [1530.0, 1530.0, 1490.0]}


def _scenario(water, *, c=1500.0):
    return parse_scenario({
        "mode": "geometry",
        "environment": {"sound_speed_mps": c, "water_depth_m": 60.0},
        "beacon": {"position_m": [0.0, 0.0, -25.0]},
        "vehicle": {"start_m": [100.0, 30.0, -5.0], "velocity_mps": [1.5, 0.0, -0.1]},
        "multipath": {"max_bounces": 1},
        "water": water,
    })


def test_the_delays_are_the_traced_rays():
    model = build_model(_scenario(THERMOCLINE), reference_frequency_hz=28e3)
    assert isinstance(model, RayTracedModel) and [p.name for p in model.paths] == ["direct", "S", "B"]
    t = np.array([0.0, 20.0, 40.0])
    model.check_span(0.0, 40.0)
    tau = model.delays(t)
    tracer = RayTracer(SoundSpeedProfile(**THERMOCLINE), water_depth_m=60.0)
    for k, tk in enumerate(t):
        x, y, z = 100.0 + 1.5 * tk, 30.0, -5.0 - 0.1 * tk
        rays = {r.name: r.travel_time_s for r in tracer.eigenrays(25.0, -z, np.hypot(x, y), max_vertices=1)}
        # the table (1 m × 0.5 m cells, Hermite with exact slopes) against the tracer: nanoseconds
        np.testing.assert_allclose(tau[:, k], [rays["direct"], rays["surface"], rays["bottom"]], rtol=0, atol=5e-9)


def test_each_path_s_doppler_follows_its_ray_angles():
    model = build_model(_scenario(THERMOCLINE), reference_frequency_hz=28e3)
    model.check_span(0.0, 20.0)
    h, t = 1e-3, 10.0
    rate = (model.delays([t + h]) - model.delays([t - h]))[:, 0] / (2 * h)  # dτ/dt of each path
    tracer = RayTracer(SoundSpeedProfile(**THERMOCLINE), water_depth_m=60.0)
    x, y, z = 100.0 + 1.5 * t, 30.0, 5.0 + 0.1 * t
    r = np.hypot(x, y)
    for path, name in zip(range(3), ("direct", "surface", "bottom")):
        ray = next(e for e in tracer.eigenrays(25.0, z, r, max_vertices=1) if e.name == name)
        # dτ/dt = ∂t/∂R · dR/dt + ∂t/∂z · dz/dt: p cos(bearing) · 1.5 m/s + vertical slowness · 0.1 m/s
        expected = ray.dt_drange_spm * 1.5 * x / r + ray.dt_dreceiver_depth_spm * 0.1
        assert rate[path] == pytest.approx(expected, abs=1e-9), name
    assert len(set(np.round(rate, 9))) == 3  # three rays, three Dopplers


def test_isovelocity_water_gives_the_image_model():
    iso = build_model(_scenario({"depth_m": [0.0], "c_mps": [1500.0]}), reference_frequency_hz=28e3)
    images = GeometryModel(_scenario({"depth_m": [0.0], "c_mps": [1500.0]}),
                           reference_frequency_hz=28e3)
    t = np.linspace(0.0, 30.0, 7)
    iso.check_span(0.0, 30.0)
    np.testing.assert_allclose(iso.delays(t), images.delays(t), rtol=0, atol=1e-9)


def test_a_cast_file_relative_to_the_scenario(tmp_path):
    (tmp_path / "ctd.csv").write_text("depth_m,temperature_c,salinity_psu\n0,20,36\n15,20,36\n35,14,36\n60,13,36\n")
    (tmp_path / "s.toml").write_text(
        'mode = "geometry"\n[environment]\nwater_depth_m = 60.0\n[beacon]\nposition_m = [0.0, 0.0, -25.0]\n'
        '[vehicle]\nstart_m = [100.0, 0.0, -5.0]\nvelocity_mps = [1.0, 0.0, 0.0]\n[water]\nprofile = "ctd.csv"\n')
    model = build_model(load_scenario(tmp_path / "s.toml"), reference_frequency_hz=28e3)
    assert model.profile.c(0.0) > model.profile.c(40.0) + 15  # 20 °C over 13 °C: about 20 m/s faster


@pytest.mark.parametrize("water, words", [
    ({}, "either profile"),
    ({"depth_m": [0.0, 10.0]}, "either profile"),
    ({"depth_m": [0.0, 10.0, 5.0], "c_mps": [1500.0, 1500.0, 1500.0]}, "increase strictly"),
])
def test_bad_water_tables(water, words):
    with pytest.raises(ConfigError, match=words):
        _scenario(water)


def test_a_missing_cast_names_the_key_and_the_file(tmp_path):
    (tmp_path / "s.toml").write_text(
        'mode = "geometry"\n[environment]\nwater_depth_m = 60.0\n[beacon]\nposition_m = [0.0, 0.0, -25.0]\n'
        '[vehicle]\nstart_m = [100.0, 0.0, -5.0]\nvelocity_mps = [1.0, 0.0, 0.0]\n[water]\nprofile = "nope.csv"\n')
    with pytest.raises(ConfigError, match="water.profile: .*nope.csv: no such"):
        build_model(load_scenario(tmp_path / "s.toml"), reference_frequency_hz=28e3)
