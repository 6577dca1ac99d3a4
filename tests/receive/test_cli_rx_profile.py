"""``seamodem rx --sound-speed-profile``: the time of flight stays; the ranges become those along the traced ray."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from test_cli_rx import beacon  # noqa: F401  (the fixture: a beacon's frames delayed by about 300 m)

from seamodem import BeaconSchedule, get_preset, write_beacon
from seamodem.channel import parse_scenario, simulate_file
from seamodem.cli import main
from seamodem.receive import read_measurements
from seamodem.water import RayTracer, SoundSpeedProfile



@pytest.fixture(scope="module")
def delayed(beacon):
    """test_cli_rx's delayed beacon (about 300 m), with a thermocline's sound-velocity cast beside it."""
    d = beacon[0]
    (d / "svp.csv").write_text("depth_m,c_mps\n0,1530\n15,1530\n35,1490\n")
    return d


def test_ranges_along_the_ray(delayed, tmp_path):
    out = tmp_path / "m.csv"
    assert main(["rx", str(delayed / "delayed.wav"), "-o", str(out), "-q", "--sound-speed-profile",
                 str(delayed / "svp.csv"), "--beacon-depth", "25", "--vehicle-depth", "5"]) == 0
    recs, header = read_measurements(out)
    assert header["sound_speed_profile"]["c_mps"] == [1530.0, 1530.0, 1490.0] and header["vehicle_depth_m"] == 5.0
    assert header["sound_speed_mps"] == 1530.0  # Doppler with c at the vehicle
    tracer = RayTracer(SoundSpeedProfile([0, 15, 35], [1530, 1530, 1490]))
    for r in recs:
        ray = tracer.eigenrays(25.0, 5.0, r.horizontal_range_m)[0]
        # the direct ray at that horizontal range takes tof_s (the table interpolates to nanoseconds)
        assert ray.name == "direct" and abs(ray.travel_time_s - r.tof_s) < 1e-8
        assert r.range_m == pytest.approx(np.hypot(r.horizontal_range_m, 20.0), abs=1e-9)


@pytest.mark.parametrize("extra, words", [
    (["--beacon-depth", "25"], "needs --beacon-depth and --vehicle-depth"),
    (["--beacon-depth", "25", "--vehicle-depth", "5", "--sound-speed-profile", "missing.csv"], "no such"),
])
def test_one_line_errors(delayed, tmp_path, capsys, extra, words):
    argv = ["rx", str(delayed / "delayed.wav"), "-o", str(tmp_path / "m.csv"), "-q"]
    if "--sound-speed-profile" not in extra:
        extra = extra + ["--sound-speed-profile", str(delayed / "svp.csv")]
    assert main(argv + extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and not (tmp_path / "m.csv").exists()


def test_the_depths_alone_take_the_profile_of_a_simulated_recording(tmp_path):
    d = tmp_path
    shutil.copy(Path(__file__).resolve().parents[2] / "examples" / "water" / "thermocline_svp.csv", d / "svp.csv")
    write_beacon(d / "b.wav", get_preset("jmse2024"), BeaconSchedule(count=2, period_s=1.0, start_s=0.1), progress=False)
    scenario = parse_scenario({"mode": "geometry", "environment": {"water_depth_m": 60.0, "sound_speed_mps": 1500.0},
                               "beacon": {"position_m": [0.0, 0.0, -25.0]},
                               "vehicle": {"start_m": [300.0, 0.0, -5.0], "velocity_mps": [0.0, 0.0, 0.0]},
                               "water": {"profile": "svp.csv"}, "noise": {"kind": "white", "snr_db": 30.0}},
                              base_dir=d)
    simulate_file(d / "b.wav", scenario, d / "r.wav", progress=False)
    out = d / "m.csv"
    assert main(["rx", str(d / "r.wav"), "-o", str(out), "-q", "--beacon-depth", "25", "--vehicle-depth", "5"]) == 0
    recs, header = read_measurements(out)
    assert header["sound_speed_profile"]["c_mps"][0] == 1530.0
    # a still vehicle 300 m away: the ray-traced channel and the receiver's ray agree to the receiver's accuracy
    assert all(abs(r.horizontal_range_m - 300.0) < 0.01 for r in recs)


def test_the_depths_without_any_profile_give_the_merged_image(beacon, tmp_path):
    # no profile anywhere: a straight ray at c, and the depths still give a surface image merged with the
    # direct path: 2·2·3/(R·c) = 27 µs at about 300 m, 4 cm, below 1/B = 112 µs, whose predicted bias is taken
    # out of the arrival and whose σ (the waves, the reflection) is the arrival's
    from seamodem.receive.frame import merged_image_bias_s

    plain, deep = tmp_path / "plain.csv", tmp_path / "deep.csv"
    assert main(["rx", str(beacon[2]), "-o", str(plain), "-q"]) == 0
    assert main(["rx", str(beacon[2]), "-o", str(deep), "-q", "--beacon-depth", "2", "--vehicle-depth", "3"]) == 0
    (recs, _), (deep_recs, header) = read_measurements(plain), read_measurements(deep)
    assert header["beacon_depth_m"] == 2.0 and header["vehicle_depth_m"] == 3.0
    assert "sound_speed_profile" not in header
    for r, d in zip(recs, deep_recs, strict=True):
        bias, spread = merged_image_bias_s(r.range_m, 2.0, 3.0, config=get_preset("jmse2024"),
                                           sound_speed_mps=1500.0)[:2]
        assert bias != 0.0 and spread > 0.0
        assert d.range_m == pytest.approx(r.range_m - 1500.0 * bias, abs=1e-9)
        # (the image's σ in place of the channel bend's bound, which the image explains)
        assert 1500.0 * spread <= d.sigma_range_m <= np.hypot(r.sigma_range_m, 1500.0 * spread) * (1 + 1e-9)
        # this recording has no surface image: the shift for one is within the σ it brings
        assert abs(d.range_m - r.range_m) <= d.sigma_range_m


@pytest.mark.parametrize("extra, words", [
    (["--wave-amplitude", "-1"], "wave_amplitude"),
    (["--wave-period", "0"], "wave_period"),
])
def test_an_impossible_sea_is_a_one_line_error(beacon, tmp_path, capsys, extra, words):
    out = tmp_path / "m.csv"
    assert main(["rx", str(beacon[2]), "-o", str(out), "-q", "--beacon-depth", "2", "--vehicle-depth", "3"] + extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and not out.exists()


def test_a_calm_sea_narrows_the_merged_images_sigma(beacon, tmp_path):
    # the sea state is the header's, and a calmer one gives the image's spread (range) a smaller σ
    rough, calm = tmp_path / "rough.csv", tmp_path / "calm.csv"
    depths = ["--beacon-depth", "2", "--vehicle-depth", "3"]
    assert main(["rx", str(beacon[2]), "-o", str(rough), "-q"] + depths) == 0
    assert main(["rx", str(beacon[2]), "-o", str(calm), "-q", "--wave-amplitude", "0.1", "--wave-period", "6"]
                + depths) == 0
    (r_recs, r_head), (c_recs, c_head) = read_measurements(rough), read_measurements(calm)
    assert r_head["wave_amplitude_m"] == 0.5 and c_head["wave_amplitude_m"] == 0.1
    assert c_head["wave_period_s"] == 6.0
    assert all(c.sigma_range_m < r.sigma_range_m for r, c in zip(r_recs, c_recs, strict=True))


def test_ranges_without_the_depths_note_the_surface_image_they_may_carry(beacon, tmp_path, capsys):
    # about 300 m: a surface image merges with the direct path for depths whose product is below
    # R·c/(2B) ≈ 25 m², biasing the range about 0.9·z_b·z_v/R; the note names the products beyond 3σ
    out = tmp_path / "m.csv"
    assert main(["rx", str(beacon[2]), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    note = [line for line in printed.splitlines() if line.startswith("note: ranges measured without the ends' depths")]
    assert len(note) == 1 and "Lloyd's mirror" in note[0]
    recs, _ = read_measurements(out)
    r = float(np.median([x.range_m for x in recs]))
    assert f"median range of {r:.3g} m" in note[0]
    cfg = get_preset("jmse2024")
    high = r * 1500.0 / (2 * cfg.symbol_rate_hz * (1 + cfg.rolloff))
    assert f"-{high:.2g} m²" in note[0]
    # with the depths the image is taken out: no note
    assert main(["rx", str(beacon[2]), "-o", str(out), "--beacon-depth", "2", "--vehicle-depth", "3"]) == 0
    assert "Lloyd's mirror" not in capsys.readouterr().out


def test_a_depth_log_gives_each_frame_the_vehicles_depth_at_its_arrival(beacon, delayed, tmp_path, capsys):
    # a log that holds the vehicle at 3 m gives the records of --vehicle-depth 3, with and without a profile;
    # one that dives gives each frame the image of its own depth
    from seamodem.receive.frame import merged_image_bias_s

    still, logged, diving = tmp_path / "still.csv", tmp_path / "logged.csv", tmp_path / "diving.csv"
    (tmp_path / "still_log.csv").write_text("t_s,depth_m\n0,3\n100,3\n")
    (tmp_path / "dive_log.csv").write_text("t_s,depth_m\n0.5,1\n10,11\n")
    common = ["-q", "--beacon-depth", "2"]
    assert main(["rx", str(beacon[2]), "-o", str(still), "--vehicle-depth", "3"] + common) == 0
    assert main(["rx", str(beacon[2]), "-o", str(logged), "--vehicle-depth-log", str(tmp_path / "still_log.csv")]
                + common) == 0
    (a, _), (b, header) = read_measurements(still), read_measurements(logged)
    assert [(r.range_m, r.sigma_range_m, r.v_r_mps) for r in a] == [(r.range_m, r.sigma_range_m, r.v_r_mps) for r in b]
    assert header["vehicle_depth_log"] == [[0.0, 100.0], [3.0, 3.0]]
    profile = ["--sound-speed-profile", str(delayed / "svp.csv"), "--beacon-depth", "25"]
    assert main(["rx", str(delayed / "delayed.wav"), "-o", str(still), "-q", "--vehicle-depth", "5"] + profile) == 0
    (tmp_path / "five.csv").write_text("t_s,depth_m\n0,5\n100,5\n")
    assert main(["rx", str(delayed / "delayed.wav"), "-o", str(logged), "-q", "--vehicle-depth-log",
                 str(tmp_path / "five.csv")] + profile) == 0
    (a, _), (b, header) = read_measurements(still), read_measurements(logged)
    assert [r.horizontal_range_m for r in a] == [r.horizontal_range_m for r in b]
    assert header["vehicle_depth_log"] == [[0.0, 100.0], [5.0, 5.0]]
    assert header["vehicle_depth_log_file"] == str(tmp_path / "five.csv")
    capsys.readouterr()
    assert main(["rx", str(beacon[2]), "-o", str(diving), "--vehicle-depth-log", str(tmp_path / "dive_log.csv")]
                + common) == 0
    err = capsys.readouterr().err  # the log starts after the recording does: said in one line
    assert "warning: vehicle depth log" in err and "covers 0.5-10 s of the recording's 0-" in err, err
    plain = tmp_path / "plain.csv"
    assert main(["rx", str(beacon[2]), "-o", str(plain), "-q"]) == 0
    recs, dive_recs = read_measurements(plain)[0], read_measurements(diving)[0]
    for r, d in zip(recs, dive_recs, strict=True):
        depth = float(np.interp(r.t_arrival_s, [0.5, 10.0], [1.0, 11.0]))
        bias = merged_image_bias_s(r.range_m, 2.0, depth, config=get_preset("jmse2024"), sound_speed_mps=1500.0)[0]
        assert d.range_m == pytest.approx(r.range_m - 1500.0 * bias, abs=1e-9)


@pytest.mark.parametrize("log, extra, words", [
    ("t_s,depth_m\n0,3\n", ["--vehicle-depth", "3"], "not both"),
    ("t_s,z_m\n0,3\n", [], "depth_m"),
    ("t_s,depth_m\n0,-3\n", [], "depth"),
])
def test_a_depth_log_that_cannot_be_used_is_a_one_line_error(beacon, tmp_path, capsys, log, extra, words):
    out = tmp_path / "m.csv"
    (tmp_path / "depth.csv").write_text(log)
    assert main(["rx", str(beacon[2]), "-o", str(out), "-q", "--beacon-depth", "2", "--vehicle-depth-log",
                 str(tmp_path / "depth.csv")] + extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err and not out.exists(), err


def test_no_echo_geometry_reaches_the_receiver_and_its_header(beacon, tmp_path):
    # the option turns off the depths inferred from the echoes (ReceiverSettings.echo_geometry); the header
    # says which was used. This beacon has no echoes, so the records themselves are the same either way
    on, off = tmp_path / "on.csv", tmp_path / "off.csv"
    assert main(["rx", str(beacon[2]), "-o", str(on), "-q"]) == 0
    assert main(["rx", str(beacon[2]), "-o", str(off), "-q", "--no-echo-geometry"]) == 0
    (on_recs, on_head), (off_recs, off_head) = read_measurements(on), read_measurements(off)
    assert on_head["echo_geometry"] is True and off_head["echo_geometry"] is False
    assert [r.range_m for r in on_recs] == [r.range_m for r in off_recs]
