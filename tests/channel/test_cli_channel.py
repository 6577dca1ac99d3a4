"""``seamodem channel`` end to end: files, truth against closed-form geometry, one-line errors."""

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile

from seamodem.channel import interpolate
from seamodem.cli import main

C = 1500.0
BEACON = np.array([10.0, -20.0, -8.0])
START = np.array([-150.0, 60.0, -4.0])
VELOCITY = np.array([2.0, -0.6, -0.05])

SCENARIO = f"""
mode = "geometry"
seed = 11
[environment]
sound_speed_mps = {C}
water_depth_m = 25.0
[beacon]
position_m = {BEACON.tolist()}
[vehicle]
start_m = {START.tolist()}
velocity_mps = {VELOCITY.tolist()}
[multipath]
max_bounces = 1
[noise]
kind = "white"
snr_db = 20.0
[clock]
offset_s = {{offset}}
sample_rate_offset_ppm = {{ppm}}
"""


def run(args, capsys):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def beacon(tmp_path_factory):
    folder = tmp_path_factory.mktemp("beacon")
    wav = folder / "in.wav"
    assert main(["tx", "--preset", "jmse2024", "--count", "3", "--period", "0.5", "--start", "0.1", "-q", "-o", str(wav)]) == 0
    return wav


def arrival(te, c=C):
    """Independent closed form: |d0 + v t| = c (t − te) for a still beacon, d0 = start − beacon."""
    d0 = START - BEACON
    a = VELOCITY @ VELOCITY - c**2
    b = 2 * (d0 @ VELOCITY + c**2 * te)
    cc = d0 @ d0 - c**2 * te**2
    roots = np.roots([a, b, cc])
    return float(max(r.real for r in roots if r.real > te))


@pytest.mark.parametrize("offset,ppm", [(0.0, 0.0), (0.002, -40.0)])
def test_truth_matches_closed_form_geometry(beacon, tmp_path, capsys, offset, ppm):
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(offset=offset, ppm=ppm))
    out = tmp_path / "out.wav"
    code, stdout, _ = run(["channel", beacon, "--scenario", scenario, "-o", out], capsys)
    assert code == 0 and "wrote" in stdout
    side = json.loads(out.with_suffix(".json").read_text())
    side_in = json.loads(beacon.with_suffix(".json").read_text())
    for key in ("config", "pilot", "schedule", "frames", "format"):
        assert side[key] == side_in[key]  # carried forward
    assert side["channel"]["input_recording"] == side_in["recording"]
    assert [p["name"] for p in side["channel"]["paths"]] == ["direct", "S", "B"]
    cfg = side_in["config"]
    t_f = (2 * cfg["n_guard"] + cfg["n_pilot"] + cfg["n_data"]) / cfg["symbol_rate_hz"]
    rate = 1 + ppm * 1e-6
    for row, frame in zip(side["truth"], side_in["frames"]):
        te = frame["t_emit_s"]
        ta, tb = arrival(te), arrival(te + t_f)
        assert row["t_emit_s"] == te
        assert row["t_arrival_true_s"] == pytest.approx(ta, abs=1e-12)
        assert row["range_true_m"] == pytest.approx(np.linalg.norm(START + VELOCITY * ta - BEACON), abs=1e-8)
        v_mean = -(np.linalg.norm(START + VELOCITY * tb - BEACON) - np.linalg.norm(START + VELOCITY * ta - BEACON)) / (tb - ta)
        assert row["v_r_true_mps"] == pytest.approx(v_mean, abs=1e-6)
        # the SPEC columns, on the receiver's clock
        assert row["t_arrival_s"] == pytest.approx(rate * ta + offset, abs=1e-12)
        assert row["tof_s"] == pytest.approx(row["t_arrival_s"] - te, abs=1e-12)
        assert row["range_m"] == pytest.approx(C * row["tof_s"], abs=1e-8)
        d_rx = rate * (tb - ta)
        assert row["v_r_mps"] == pytest.approx(C * (t_f - d_rx) / d_rx, abs=1e-6)
        assert row["snr_db"] == pytest.approx(20.0, abs=1.0)
    x, fs = soundfile.read(out)
    assert fs == side_in["recording"]["sample_rate_hz"] and x.size == side["recording"]["n_samples"]
    assert side["recording"]["file"] == "out.wav" and soundfile.info(out).subtype == "FLOAT"
    last = side["truth"][-1]
    assert x.size / fs > last["t_arrival_s"] + last["reception_duration_s"]  # the last frame is not cut


def test_output_wav_is_the_input_seen_through_the_geometry(beacon, tmp_path, capsys):
    # no noise, one path: OUT.wav[n] ∝ s(t_n − R(t_n)/c), s read from IN.wav by band-limited interpolation
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(offset=0.0, ppm=0.0).replace("max_bounces = 1", "max_bounces = 0")
                        .replace('kind = "white"', 'kind = "none"'))
    out = tmp_path / "o.wav"
    assert run(["channel", beacon, "--scenario", scenario, "-o", out], capsys)[0] == 0
    side = json.loads(out.with_suffix(".json").read_text())
    x, fs = soundfile.read(beacon)
    y, _ = soundfile.read(out)
    row = side["truth"][0]
    n = np.arange(int(row["t_arrival_s"] * fs) - 100, int((row["t_arrival_s"] + 0.3) * fs))
    t = n / fs
    R = np.linalg.norm(START[:, None] + VELOCITY[:, None] * t - BEACON[:, None], axis=0)
    ref = interpolate(x, (t - R / C) * fs)
    assert np.all(y[n[:50]] == 0.0) and np.all(ref[:50] == 0.0)  # silent before the arrival
    # amplitude aside (spreading, absorption), the waveform is the same to -60 dB
    rho = np.dot(y[n], ref) / np.sqrt(np.dot(y[n], y[n]) * np.dot(ref, ref))
    assert 10 * np.log10(1 - rho) < -60


