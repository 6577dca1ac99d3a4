"""Sound-speed profiles: the type's checks, the cast reader, TEOS-10 against gsw, the figure."""

import numpy as np
import pytest

from seamodem.errors import ConfigError, InputFileError
from seamodem.water import SoundSpeedProfile, profile_from_ctd, read_profile, sound_speed_mackenzie, sound_speed_teos10

gsw = pytest.importorskip("gsw")


def test_linear_interpolation_and_held_ends():
    p = SoundSpeedProfile([10.0, 20.0], [1500.0, 1480.0])
    assert p.c([0.0, 10.0, 15.0, 20.0, 50.0]).tolist() == [1500.0, 1500.0, 1490.0, 1480.0, 1480.0]


@pytest.mark.parametrize("depth, c, words", [
    ([0, 10, 10], [1500, 1500, 1500], "node 2"),
    ([0, 10, 5], [1500, 1500, 1500], "increase strictly"),
    ([-1, 10], [1500, 1500], "positive down"),
    ([0, 10], [1500, 15.0], "outside"),
    ([0, 10], [1500, np.nan], "not a finite"),
    ([0, 10], [1500], "as many"),
])
def test_bad_profiles_are_one_line_errors(depth, c, words):
    with pytest.raises(ConfigError, match=words) as info:
        SoundSpeedProfile(depth, c, source="cast.csv")
    assert str(info.value).startswith("cast.csv: ") and "\n" not in str(info.value)


def test_teos10_is_gsw_for_a_cast_given_as_pressure_temperature_salinity(tmp_path):
    p = np.array([1.0, 10.0, 20.0, 30.0, 50.0, 200.0])
    t = np.array([22.0, 21.5, 16.0, 12.0, 11.0, 9.0])
    sp = np.array([36.2, 36.2, 36.0, 35.8, 35.6, 35.4])
    lat, lon = 43.1, 5.9
    path = tmp_path / "ctd.csv"
    path.write_text("# a CTD down-cast\npressure_dbar,temperature_c,salinity_psu\n"
                    + "".join(f"{a},{b},{c}\n" for a, b, c in zip(p, t, sp)))
    profile = read_profile(path, latitude_deg=lat, longitude_deg=lon)
    sa = gsw.SA_from_SP(sp, p, lon, lat)
    expected = gsw.sound_speed(sa, gsw.CT_from_t(sa, t, p), p)
    # the same equations through the same package: agreement to rounding (the issue asks 0.01 m/s)
    np.testing.assert_allclose(profile.c_mps, expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(profile.depth_m, -gsw.z_from_p(p, lat), rtol=0, atol=1e-9)
    assert profile.source.startswith(str(path))


def test_mackenzie_and_teos10_agree_in_the_upper_ocean():
    # Mackenzie's stated standard error is 0.07 m/s against its own data; against TEOS-10 the two formulas
    # differ by a few tenths of a m/s in 0–30 °C, 30–38 psu, 0–500 m
    t, s, z = np.meshgrid(np.linspace(2, 28, 6), np.linspace(30, 38, 5), np.linspace(0, 500, 6), indexing="ij")
    p = gsw.p_from_z(-z, 45.0)
    diff = sound_speed_teos10(t, s, p) - sound_speed_mackenzie(t, s, z)
    assert np.max(np.abs(diff)) < 1.0


def test_a_ctd_cast_by_depth_with_mackenzie_needs_no_pressure():
    prof = profile_from_ctd([20.0, 10.0], [35.0, 35.0], depth_m=[0.0, 50.0], formula="mackenzie")
    np.testing.assert_allclose(prof.c_mps, sound_speed_mackenzie([20.0, 10.0], 35.0, [0.0, 50.0]), rtol=0, atol=1e-12)


def test_a_sound_velocity_cast(tmp_path):
    path = tmp_path / "svp.csv"
    path.write_text("depth_m,c_mps\n0,1530\n15,1530\n35,1490\n60,1490\n")
    prof = read_profile(path)
    assert prof.depth_m.tolist() == [0, 15, 35, 60] and float(prof.c(25.0)) == 1510.0
    assert SoundSpeedProfile.from_dict(prof.to_dict()).c_mps.tolist() == prof.c_mps.tolist()


@pytest.mark.parametrize("text, words", [
    ("", "empty"),
    ("depth_m,c_mps\n", "no rows"),
    ("depth_m,speed\n0,1500\n", "has neither"),
    ("depth_m,c_mps\n0,1500\n5,abc\n", "row 2"),
    ("depth_m,c_mps\n0,1500\n5\n", "row 2 has 1 fields"),
    ("depth_m,c_mps\n0,1500\n10,1500\n8,1500\n", "increase strictly"),
    ("depth_m,c_mps\n0,1500\n10,4900\n", "outside"),
])
def test_bad_casts_name_the_file_and_the_problem(tmp_path, text, words):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=words) as info:
        read_profile(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_a_missing_file(tmp_path):
    with pytest.raises(InputFileError, match="no such"):
        read_profile(tmp_path / "none.csv")


def test_harmonic_and_arithmetic_means():
    p = SoundSpeedProfile.linear(1500.0, 0.1, 100.0)
    assert p.mean_speed(0, 100) == pytest.approx(1505.0, abs=1e-9)
    # ∫dz/c for c = c0 + g z is ln(c1/c0)/g: the harmonic mean is 100 g / ln(1510/1500)
    assert p.mean_slowness_speed(0, 100) == pytest.approx(10.0 / np.log(1510 / 1500), rel=1e-12)


def test_the_figure(tmp_path):
    from seamodem.water.plot import plot_profile

    out = tmp_path / "p.png"
    plot_profile(SoundSpeedProfile([0, 15, 35], [1530, 1530, 1490], source="thermocline"), out,
                 depths_m={"beacon": 25.0, "vehicle": 5.0}, water_depth_m=60.0)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
