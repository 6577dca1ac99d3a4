"""Geodetic ↔ local conversion on WGS-84 and the latitude/longitude checks."""

import warnings

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.navigation.geometry import CoordinateWarning, check_lat_lon, geodetic_to_local, local_to_geodetic

# WGS-84 defining constants (NIMA TR8350.2, 3rd ed., Table 3.1), written out so that the
# closed-form checks do not share the module's constants.
A = 6378137.0
F = 1 / 298.257223563
E2 = F * (2 - F)


def meridian_radius(phi):
    """M(φ) = a(1 − e²)/(1 − e² sin²φ)^{3/2} [m]."""
    return A * (1 - E2) / (1 - E2 * np.sin(phi) ** 2) ** 1.5


def prime_vertical_radius(phi):
    """N(φ) = a/√(1 − e² sin²φ) [m]."""
    return A / np.sqrt(1 - E2 * np.sin(phi) ** 2)


def test_published_reference_point_matterhorn_from_zermatt():
    # MathWorks Mapping Toolbox documentation, geodetic2enu, example "Calculate ENU coordinates
    # of the Matterhorn with respect to Zermatt" (https://www.mathworks.com/help/map/ref/geodetic2enu.html):
    # origin 46.017° N 7.750° E h0 = 1673 m; point 45.976° N 7.658° E h = 4531 m, WGS-84;
    # printed result xEast = -7134.8 m, yNorth = -4556.3 m.
    east, north = geodetic_to_local(45.976, 7.658, 46.017, 7.750, height_m=4531.0, origin_height_m=1673.0)
    # The reference is printed to 0.1 m: half a unit of its last digit.
    assert east == pytest.approx(-7134.8, abs=0.05)
    assert north == pytest.approx(-4556.3, abs=0.05)
    # The same documentation's enu2geodetic example goes back to 45.976°, 7.658° (printed to 1e-3°).
    lat, lon = local_to_geodetic(-7134.8, -4556.3, 46.017, 7.750, height_m=4531.0, origin_height_m=1673.0)
    # 0.05 m of rounding in east/north is 5e-7°; 1e-5° still tells 1 m (1e-5° ≈ 1.1 m) from the printed value.
    assert lat == pytest.approx(45.976, abs=1e-5) and lon == pytest.approx(7.658, abs=1e-5)


@pytest.mark.parametrize("lat0", [0.0, 30.0, 48.38243, -62.5, 75.0])
def test_offsets_equal_the_meridian_arc_and_the_parallel_arc(lat0):
    phi = np.radians(lat0)
    for d_deg in (1e-3, np.degrees(450.0 / meridian_radius(phi))):  # 111 m and 450 m
        _, north = geodetic_to_local(lat0 + d_deg, 10.0, lat0, 10.0)
        east, _ = geodetic_to_local(lat0, 10.0 + d_deg, lat0, 10.0)
        # Second-order terms (the change of M across the arc, the chord vs the tangent
        # plane) are below 0.2 mm at 450 m: 1 mm tells them from any scale error (1e-4 = 45 mm).
        assert north == pytest.approx(meridian_radius(phi) * np.radians(d_deg), abs=1e-3)
        assert east == pytest.approx(prime_vertical_radius(phi) * np.cos(phi) * np.radians(d_deg), abs=1e-3)


def test_round_trip_over_ten_kilometres():
    rng = np.random.default_rng(12)
    east = rng.uniform(-10e3, 10e3, 50)
    north = rng.uniform(-10e3, 10e3, 50)
    for lat0, lon0 in ((48.38243, -4.407295), (-33.9, 151.2), (0.0, 179.99)):
        lat, lon = local_to_geodetic(east, north, lat0, lon0)
        e2, n2 = geodetic_to_local(lat, lon, lat0, lon0)
        # float64 Earth-centred coordinates round at ~1e-9 m: 1 µm is far above that, far below any effect.
        np.testing.assert_allclose(e2, east, atol=1e-6)
        np.testing.assert_allclose(n2, north, atol=1e-6)


