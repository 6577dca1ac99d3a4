"""Every ``seamodem …`` command shown in README.md and docs/*.md code blocks is run here, or listed with the reason.

The commands are extracted from the pages, so a new or edited command fails
``test_every_documented_command_is_accounted_for`` until it is added below: the docs cannot drift from
the code unnoticed. Commands run in-process (``seamodem.cli.main``) in one temporary directory, in page
order, so a later command finds what an earlier one wrote (``beacon.wav`` → ``received.wav`` → ``meas.csv``).
Commands that would take minutes are run with smaller counts: each such rewrite is in ``SMALLER`` and says so.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pandas as pd
import pytest

from seamodem.cli import main

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def documented_commands() -> list[tuple[str, str]]:
    """(page, command) for every ``seamodem`` or ``python examples/`` command in a fenced code block."""
    found = []
    for page in PAGES:
        for block in re.findall(r"```[^\n]*\n(.*?)```", page.read_text(encoding="utf-8"), re.S):
            for line in re.sub(r"\\\n\s*", " ", block).splitlines():
                for part in line.split("&&"):
                    command = " ".join(re.sub(r"\s+#.*$", "", part).split())
                    if command.startswith(("seamodem ", "python examples/")):
                        found.append((page.name, command))
    return found


def is_synopsis(command: str) -> bool:
    """docs/cli.md's usage lines: placeholders, not a command to run."""
    return "[options]" in command or "…" in command


#: Commands run as written, in this order (the ones the next ones need come first).
RUN = [
    "seamodem tx --preset jmse2024 --count 20 --period 3 -o beacon.wav",
    "seamodem plot beacon.wav",
    "seamodem config --preset jmse2024 -o my.toml",
    "seamodem channel beacon.wav --scenario examples/scenarios/straight_line.toml -o received.wav",
    "seamodem rx received.wav -o meas.csv",
    "seamodem rx sea.wav --emit-start 0 --emit-period 3 -o meas.csv",
    "seamodem tx --preset jmse2024 --count 20 -o beacon.wav",
    "seamodem tx --preset oceans2021 --payload-file notes.txt --period 1 -o notes.wav",
    'seamodem tx --set modulation=\\"qpsk\\" --set rolloff=0.25 --format pcm16 -o q.wav',
    "seamodem plot beacon.wav --start 0 --duration 1",
    "seamodem tx --preset jmse2024 --count 200 --period 3 -o beacon.wav",
    "seamodem rx survey/*.wav -o all.csv",
    "seamodem rx survey/*.wav --workers 2 -o all.jsonl",
    "seamodem rx survey/*.wav -o all.csv --resume",
    "seamodem ber --snr 0 1 2 3 4 5 6 8 --frames 50 -o ber_awgn/",
    "seamodem ber --scenario examples/scenarios/decode_multipath.toml --period 3 --snr 2 4 6 8 -o ber_mp/",
    "seamodem tx --preset jmse2024 --count 3 --period 1 -o thermo_beacon.wav",
    "seamodem channel thermo_beacon.wav --scenario examples/scenarios/thermocline.toml -o thermo.wav",
    "seamodem rx thermo.wav --sound-speed-profile examples/water/thermocline_svp.csv --beacon-depth 25 "
    "--vehicle-depth 5 -o thermo.csv",
]