def test_profile_and_seed_override(beacon, tmp_path, capsys):
    scenario = tmp_path / "p.toml"
    scenario.write_text(f'mode = "profile"\n[environment]\nsound_speed_mps = {C}\n[doppler]\ninitial_range_m = 150.0\n'
                        'components = [{ kind = "constant", v_mps = 1.0 }]\n')
    out = tmp_path / "p.wav"
    code, _, _ = run(["channel", beacon, "--scenario", scenario, "--seed", 9, "-q", "-o", out], capsys)
    assert code == 0
    side = json.loads(out.with_suffix(".json").read_text())
    row = side["truth"][0]
    # closed form: t − (R0 − v t)/c = te → t = (te + R0/c) / (1 + v/c)
    assert row["t_arrival_s"] == pytest.approx((row["t_emit_s"] + 150.0 / C) / (1 + 1.0 / C), abs=1e-12)
    assert row["v_r_mps"] == pytest.approx(1.0, abs=1e-9)
    assert side["channel"]["seed"] == 9


BAD = [
    ("environment.water_depth_m = 25.0", "environment.water_depth_m = -25.0", "environment.water_depth_m"),
    (f"start_m = {START.tolist()}", "start_m = [0.0, 0.0, 3.0]", "vehicle.start_m"),
    (f"velocity_mps = {VELOCITY.tolist()}", "velocity_mps = [1600.0, 0.0, 0.0]", "vehicle.velocity_mps"),
    ("[noise]", "[noise]\nloudness = 3", "noise.loudness"),
]


@pytest.mark.parametrize("old,new,name", BAD, ids=[b[2] for b in BAD])
def test_bad_scenarios_are_one_line_errors(beacon, tmp_path, capsys, old, new, name):
    text = SCENARIO.format(offset=0.0, ppm=0.0)
    if old.startswith("environment."):
        old, new = old.split(".", 1)[1], new.split(".", 1)[1]
    assert old in text
    scenario = tmp_path / "bad.toml"
    scenario.write_text(text.replace(old, new))
    out = tmp_path / "out.wav"
    code, _, err = run(["channel", beacon, "--scenario", scenario, "-o", out], capsys)
    assert code == 2 and err.count("\n") == 1 and name in err and "Traceback" not in err
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_sample_rate_disagreeing_with_sidecar(beacon, tmp_path, capsys):
    x, fs = soundfile.read(beacon)
    wav = tmp_path / "resampled.wav"
    soundfile.write(wav, x, 48000, subtype="FLOAT")
    wav.with_suffix(".json").write_text(beacon.with_suffix(".json").read_text())
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(offset=0.0, ppm=0.0))
    out = tmp_path / "out.wav"
    code, _, err = run(["channel", wav, "--scenario", scenario, "-o", out], capsys)
    assert code == 2 and err.count("\n") == 1 and "48000" in err and "sample_rate_hz" in err
    assert not out.exists()


def test_missing_inputs(beacon, tmp_path, capsys):
    scenario = tmp_path / "s.toml"
    scenario.write_text(SCENARIO.format(offset=0.0, ppm=0.0))
    for args, words in (
        (["channel", tmp_path / "none.wav", "--scenario", scenario, "-o", tmp_path / "o.wav"], "not found"),
        (["channel", beacon, "--scenario", tmp_path / "none.toml", "-o", tmp_path / "o.wav"], "scenario file not found"),
        (["channel", beacon, "--scenario", scenario, "-o", tmp_path / "o.flac"], "output"),
    ):
        code, _, err = run(args, capsys)
        assert code == 2 and err.count("\n") == 1 and words in err


EXAMPLES = sorted((Path(__file__).parents[2] / "examples" / "scenarios").glob("*.toml"))


@pytest.mark.parametrize("path", [p for p in EXAMPLES if "replay" not in p.name], ids=lambda p: p.name)
def test_example_scenarios_run(beacon, tmp_path, capsys, path):
    out = tmp_path / "ex.wav"
    code, _, err = run(["channel", beacon, "--scenario", path, "-q", "-o", out], capsys)
    assert code == 0, err
    side = json.loads(out.with_suffix(".json").read_text())
    assert len(side["truth"]) == 3 and all(row["snr_db"] is not None for row in side["truth"])
    assert np.all(np.isfinite(soundfile.read(out)[0]))


def test_loud_output_is_scaled_below_full_scale(tmp_path):
    # two equal echoes on a 0.5-peak input reach ≈ 1.0: the output must be scaled, the gain recorded
    import json

    import soundfile

    from seamodem.cli import main

    beacon = tmp_path / "b.wav"
    assert main(["tx", "--count", "1", "--period", "1", "--peak", "0.9", "-q", "-o", str(beacon)]) == 0
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        'mode = "profile"\nseed = 3\n[environment]\nsound_speed_mps = 1500.0\n'
        '[doppler]\ninitial_range_m = 100.0\ncomponents = [{kind = "constant", v_mps = 0.0}]\n'
        '[multipath]\npaths = [{delay_s = 0.0005, gain = 0.9}]\n'
    )
    out = tmp_path / "r.wav"
    assert main(["channel", str(beacon), "--scenario", str(scenario), "-o", str(out)]) == 0
    x, _ = soundfile.read(out)
    side = json.loads(out.with_suffix(".json").read_text())
    gain = side["channel"]["output"]["gain"]
    assert gain < 1 and np.max(np.abs(x)) == pytest.approx(0.5, rel=1e-6)
    assert side["recording"]["peak"] == pytest.approx(0.5, rel=1e-6)
