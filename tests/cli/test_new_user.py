"""Issue 29, "what a new user met": each item reproduced as the user met it, on the command line."""

from __future__ import annotations

import pytest

from seamodem.cli import _parser, main


def _error_line(capsys, argv) -> str:
    """The one stderr line of a command line argparse refuses (exit 2)."""
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err  # docs/cli.md: one line, no usage block
    return lines[0]


def test_negative_coordinates_are_values_not_options():
    """Item 2: ``--beacon -45,25 --start -60,20`` parses as the ``=`` form does."""
    track = ["nav", "track", "m.csv", "--imu", "i.csv", "-o", "t.csv"]
    args = _parser().parse_args([*track, "--beacon", "-45,25", "--start", "-60,20", "--depth", "5", "-2.5"])
    assert (args.beacon, args.start, args.depth) == ("-45,25", "-60,20", [5.0, -2.5])
    same = _parser().parse_args([*track, "--beacon=-45,25", "--start=-60,20"])
    assert (same.beacon, same.start) == (args.beacon, args.start)
    assert _parser().parse_args(["rx", "x.wav", "--emit-start", "-1e-3", "--emit-period", "3", "-o", "m.csv"]
                                ).emit_start == -1e-3


@pytest.mark.parametrize("argv, option", [
    (["rx", "x.wav", "--v-max", "abc", "-o", "m.csv"], "--v-max"),
    (["nav", "track", "m.csv", "--imu", "i.csv", "--beacon", "1,2", "--start", "0,0", "--min-speed", "abc",
      "-o", "t.csv"], "--min-speed"),
    (["demo", "--snr", "abc"], "--snr"),
    (["nav", "simulate", "--runs", "many"], "--runs"),
    (["tx", "--count"], "--count"),
    (["rx", "x.wav", "--no-such-option", "-o", "m.csv"], "--no-such-option"),
])
def test_a_bad_value_is_one_line_naming_the_option(capsys, argv, option):
    """Item 3: a mistyped value is one line, ``seamodem CMD: error: argument --opt: ...``, exit 2."""
    line = _error_line(capsys, argv)
    command = " ".join(w for w in argv[:2] if not w.endswith((".wav", ".csv")) and not w.startswith("-"))
    assert line.startswith(f"seamodem {command}: error:") and option in line, line


def test_demo_array_alone_takes_the_documented_array(capsys):
    """Item 8: ``seamodem demo --array`` alone is the tetrahedron of docs/array.md, not an error."""
    assert _parser().parse_args(["demo", "--array", "-o", "d"]).array == "tetra:0.08"
    assert _parser().parse_args(["demo", "--array", "circle4", "-o", "d"]).array == "circle4"
    assert _parser().parse_args(["demo"]).array is None


def test_demo_and_nav_track_smooth_give_the_same_smoother_on_the_same_files(tmp_path, monkeypatch):
    """Item 7: the demo's batch smoother said 0.21 m, ``nav track --smooth`` on its files 0.12 m.

    The demo weighted every frame by a default σ (5 cm) while nav track uses each record's σ; now both use
    the records'. The tracks are compared state by state, at the demo's instants (its IMU samples).
    """
    import numpy as np
    import pandas as pd

    monkeypatch.setenv("MPLBACKEND", "Agg")
    out = tmp_path / "demo"
    assert main(["demo", "--duration", "30", "--no-plots", "-q", "-o", str(out)]) == 0
    for flag, name in ((["--smooth"], "batch"), ([], "inertial")):
        track = tmp_path / f"nav_{name}.csv"
        assert main(["nav", "track", str(out / "measurements.csv"), "--imu", str(out / "imu.csv"), "--beacon",
                     "45,-25", "--start", "0,0", "--start-speed", "1", *flag, "-o", str(track)]) == 0
        nav = pd.read_csv(track).drop_duplicates("t_s", keep="last")  # the state after each IMU sample
        demo = pd.read_csv(out / f"track_{name}.csv")
        both = demo.merge(nav, on="t_s", suffixes=("_demo", "_nav"))
        assert len(both) == len(demo)
        # 1 µm: imu.csv and the tracks are written to 9 significant digits (tens of metres → 1e-7 m)
        np.testing.assert_allclose(both[["x_m_nav", "y_m_nav"]].to_numpy(), both[["x_m_demo", "y_m_demo"]].to_numpy(),
                                   atol=1e-6, rtol=0)
