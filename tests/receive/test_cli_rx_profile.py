"""``seamodem rx --sound-speed-profile``: the time of flight stays; the ranges become those along the traced ray."""

import numpy as np
import pytest
from test_cli_rx import beacon  # noqa: F401  (the fixture: a beacon's frames delayed by about 300 m)

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
