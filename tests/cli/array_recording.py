"""A jmse2024 beacon heard on a 4-element tetrahedron (tetra:0.08), and its file-run records: the recording
the live array tests stream and compare against (tests/cli/test_rx_live_*.py)."""

from __future__ import annotations

from pathlib import Path

from seamodem.cli import main

SCENARIO = ('mode = "geometry"\nseed = 3\n[environment]\nsound_speed_mps = 1500.0\n'
            'water_depth_m = 35.0\n[beacon]\nposition_m = [0.0, 0.0, -20.0]\n[vehicle]\n'
            'start_m = [-150.0, 60.0, -10.0]\nvelocity_mps = [1.2, 0.2, 0.0]\n'
            '[noise]\nkind = "white"\nsnr_db = 12.0\n')


def write_array_recording(d: Path, count: int) -> Path:
    """``count`` frames one a second into ``d``: beacon.wav, s.toml, rx.wav (+ rx.json), and off.csv from
    ``rx rx.wav --array tetra:0.08``. Returns ``d``."""
    assert main(["tx", "--preset", "jmse2024", "--count", str(count), "--period", "1", "--start", "0.1",
                 "-o", str(d / "beacon.wav"), "-q"]) == 0
    (d / "s.toml").write_text(SCENARIO)
    assert main(["channel", str(d / "beacon.wav"), "--scenario", str(d / "s.toml"), "--array", "tetra:0.08",
                 "-o", str(d / "rx.wav"), "-q"]) == 0
    assert main(["rx", str(d / "rx.wav"), "--array", "tetra:0.08", "-o", str(d / "off.csv"), "-q"]) == 0
    return d
