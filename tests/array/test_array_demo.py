"""``seamodem demo --array``: the array case beside one hydrophone on the demo's mission (issue 17)."""

import json

import numpy as np
import pandas as pd

from seamodem.cli import main


def test_demo_with_an_array_compares_it_with_one_hydrophone(tmp_path, capsys):
    # docs/array.md's command with a 12 s mission (4 frames) instead of the whole survey
    out = tmp_path / "demo_array"
    assert main(["demo", "--array", "tetra:0.08", "--duration", "12", "--no-plots", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "hydrophone array tetra:0.08 (4 elements, 8 cm)" in printed and "one-frame fix" in printed
    a = json.loads((out / "summary.json").read_text())["array"]
    assert a["array"]["frames_detected"] == a["one_hydrophone"]["frames_detected"] == 4
    assert a["array"]["payloads_correct"] == 4
    # 12 dB per element: the bearing within a degree of the truth and within 3 sigma
    assert a["azimuth_rmse_deg"] < 1.0 and a["azimuth_within_3_sigma"] == 1.0
    # one frame, no filter: range (mm) x azimuth (0.2 deg) x AHRS heading (1 deg) at 30-55 m: about a metre
    assert a["one_frame_fix_median_error_m"] < 2.0
    # both ranges against their own geometric truth (element 0 vs the body origin): centimetres, not the lever arm
    assert a["array"]["range_rmse_m"] < 0.02 and a["one_hydrophone"]["range_rmse_m"] < 0.02
    m = pd.read_csv(out / "measurements_array.csv")
    assert len(m) == 4 and (m["n_channels"] == 4).all() and np.isfinite(m["azimuth_body_rad"]).all()
    side = json.loads((out / "measurements_array.csv.json").read_text())
    assert side["array"]["spec"] == "tetra:0.08"


def test_demo_array_bad_spec_is_one_line(tmp_path, capsys):
    assert main(["demo", "--array", "cube9", "--duration", "12", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("seamodem demo: error:") and "cube9" in err and "\n" not in err
    assert not (tmp_path / "x").exists()