#: Rewrites for the suite's time budget (the documented command → what runs instead, and why it is the same path).
SMALLER = {
    # 20 frames through the channel and the receiver take ~30 s here; 4 frames go through the same code
    "seamodem tx --preset jmse2024 --count 20 --period 3 -o beacon.wav":
        "seamodem tx --preset jmse2024 --count 4 --period 3 -o beacon.wav",
    "seamodem tx --preset jmse2024 --count 20 -o beacon.wav": "seamodem tx --preset jmse2024 --count 4 -o beacon.wav",
    # 10 minutes of audio (the page's "~2.3 s"): 30 s here
    "seamodem tx --preset jmse2024 --count 200 --period 3 -o beacon.wav":
        "seamodem tx --preset jmse2024 --count 10 --period 3 -o beacon.wav",
    # the page's 8 SNRs x 50 frames is a study; 2 SNRs x 2 frames run every line of it
    "seamodem ber --snr 0 1 2 3 4 5 6 8 --frames 50 -o ber_awgn/": "seamodem ber --snr 0 8 --frames 2 -o ber_awgn/",
    "seamodem ber --scenario examples/scenarios/decode_multipath.toml --period 3 --snr 2 4 6 8 -o ber_mp/":
        "seamodem ber --scenario examples/scenarios/decode_multipath.toml --period 3 --snr 8 --frames 2 -o ber_mp/",
}

