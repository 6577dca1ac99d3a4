"""The ray tracer against closed forms: straight rays and images in isovelocity water, circular arcs in a linear gradient."""

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.water import SoundSpeedProfile
from seamodem.water.closed_form import linear_gradient_arc
from seamodem.water.rays import RayTracer

RANGES = [50.0, 200.0, 1000.0, 2000.0]


@pytest.mark.parametrize("c0, g, depth, zs, zr", [
    (1500.0, 0.05, 200.0, 60.0, 20.0),    # rays bend up; at 2 km the arc turns below the source
    (1520.0, -0.02, 200.0, 100.0, 50.0),  # rays bend down
    (1500.0, 0.017, 500.0, 300.0, 10.0),  # the deep isothermal gradient (pressure alone)
])
def test_linear_gradient_direct_ray_is_the_circular_arc(c0, g, depth, zs, zr):
    tracer = RayTracer(SoundSpeedProfile.linear(c0, g, depth), water_depth_m=depth)
    for r in RANGES:
        ray = tracer.eigenrays(zs, zr, r)[0]
        t, launch, arrival = linear_gradient_arc(c0, g, zs, zr, r)
        assert ray.name == "direct"
        # the bounds are 1 µs and 0.01°; the closed-form layer integrals do far better: 1 ns and 1e-9°
        assert abs(ray.travel_time_s - t) < 1e-9, r
        assert abs(np.degrees(ray.launch_angle_rad - launch)) < 1e-9, r
        assert abs(np.degrees(ray.arrival_angle_rad - arrival)) < 1e-9, r


def test_isovelocity_rays_are_the_image_sources():
    c, depth, zs, zr = 1500.0, 40.0, 25.0, 5.0
    tracer = RayTracer(SoundSpeedProfile.isovelocity(c), water_depth_m=depth)
    for r in RANGES:
        rays = {ray.name: ray for ray in tracer.eigenrays(zs, zr, r)}
        images = {"direct": zr - zs, "surface": zr + zs, "bottom": 2 * depth - zs - zr,
                  "surface-bottom": 2 * depth + zs - zr, "bottom-surface": 2 * depth - zs + zr}
        assert set(rays) == set(images)
        for name, dz in images.items():
            # 10 ps: the launch angle is found to rounding, which a grazing ray's run R ≈ Δz / tan θ magnifies
            assert rays[name].travel_time_s == pytest.approx(np.hypot(r, dz) / c, abs=1e-11), (name, r)
            # the launch and arrival angles: the straight line to the image, reflected at each bounce
            assert abs(rays[name].ray_parameter_spm - r / np.hypot(r, dz) / c) < 1e-15
        assert rays["surface"].n_surface == 1 and rays["bottom"].n_bottom == 1 and rays["surface"].launch_angle_rad < 0


def test_travel_time_derivatives_match_finite_differences():
    prof = SoundSpeedProfile([0.0, 15.0, 35.0, 60.0], [1530.0, 1530.0, 1490.0, 1491.0])
    tracer = RayTracer(prof, water_depth_m=60.0)
    zs, zr, r, h = 25.0, 5.0, 400.0, 1e-3

    def times(zs_, zr_, r_):
        return {ray.name: ray.travel_time_s for ray in tracer.eigenrays(zs_, zr_, r_)}

    steps = {"dt_drange_spm": np.array([0, 0, h]), "dt_dsource_depth_spm": np.array([h, 0, 0]),
             "dt_dreceiver_depth_spm": np.array([0, h, 0])}
    for ray in tracer.eigenrays(zs, zr, r):
        for field, step in steps.items():
            fwd = times(*(np.array([zs, zr, r]) + step))[ray.name]
            back = times(*(np.array([zs, zr, r]) - step))[ray.name]
            # a central difference of a smooth function: error h^2 d3t of order 1e-12 s/m
            assert (fwd - back) / (2 * h) == pytest.approx(getattr(ray, field), abs=1e-9), (ray.name, field)


def test_refraction_in_a_thermocline_lengthens_the_direct_ray_up_into_the_fast_layer():
    prof = SoundSpeedProfile([0.0, 15.0, 35.0], [1530.0, 1530.0, 1490.0])
    tracer = RayTracer(prof, water_depth_m=60.0)
    ray = tracer.eigenrays(25.0, 5.0, 1000.0)[0]
    # Snell: to reach 5 m the ray must leave 25 m (c = 1510) steeper than arccos(1510 / 1530) = 9.2°
    assert ray.name == "direct" and -ray.launch_angle_rad > np.arccos(1510.0 / 1530.0)
    assert abs(ray.arrival_angle_rad) < np.radians(2.0)


def test_bad_depths_and_ranges():
    tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=40.0)
    with pytest.raises(ConfigError, match="within the water"):
        tracer.eigenrays(45.0, 5.0, 100.0)
    with pytest.raises(ConfigError, match="range_m"):
        tracer.eigenrays(10.0, 5.0, 0.0)
    with pytest.raises(ConfigError, match="water_depth_m"):
        RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=-1.0)


def test_equal_depths_give_the_horizontal_direct_ray():
    # the demo's case (beacon and vehicle at the same depth): a ray that neither climbs nor dives
    tracer = RayTracer(SoundSpeedProfile.isovelocity(1500.0), water_depth_m=20.0)
    for r in (1.0, 100.0, 5000.0):
        rays = {ray.name: ray for ray in tracer.eigenrays(5.0, 5.0, r)}
        # found with the receiver 10 µm lower: Δz² / (2 R c) below 1e-13 s
        assert rays["direct"].travel_time_s == pytest.approx(r / 1500.0, abs=1e-13)
        assert abs(rays["direct"].launch_angle_rad) <= 1.001e-5 / r  # the 10 µm step seen from R
        assert rays["surface"].travel_time_s == pytest.approx(np.hypot(r, 10.0) / 1500.0, abs=1e-13)
