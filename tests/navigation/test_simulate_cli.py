"""``seamodem nav simulate``: defaults that are results, the paper-faithful preset, and the docs' commands."""

import csv
import re
import shlex
from pathlib import Path

import pytest

from seamodem.cli import main

DOC = Path(__file__).resolve().parents[2] / "docs" / "navigation.md"
SHORT = {"lane_length_m": 30.0, "n_lanes": 2}


@pytest.fixture
def short_path(monkeypatch):
    import seamodem.navigation.montecarlo as mc

    # A short path keeps these CLI tests to seconds; the full mission runs in the benchmark.
    monkeypatch.setattr(mc.MissionConfig.__dataclass_fields__["path"], "default_factory", lambda: dict(SHORT))


def _rows(folder):
    with open(folder / "table.csv") as f:
        return list(csv.DictReader(f))


def test_default_runs_the_inertial_filter_and_prints_no_unstable_row(tmp_path, capsys, short_path):
    assert main(["nav", "simulate", "--tcom", "3", "6", "--runs", "6", "-q", "-o", str(tmp_path / "sim")]) == 0
    rows = _rows(tmp_path / "sim")
    assert [(r["tcom_s"], r["filter"]) for r in rows] == [("3.0", "inertial"), ("6.0", "inertial")]
    assert all(r["diverged"] == "0" for r in rows)
    out = capsys.readouterr().out
    assert "UNSTABLE" not in out and "per estimator" in out
    assert "noise: range 0.01 m, v_r 0.02 m/s" in out and "at its own noise" in out  # receiver-grade, said so
    assert (tmp_path / "sim" / "fig7_top_view.png").exists() and (tmp_path / "sim" / "fig8_error.png").exists()


def test_paper_preset_is_the_faithful_reproduction(tmp_path, capsys, short_path):
    assert main(["nav", "simulate", "--paper", "--tcom", "3", "--runs", "5", "-q", "-o", str(tmp_path / "p")]) == 0
    rows = _rows(tmp_path / "p")
    assert list(rows[0]) == ["tcom_s", "filter", "mean_error_m", "error_variance_m2", "etd_max_pct",
                             "etd_mean_pct", "outliers", "diverged", "median_error_m"]
    assert [r["filter"] for r in rows] == ["proposed", "rosb"]
    assert "controller steers on the truth" in capsys.readouterr().out


def test_unstable_rows_are_flagged_not_presented(tmp_path, capsys):
    """The paper's EKF told the true centimetre noise, steering on the estimate: diverges, and says so."""
    code = main(["nav", "simulate", "--tcom", "3", "--runs", "8", "--seed", "1", "--sigma-range", "0.02",
                 "--sigma-vr", "0.02", "--matched-r", "--filters", "proposed", "inertial", "-q",
                 "-o", str(tmp_path / "u")])
    assert code == 0
    rows = {r["filter"]: r for r in _rows(tmp_path / "u")}
    assert int(rows["proposed"]["diverged"]) > 0 and rows["inertial"]["diverged"] == "0"
    out = capsys.readouterr().out
    # every run diverged and none is an IQR outlier: the mean holds them, is marked '!' and said not to be a result
    assert re.search(rf"{float(rows['proposed']['mean_error_m']):.3f} \(  0,  8\)!", out)
    assert "8 are inside the means marked '!': those means are not results" in out


def test_paper_table_states_its_means_with_the_diverged_runs_beside_them(tmp_path, capsys):
    """Issue 29 item 6: --paper printed UNSTABLE in every row; the means were only in table.csv."""
    assert main(["nav", "simulate", "--paper", "--tcom", "3", "12", "--runs", "20", "--seed", "0", "-q",
                 "-o", str(tmp_path / "p")]) == 0
    out = capsys.readouterr().out
    rows = _rows(tmp_path / "p")
    assert sum(int(r["diverged"]) for r in rows) > 0  # the case the issue met
    assert "UNSTABLE" not in out
    for r in rows:  # each row's mean, outliers and diverged runs as table.csv has them
        cell = f"{float(r['mean_error_m']):.3f} ({int(r['outliers']):>3}, {int(r['diverged']):>2})"
        assert out.count(cell) >= 1, (cell, out)
    assert "diverged = runs whose error exceeded 50 m at some time (the filter lost the vehicle)" in out
    assert "are among the outliers, outside the means" in out and "'!'" not in out


def test_paper_noise_and_array_bearing_options(tmp_path, capsys, short_path):
    assert main(["nav", "simulate", "--paper-noise", "--sigma-bearing", "1", "--tcom", "3", "--runs", "5", "-q",
                 "-o", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "noise: range 3.46 m, v_r 0.447 m/s" in out and "array bearing 1 deg" in out
    assert main(["nav", "simulate", "--sigma-bearing", "-1", "--runs", "5", "-o", str(tmp_path / "n")]) != 0
    assert "--sigma-bearing" in capsys.readouterr().err and not (tmp_path / "n").exists()


def test_error_of_is_refused_for_the_inertial_filter(capsys):
    assert main(["nav", "simulate", "--error-of", "smoothed", "--runs", "5", "-o", "/tmp/never"]) != 0
    assert "--error-of" in capsys.readouterr().err


@pytest.mark.slow
def test_the_docs_simulate_commands_run(tmp_path, monkeypatch):
    block = DOC.read_text(encoding="utf-8").split("## The inertial filter", 1)[1].split("```")[1]
    commands = [line.split("#")[0].strip() for line in block.splitlines() if line.startswith("seamodem nav simulate")]
    assert len(commands) == 2
    monkeypatch.chdir(tmp_path)
    for command in commands:
        # with 4 runs instead of the page's 20 (appended last, it replaces the page's --runs: 36 s -> about 10 s
        # of the suite); every other option as written. The page's figures are the benchmark's
        assert main([*shlex.split(command)[1:], "--runs", "4"]) == 0, command