def test_the_old_sphere_was_a_tenth_to_two_tenths_of_a_percent_off_at_brest():
    lat0, lon0 = 48.38243, -4.407295
    d = 450.0
    lat_n, _ = local_to_geodetic(0.0, d, lat0, lon0)  # 450 m due north
    _, lon_e = local_to_geodetic(d, 0.0, lat0, lon0)  # 450 m due east
    # paper 001 eq 50–52, the previous implementation: equirectangular sphere of radius a
    sphere_east = A * np.radians(lon_e - lon0) * np.cos(np.radians(lat0))
    sphere_north = A * np.radians(lat_n - lat0)
    north_scale = sphere_north / d - 1
    east_scale = sphere_east / d - 1
    # M(48.4°) < a: the sphere overstates north by 0.11 %; N cos φ > a cos φ: it understates east by 0.19 %.
    assert 0.0010 < north_scale < 0.0012
    assert -0.0020 < east_scale < -0.0018
    error_m = np.hypot(sphere_east - d, sphere_north - d)
    assert 0.9 < error_m < 1.0  # 0.50 m north and 0.84 m east at 450 m each way


def test_origin_is_validated():
    with pytest.raises(ConfigError, match=r"origin_lat_deg: must be in \(-90, 90\) degrees, got 90"):
        geodetic_to_local(0.0, 0.0, 90, 0.0)
    with pytest.raises(ConfigError, match="origin_lon_deg: must be finite, got nan"):
        local_to_geodetic(0.0, 0.0, 10.0, float("nan"))


def test_check_lat_lon_rejects_out_of_range_values_and_hints_at_swaps():
    with pytest.raises(ConfigError, match=r"^beacon: latitude must be in \[-90, 90\] degrees, got -150.0 "
                                          r"\(looks like lon,lat: give lat,lon\)$"):
        check_lat_lon(-150.0, 40.0, "beacon")
    with pytest.raises(ConfigError, match=r"^beacon: latitude must be in \[-90, 90\] degrees, got 95.0$"):
        check_lat_lon(95.0, 170.0, "beacon")  # no hint: 170 cannot be a latitude either
    with pytest.raises(ConfigError, match=r"^fix: longitude must be in \[-180, 180\] degrees, got 181.0$"):
        check_lat_lon([10.0, 10.0], [20.0, 181.0], "fix")
    with pytest.raises(ConfigError, match="start: latitude must be finite, got nan"):
        check_lat_lon(float("nan"), 3.0, "start")


def test_check_lat_lon_warns_when_a_point_is_far_as_given_but_near_when_swapped():
    beacon = (48.38243, -4.407295)
    with pytest.warns(CoordinateWarning, match=r"^start: \(-4.4079, 48.3822\) 77\d\d km from the beacon but within "
                                               r"50 km if read as lon,lat: was it given as lon,lat\? \(expected lat,lon\)$"):
        lat, lon = check_lat_lon(-4.4079, 48.3822, "start", reference=beacon, reference_what="the beacon")
    assert (lat, lon) == (-4.4079, 48.3822)  # warned, not altered
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_lat_lon(48.3822, -4.4079, "start", reference=beacon)  # 200 m away: silent
        check_lat_lon(43.3, 5.4, "start", reference=beacon)  # 900 km but 4800 km swapped: a real mistake, not a swap
    with pytest.warns(CoordinateWarning, match=r"^GNSS fixes: 2 of 3 points \d+ km from the origin"):
        check_lat_lon([48.383, -4.40, -4.41], [-4.40, 48.38, 48.39], "GNSS fixes", reference=beacon)


def test_check_lat_lon_is_silent_near_the_lat_equals_lon_line():
    # Documented limit: exchanging lat and lon near lat = lon moves a point by less than 50 km.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_lat_lon(45.1, 45.0, "start", reference=(45.0, 45.1))