#: Commands not run by this test, with the reason (and where they are run, when they are).
ELSEWHERE = {
    "seamodem demo": "tests/cli/test_demo.py runs the demo with small settings (the default takes minutes)",
    "seamodem demo -o DIR --snr 6 --tcom 6 --seed 3 --keep-audio": "as above: tests/cli/test_demo.py",
    "seamodem tx --preset jmse2024 --count 2 --period 1 --start 0.1 -o beacon.wav": "tests/array/test_array_cli.py",
    "seamodem channel beacon.wav --scenario S.toml --array tetra:0.08 -o rx.wav":
        "tests/array/test_array_cli.py (S.toml is the user's scenario; the test writes one)",
    "seamodem rx rx.wav --array tetra:0.08 -o m.csv": "tests/array/test_array_cli.py",
    "seamodem demo --array tetra:0.08 -o demo_array":
        "tests/array/test_array_demo.py runs it with --duration 12 (the whole survey takes minutes)",
    "seamodem tx --reference lfm:19000-29000:0.05 --count 5 --period 2 --start 0.3 -o pings.wav":
        "tests/reference/test_reference_docs.py runs docs/references.md's block as written",
    "seamodem rx pings.wav --reference pings.json -o pings_meas.csv": "tests/reference/test_reference_docs.py",
    "seamodem rx pings.wav --reference lfm:19000-29000:0.05 --emit-start 0.3 --emit-period 2 -o pings_meas.jsonl":
        "tests/reference/test_reference_docs.py",
    "seamodem tx --preset jmse2024 --count 4 -o replies.wav":
        "docs/channel.md's two-way block: two_way.toml is shown only as a fragment (clock and two_way tables); "
        "tests/channel/test_two_way.py and tests/receive/test_two_way_end_to_end.py run the chain",
    "seamodem channel replies.wav --scenario two_way.toml -o rec.wav": "as above (two-way fragment)",
    "seamodem rx rec.wav --config rec.json --turnaround 0.25 -o ranges.csv": "as above (two-way fragment)",
    "seamodem rx day.wav --segment 600 -o day.csv": "needs a recording longer than 600 s (minutes to decode)",
    "seamodem rx survey/*.wav --scheduler tcp://head:8786 -o all.csv": "needs a Dask cluster at tcp://head:8786",
    "seamodem rx /data/survey/*.wav --scheduler tcp://head:8786 -o /data/survey.csv": "needs a Dask cluster",
    "seamodem nav simulate --runs 300 --scheduler tcp://HOST:8786 -o nav/": "needs a Dask cluster",
    "seamodem ber --scenario examples/scenarios/decode_multipath.toml --period 3 --snr 1 2 3 4 5 6 --frames 100 "
    "--scheduler tcp://HOST:8786 -o ber_mp/": "needs a Dask cluster",
    "seamodem nav simulate --runs 300 -o mc/": "300 Monte Carlo missions (minutes); tests/navigation/"
                                               "test_simulate_cli.py runs nav simulate with few runs",
    "seamodem nav simulate --tcom 3 20 --runs 20 --seed 1 -q -o out_inertial/":
        "tests/navigation/test_simulate_cli.py runs docs/navigation.md's inertial-filter block",
    "seamodem nav simulate --tcom 3 20 --runs 20 --filters inertial fixed-lag batch --sigma-range 0.01 "
    "--sigma-vr 0.02 -q -o out_cm/": "tests/navigation/test_simulate_cli.py (the same block)",
    "seamodem nav simulate --paper --tcom 3 6 9 12 15 20 --runs 300 --seed 0 -o out_truth/":
        "paper 000 Tables 3-4 at 300 runs (minutes); tests/navigation/test_paper_tables.py checks --paper",
    "seamodem nav simulate --filters proposed rosb --tcom 3 6 9 12 15 20 --runs 300 --seed 0 -o out/":
        "300 runs x 6 T_com (minutes)",
    "seamodem nav simulate --paper --error-of last-fix -o out_lastfix/":
        "the default 300 runs (minutes); test_documented_simulations_run_with_fewer_runs runs it with 4",
    "seamodem nav track meas.csv --imu imu.csv --beacon 45,-25 --start 0,0 --start-speed 1 --truth truth.csv "
    "-o track.csv": "needs the demo's imu.csv and truth.csv (seamodem demo --keep-audio); tests/cli/test_demo.py",
    "seamodem nav track MEAS.csv --imu IMU.csv --beacon 50,100 --start 0,0 [--start-speed 1] "
    "[--depth 5 2 | --depth-log DEPTH.csv --beacon-depth 2]": "a synopsis (optional arguments in brackets)",
    "seamodem nav track MEAS.csv --imu IMU.csv --geodetic --beacon 48.38243,-4.407295 --start 48.3822,-4.4079 "
    "-o track.csv": "needs the user's MEAS.csv and IMU.csv logged near Brest",
    "seamodem tx --janus --sample-rate 48000 --format pcm16 --packet-cargo \"Hello JANUS\" -o hello.wav":
        "tests/cli/test_janus_docs.py runs docs/janus.md's blocks as written",
    "seamodem rx --janus hello.wav -o hello.csv": "tests/cli/test_janus_docs.py",
    "seamodem tx --janus --sample-rate 96000 --count 5 --period 3 --wut 1 --packet-app-fields "
    "StationIdentifier=42,ParameterSetIdentifier=1 -o janus_beacon.wav": "tests/cli/test_janus_docs.py",
    "seamodem rx --janus janus_beacon.wav -o janus_meas.csv": "tests/cli/test_janus_docs.py",
    "seamodem config --list": "tests/cli/test_janus_docs.py",
    "seamodem channel janus_beacon.wav --scenario examples/scenarios/straight_line.toml -o janus_received.wav":
        "tests/cli/test_janus_docs.py",
    "seamodem rx --janus janus_received.wav -o janus_received.csv": "tests/cli/test_janus_docs.py",
    "seamodem demo --waveform janus --keep-audio -o demo_janus":
        "tests/cli/test_demo_janus.py runs it with --duration 21 (the whole survey: 151 s of 96 kHz audio)",
    "seamodem rx --janus demo_janus/received.wav -o demo_janus/rx.csv":
        "tests/cli/test_demo_janus.py (rx --janus on the 21 s JANUS demo's recording)",
    "seamodem nav track demo_janus/rx.csv --imu demo_janus/imu.csv --beacon 45,-25 --start 0,0 --start-speed 1 "
    "--truth demo_janus/truth.csv -o demo_janus/track.csv": "tests/cli/test_demo_janus.py (the same, on its files)",
    "seamodem rx RECORDING.wav [--config SIDECAR.json] -o MEAS.csv": "a synopsis (placeholders)",
    "seamodem nav track meas.csv --imu imu.csv --beacon 45,-25 --start 0,0 --depth 5 25 --sound-speed-profile "
    "examples/water/thermocline_svp.csv -o track.csv":
        "needs an IMU log; tests/navigation/test_track_profile.py runs nav track --sound-speed-profile --depth",
    "seamodem rx --device 1 --sample-rate 96000 --emit-start 0 --emit-period 3 -o meas.csv":
        "needs a sound card (docs/live.md); tests/cli/test_rx_audio_server.py runs rx --device on a PulseAudio "
        "server without hardware, tests/io/test_device.py the source with a stand-in for PortAudio",
    "seamodem nav track meas.csv --follow --imu imu.csv --beacon 50,100 --start 0,0 --fixed-lag 6 -o track.csv":
        "follows a file a running rx is writing (docs/live.md); tests/navigation/test_follow.py follows a growing "
        "file, tests/cli/test_live_pipeline.py runs the whole pipe",
    "seamodem rx RECORDING.wav --emit-start 0 --emit-period 3 -o MEAS.csv":
        "a synopsis; docs/guide.md's 'seamodem rx sea.wav --emit-start 0 --emit-period 3' runs here",
}


