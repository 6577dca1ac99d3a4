"""docs/janus.md's commands, run as written in page order, and what they write checked."""

import json
import re
import shlex
from pathlib import Path

import pandas as pd

from seamodem.cli import main

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "janus"


def page_commands() -> list[str]:
    text = (ROOT / "docs" / "janus.md").read_text(encoding="utf-8")
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        commands += [line.strip() for line in block.splitlines() if line.strip().startswith("seamodem ")]
    return commands


#: "Navigating from JANUS beacons": the whole survey's demo, run by tests/cli/test_demo_janus.py on a 21 s mission
#: (the same demo, rx --janus on its recording and nav track on that file)
NAVIGATION = (
    "seamodem demo --waveform janus --keep-audio -o demo_janus",
    "seamodem rx --janus demo_janus/received.wav -o demo_janus/rx.csv",
    "seamodem nav track demo_janus/rx.csv --imu demo_janus/imu.csv --beacon 45,-25 --start 0,0 --start-speed 1 "
    "--truth demo_janus/truth.csv -o demo_janus/track.csv",
)


def test_janus_page_navigation_commands_are_listed():
    assert set(NAVIGATION) <= set(page_commands())


def test_janus_page_commands_run_and_do_what_the_page_says(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    commands = [c for c in page_commands() if c not in NAVIGATION]
    assert len(commands) == 7
    for command in commands:
        assert main(shlex.split(command)[1:]) == 0, command
    out = capsys.readouterr().out
    assert "janus pset 1" in out
    # the reference's file, byte for byte
    assert (tmp_path / "hello.wav").read_bytes() == (DATA / "pset1_48k_cargo_hello.wav").read_bytes()
    hello = pd.read_csv(tmp_path / "hello.csv")
    assert hello["cargo_text"].tolist() == ["Hello JANUS"] and hello["packet_hex"].tolist() == ["321000000000054e"]
    meas = pd.read_csv(tmp_path / "janus_meas.csv")
    assert meas["frame_index"].tolist() == [0, 1, 2, 3, 4]
    assert (meas["station_id"] == 42).all() and (meas["pset_id"] == 1).all()
    # noiseless, same clock: the range is 0 to far below a sample at 96 kHz (16 mm)
    assert meas["range_m"].abs().max() < 1e-3
    # through shallow water: every packet, its range within 3σ of the simulator's direct path
    received = pd.read_csv(tmp_path / "janus_received.csv")
    truth = pd.DataFrame(json.loads((tmp_path / "janus_received.json").read_text())["truth"])
    m = received.merge(truth[["frame_index", "range_true_m"]], on="frame_index")
    assert len(m) == 5 and (abs(m["range_m"] - m["range_true_m"]) <= 3 * m["sigma_range_m"]).all()
