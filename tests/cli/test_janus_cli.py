"""``seamodem tx --janus``, ``rx --janus`` and the JANUS lines of ``config --list``."""

import json
from pathlib import Path

import pandas as pd
import pytest

from seamodem.cli import main

DATA = Path(__file__).resolve().parents[1] / "data" / "janus"


def run(args, capsys):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_tx_janus_writes_the_reference_file_byte_for_byte(tmp_path, capsys):
    out = tmp_path / "hello.wav"
    code, stdout, _ = run(["tx", "--janus", "--sample-rate", 48000, "--format", "pcm16",
                           "--packet-cargo", "Hello JANUS", "-o", out], capsys)
    assert code == 0 and "32 10 00 00 00 00 05 4E" in stdout
    assert out.read_bytes() == (DATA / "pset1_48k_cargo_hello.wav").read_bytes()
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["frames"][0]["t_emit_s"] == pytest.approx(1500 / 48000)
    assert side["janus"]["pset"]["fc_hz"] == 11520


def test_rx_janus_beacon_records_with_emissions_from_the_sidecar(tmp_path, capsys):
    wav = tmp_path / "b.wav"
    assert run(["tx", "--janus", "--sample-rate", 48000, "--count", 3, "--period", 2, "--start", 0.25,
                "--packet-app-fields", "StationIdentifier=42,ParameterSetIdentifier=1", "--packet-cargo", "hi",
                "-o", wav], capsys)[0] == 0
    csv = tmp_path / "b.csv"
    code, stdout, _ = run(["rx", "--janus", wav, "-o", csv], capsys)
    assert code == 0 and "3 JANUS packets" in stdout
    d = pd.read_csv(csv)
    assert d["frame_index"].tolist() == [0, 1, 2]
    assert d["station_id"].tolist() == [42] * 3 and d["cargo_text"].tolist() == ["hi"] * 3
    # noiseless, same clock: tof 0 to far below a sample (1/48000 s = 31 mm)
    assert d["range_m"].abs().max() < 1e-3
    assert json.loads(Path(f"{csv}.json").read_text())["sound_speed_mps"] == 1500


def test_config_list_shows_janus_parameter_sets(capsys):
    code, stdout, _ = run(["config", "--list"], capsys)
    assert code == 0 and "janus pset 1" in stdout and "fc 11520 Hz" in stdout


@pytest.mark.parametrize("args, message", [
    (["tx", "--janus", "--packet-app-fields", "Foo=1", "-o", "x.wav"], "packet-app-fields"),
    (["tx", "--janus", "--sample-rate", 20000, "-o", "x.wav"], "fs must exceed"),
    (["tx", "--janus", "--packet-cargo", "x" * 481, "-o", "x.wav"], "cargo must be"),
    (["rx", "--janus", "missing.wav", "-o", "x.csv"], "recording not found"),
    (["rx", "--janus", "x.wav", "--reference", "lfm:19000-29000:0.05", "-o", "x.csv"], "not both"),
    (["tx", "--janus", "--reference", "lfm:19000-29000:0.05", "-o", "x.wav"], "not both"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(args, capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_janus_beacon_through_the_channel_simulator(tmp_path, capsys):
    """Shallow water (examples/scenarios/straight_line.toml): the surface echo arrives ~0.3 ms after the
    direct path with the opposite sign, inside the packet's delay resolution; the range is the first
    arrival's and its σ covers the echo's pull."""
    root = Path(__file__).resolve().parents[2]
    wav, rx, csv = tmp_path / "jb.wav", tmp_path / "jr.wav", tmp_path / "jr.csv"
    assert run(["tx", "--janus", "--sample-rate", 96000, "--count", 5, "--period", 3, "--start", 0.5,
                "--packet-app-fields", "StationIdentifier=7", "-o", wav], capsys)[0] == 0
    assert run(["channel", wav, "--scenario", root / "examples" / "scenarios" / "straight_line.toml", "-o", rx],
               capsys)[0] == 0
    assert run(["rx", "--janus", rx, "-o", csv], capsys)[0] == 0
    d = pd.read_csv(csv)
    truth = pd.DataFrame(json.loads(rx.with_suffix(".json").read_text())["truth"])
    m = d.merge(truth[["frame_index", "range_true_m", "v_r_true_mps"]], on="frame_index")
    assert len(m) == 5 and (m["station_id"] == 7).all()
    assert (abs(m["range_m"] - m["range_true_m"]) <= 3 * m["sigma_range_m"]).all()
    assert (abs(m["v_r_mps"] - m["v_r_true_mps"]) <= 3 * m["sigma_v_r_mps"]).all()
