"""``seamodem channel --array`` and ``seamodem rx --array`` end to end; bad input is one line, exit 2, no file."""

import json
import math

import pandas as pd
import pytest
import soundfile

from seamodem import get_preset
from seamodem.cli import main

CFG = get_preset("jmse2024")

SCENARIO = """mode = "geometry"
seed = 3
[environment]
sound_speed_mps = 1500.0
water_depth_m = 35.0
[beacon]
position_m = [0.0, 0.0, -20.0]
[vehicle]
start_m = [-150.0, 60.0, -10.0]
velocity_mps = [1.2, 0.2, 0.0]
[multipath]
max_bounces = 1
surface_reflection = -0.9
bottom_reflection = 0.5
[noise]
kind = "white"
snr_db = 12.0
"""


@pytest.fixture(scope="module")
def received(tmp_path_factory):
    d = tmp_path_factory.mktemp("array")
    # the commands of docs/array.md
    assert main(["tx", "--preset", "jmse2024", "--count", "2", "--period", "1", "--start", "0.1",
                 "-o", str(d / "beacon.wav"), "-q"]) == 0
    (d / "s.toml").write_text(SCENARIO)
    (d / "profile.toml").write_text('mode = "profile"\n[doppler]\ninitial_range_m = 100.0\n'
                                    'components = [{ kind = "constant", v_mps = 1.0 }]\n')
    assert main(["channel", str(d / "beacon.wav"), "--scenario", str(d / "s.toml"), "--array", "tetra:0.08",
                 "-o", str(d / "rx.wav"), "-q"]) == 0
    return d


def test_channel_writes_one_channel_per_element_and_directions(received):
    info = soundfile.info(received / "rx.wav")
    assert info.channels == 4
    side = json.loads((received / "rx.json").read_text())
    assert side["recording"]["n_channels"] == 4 and len(side["channel"]["array"]["element_positions_m"]) == 4
    direct = side["truth"][0]["paths"][0]
    assert {"azimuth_body_rad", "elevation_body_rad", "azimuth_world_rad", "elevation_world_rad"} <= set(direct)


def test_rx_array_records_directions(received):
    out = received / "m.csv"
    assert main(["rx", str(received / "rx.wav"), "--array", "tetra:0.08", "-o", str(out), "-q"]) == 0
    df = pd.read_csv(out)
    side = json.loads((received / "rx.json").read_text())
    assert len(df) == 2 and (df["n_channels"] == 4).all() and df["crc_ok"].all()
    for _, row in df.iterrows():
        truth = side["truth"][int(row["frame_index"])]["paths"][0]
        err = abs(math.remainder(row["azimuth_body_rad"] - truth["azimuth_body_rad"], 2 * math.pi))
        assert err < 4 * row["sigma_azimuth_body_rad"] + 1e-3  # σ ≈ 0.15° at 12 dB
    meta = json.loads((received / "m.csv.json").read_text())
    assert meta["array"]["spec"] == "tetra:0.08"
    assert meta["array"]["geometry"] == "volume" and meta["array"]["ambiguity"] is None


