"""The receiver's records on an example scenario, bit for bit as before the receiver's restructuring (issue 13).

``data/doppler_profile_records.csv`` holds the data rows ``seamodem rx`` wrote
at commit a85d394 (before ReceiverSettings and the split of receive/) for a
6-frame beacon through ``examples/scenarios/doppler_profile.toml``: the
channel is seeded, so the same commands must give the same text, digit for
digit. A change that moves any number is a change of behaviour, to be made
on purpose (and this file rewritten with the reason).
"""

from pathlib import Path

from seamodem.cli import main

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).with_name("data") / "doppler_profile_records.csv"


def test_rx_records_on_the_doppler_profile_scenario_are_unchanged(tmp_path):
    tx, rx, out = tmp_path / "tx.wav", tmp_path / "rx.wav", tmp_path / "m.csv"
    assert main(["tx", "--count", "6", "--period", "2", "-o", str(tx), "-q"]) == 0
    scenario = ROOT / "examples" / "scenarios" / "doppler_profile.toml"
    assert main(["channel", str(tx), "--scenario", str(scenario), "-o", str(rx), "-q"]) == 0
    assert main(["rx", str(rx), "-o", str(out), "-q"]) == 0
    rows = [line for line in out.read_text(encoding="utf-8").splitlines() if not line.startswith("#")]
    assert rows == GOLDEN.read_text(encoding="utf-8").splitlines()