def test_every_documented_command_is_accounted_for():
    documented = {c for _, c in documented_commands() if not is_synopsis(c)}
    assert len(documented) >= 40  # the extraction still finds the pages' commands
    unaccounted = sorted(documented - set(RUN) - set(ELSEWHERE))
    assert not unaccounted, f"documented commands neither run nor listed with a reason: {unaccounted}"
    gone = sorted((set(RUN) | set(ELSEWHERE) | set(SMALLER)) - documented)
    assert not gone, f"listed here but no longer in the docs: {gone}"
    assert not set(RUN) & set(ELSEWHERE)


def argv(command: str) -> list[str]:
    words = shlex.split(SMALLER.get(command, command))
    assert words[0] == "seamodem"
    expanded = []
    for w in words[1:]:  # the shell's globbing, for survey/*.wav
        expanded += sorted(str(p) for p in Path().glob(w)) if "*" in w else [w]
    return expanded


def test_documented_commands_run(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    (tmp_path / "notes.txt").write_text("first note\nsecond note\n", encoding="utf-8")
    for command in RUN:
        if command.startswith("seamodem rx sea.wav"):  # a recording with no sidecar: the guide's PPS case
            shutil.copy("received.wav", "sea.wav")
        if command.startswith("seamodem rx survey/"):
            Path("survey").mkdir(exist_ok=True)
            for name in ("beacon.wav", "received.wav"):
                if not (Path("survey") / name).exists():
                    shutil.copy(name, Path("survey") / name)
                    shutil.copy(Path(name).with_suffix(".json"), (Path("survey") / name).with_suffix(".json"))
        code = main(argv(command))
        assert code == 0, f"{command}: exit {code}: {capsys.readouterr().err[-1500:]}"
    for name in ("beacon.png", "my.toml", "notes.wav", "q.wav", "ber_awgn", "ber_mp", "thermo.csv"):
        assert (tmp_path / name).exists(), name
    # the last rx of meas.csv is the PPS case: 4 frames emitted at 0, 3, 6, 9 s, all heard and decoded
    meas, both = pd.read_csv("meas.csv"), pd.read_csv("all.csv")
    assert list(meas["frame_index"]) == [0, 1, 2, 3] and meas["crc_ok"].all()
    assert len(both) >= 4 and len(pd.read_json("all.jsonl", lines=True)) == len(both)


def test_documented_simulations_run_with_fewer_runs(tmp_path, monkeypatch, capsys):
    """Every documented ``nav simulate`` (minutes as written) runs as written with 4 runs at T_com = 3 s.

    The options appended come last, so they replace the page's ``--runs`` and ``--tcom``; everything else
    (filters, steering, noise, --error-of) is checked and run as the page gives it (issue 29 item 5: a
    documented command refused by the option checks).
    """
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    simulations = sorted({c for _, c in documented_commands() if c.startswith("seamodem nav simulate ")
                          and "--scheduler" not in c and not is_synopsis(c)})
    assert len(simulations) >= 5
    for command in simulations:
        code = main([*shlex.split(command)[1:], "--runs", "4", "--tcom", "3", "-q"])
        assert code == 0, f"{command}: exit {code}: {capsys.readouterr().err[-800:]}"