def test_rx_flat_array_states_its_assumption(received, capsys):
    # a horizontal ring of 4: accepted, one warning line naming the assumption, the sidecar says it too
    assert main(["channel", str(received / "beacon.wav"), "--scenario", str(received / "s.toml"), "--array",
                 "circle4:0.08", "-o", str(received / "flat.wav"), "-q"]) == 0
    out = received / "flat.csv"
    assert main(["rx", str(received / "flat.wav"), "--array", "circle4:0.08", "-o", str(out), "-q"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning" in err[0] and "assumed below" in err[0]
    meta = json.loads((received / "flat.csv.json").read_text())
    assert meta["array"]["geometry"] == "planar" and meta["array"]["assume"] == "below"
    df = pd.read_csv(out)
    side = json.loads((received / "flat.json").read_text())
    assert len(df) == 2 and (df["elevation_body_rad"] <= 0).all()
    for _, row in df.iterrows():
        truth = side["truth"][int(row["frame_index"])]["paths"][0]
        err = abs(math.remainder(row["azimuth_body_rad"] - truth["azimuth_body_rad"], 2 * math.pi))
        assert err < 4 * row["sigma_azimuth_body_rad"] + 1e-3


def test_rx_linear_array_reports_the_cone_on_the_assumed_side(received, capsys):
    # a fore-aft line of 4 (8 cm) through channel --array: only the angle ψ to the line is measured,
    # cos ψ = cos(el) cos(az). The beacon is to starboard here (body azimuth ≈ −31°, elevation ≈ −3.5°);
    # the default assumption (port, elevation 0) reports the mirror image, a starboard array file the truth
    assert main(["channel", str(received / "beacon.wav"), "--scenario", str(received / "s.toml"), "--array",
                 "line4:0.08", "-o", str(received / "line.wav"), "-q"]) == 0
    side = json.loads((received / "line.json").read_text())
    positions = side["channel"]["array"]["element_positions_m"]
    (received / "starboard.json").write_text(json.dumps({"array": {"element_positions_m": positions,
                                                                   "assume": "starboard"}}))
    for spec, sign in (("line4:0.08", 1.0), (str(received / "starboard.json"), -1.0)):
        out = received / "line.csv"
        assert main(["rx", str(received / "line.wav"), "--array", spec, "-o", str(out), "-q"]) == 0
        err = capsys.readouterr().err.strip().splitlines()
        side_name = "port" if sign > 0 else "starboard"
        assert len(err) == 1 and "warning" in err[0] and "cone" in err[0] and f"{side_name} side" in err[0]
        meta = json.loads((received / "line.csv.json").read_text())
        assert meta["array"]["geometry"] == "linear" and meta["array"]["assume"] == side_name
        df = pd.read_csv(out)
        assert len(df) == 2 and (df["n_channels"] == 4).all() and df["crc_ok"].all()
        assert df["elevation_body_rad"].isna().all() and df["sigma_elevation_body_rad"].isna().all()
        for _, row in df.iterrows():
            truth = side["truth"][int(row["frame_index"])]["paths"][0]
            az_t, el_t = truth["azimuth_body_rad"], truth["elevation_body_rad"]
            assert az_t < -0.3  # the truth is to starboard: the port assumption must give the mirror
            az = row["azimuth_body_rad"]
            assert sign * az > 0  # on the assumed side
            # the measured cone: ψ = acos(cos el cos az) of the truth, within 4σ (σ ≈ 0.3° at 12 dB)
            psi_true = math.acos(math.cos(el_t) * math.cos(az_t))
            assert abs(abs(az) - psi_true) < 4 * row["sigma_azimuth_body_rad"]
            # modulo the stated ambiguity (the mirror through the line; elevation taken as 0, which moves ψ off
            # |az| by |ψ − |az_t||) it is the truth
            tol = 4 * row["sigma_azimuth_body_rad"] + abs(psi_true - abs(az_t))
            assert abs(math.remainder(az - (-sign * az_t), 2 * math.pi)) < tol


@pytest.mark.parametrize("argv, expected", [
    (["--array", "square"], "unknown array"),
    (["--array", "missing.toml"], "not found"),
])
def test_channel_array_bad_input(received, capsys, argv, expected):
    out = received / "bad.wav"
    code = main(["channel", str(received / "beacon.wav"), "--scenario", str(received / "s.toml"), "-o", str(out), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and expected in err
    assert not out.exists()


def test_channel_array_needs_geometry(received, capsys):
    out = received / "bad.wav"
    code = main(["channel", str(received / "beacon.wav"), "--scenario", str(received / "profile.toml"),
                 "--array", "tetra", "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "geometry scenario" in err and not out.exists()


def test_rx_array_wrong_channel_count(received, capsys):
    out = received / "bad.csv"
    code = main(["rx", str(received / "rx.wav"), "--array", "circle6", "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "6 elements" in err
    assert not out.exists()
