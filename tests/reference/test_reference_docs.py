"""The commands docs/references.md shows run as written."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pandas as pd

from seamodem.cli import main

PAGE = Path(__file__).resolve().parents[2] / "docs" / "references.md"


def test_try_it_commands_run(tmp_path, monkeypatch):
    block = re.search(r"## Try it\n\n```sh\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S).group(1)
    commands = [shlex.split(line) for line in block.splitlines() if line.strip()]
    assert len(commands) == 3 and all(c[0] == "seamodem" for c in commands)
    monkeypatch.chdir(tmp_path)
    for argv in commands:
        assert main(argv[1:]) == 0, argv
    csv, jsonl = pd.read_csv("pings_meas.csv"), pd.read_json("pings_meas.jsonl", lines=True)
    assert len(csv) == len(jsonl) == 5
    # no channel in between: heard when emitted, at the emitter's sample grid
    assert (csv["tof_s"].abs() < 1e-6).all() and list(jsonl["frame_index"]) == [0, 1, 2, 3, 4]
