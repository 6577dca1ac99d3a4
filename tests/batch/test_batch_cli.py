"""``seamodem rx`` over several recordings and segments: merged output, per-file failures, resume."""

import json

import numpy as np
import pytest
import soundfile

from seamodem import BeaconSchedule, get_preset, write_beacon
from seamodem.cli import main
from seamodem.receive import read_measurements

CFG = get_preset("jmse2024")


def _noisy_beacon(path, *, count, start_s, seed):
    """A beacon recording with its sidecar, plus white noise (in-band SNR ≈ 40 dB)."""
    write_beacon(path, CFG, BeaconSchedule(count=count, period_s=1.0, start_s=start_s), progress=False)
    x, fs = soundfile.read(path)
    soundfile.write(path, x + 0.003 * np.random.default_rng(seed).standard_normal(len(x)), fs, subtype="FLOAT")


@pytest.fixture(scope="module")
def beacons(tmp_path_factory):
    d = tmp_path_factory.mktemp("rxbatch")
    paths = [d / f"rec{i}.wav" for i in range(3)]
    for i, p in enumerate(paths):
        _noisy_beacon(p, count=2 + i, start_s=0.1 + 0.05 * i, seed=i)
    return paths


def _rows(path, **changes):
    recs, _ = read_measurements(path)
    return json.dumps([r.to_dict() | changes for r in recs])


def test_several_recordings_give_one_file_equal_to_single_runs(beacons, tmp_path):
    out = tmp_path / "all.csv"
    assert main(["rx", *map(str, beacons), "-o", str(out), "--workers", "2", "-q"]) == 0
    recs, header = read_measurements(out)
    assert [r.source for r in recs] == [str(beacons[0])] * 2 + [str(beacons[1])] * 3 + [str(beacons[2])] * 4
    assert header["recordings"] == [str(p) for p in beacons] and header["sound_speed_mps"] == 1500.0
    assert all(r.crc_ok for r in recs)  # payloads decoded, as for a single recording
    merged = json.loads(_rows(out))
    i = 0
    for p in beacons:
        single = tmp_path / f"{p.stem}.csv"
        assert main(["rx", str(p), "-o", str(single), "-q"]) == 0
        expected = json.loads(_rows(single, source=str(p)))
        assert merged[i : i + len(expected)] == expected  # the same numbers, to the last bit
        i += len(expected)
    assert i == len(merged)


def test_long_recording_in_segments_finds_every_frame_once(tmp_path):
    long = tmp_path / "long.wav"
    _noisy_beacon(long, count=7, start_s=0.2, seed=7)
    whole, segmented = tmp_path / "whole.csv", tmp_path / "seg.jsonl"
    assert main(["rx", str(long), "-o", str(whole), "-q"]) == 0
    assert main(["rx", str(long), "--segment", "1.5", "-o", str(segmented), "-q"]) == 0
    a, _ = read_measurements(whole)
    b, header = read_measurements(segmented)
    assert header["segment_s"] == 1.5
    assert [r.frame_index for r in b] == [r.frame_index for r in a] == list(range(7))
    np.testing.assert_allclose([r.t_arrival_s for r in b], [r.t_arrival_s for r in a], rtol=0, atol=1e-7)
    assert [r.payload_hex for r in b] == [r.payload_hex for r in a]


def test_a_failing_file_is_reported_the_rest_kept_and_resume_finishes(beacons, tmp_path, capsys):
    lonely = tmp_path / "nosidecar.wav"
    x, fs = soundfile.read(beacons[0])
    soundfile.write(lonely, x, fs, subtype="FLOAT")  # no sidecar beside it: emission times unknown
    out = tmp_path / "all.csv"
    argv = ["rx", str(beacons[0]), str(lonely), str(beacons[1]), "-o", str(out)]
    assert main(argv) == 1
    captured = capsys.readouterr()
    assert f"seamodem rx: failed: {lonely}: emission times unknown" in captured.err
    assert "1 failed" in captured.out
    recs, _ = read_measurements(out)
    assert [r.source for r in recs] == [str(beacons[0])] * 2 + [str(beacons[1])] * 3
    # the sidecar is supplied: only that file is decoded on the rerun
    (tmp_path / "nosidecar.json").write_text(beacons[0].with_suffix(".json").read_text())
    assert main([*argv, "--resume"]) == 0
    assert "2 from an earlier run" in capsys.readouterr().out
    recs, _ = read_measurements(out)
    assert [r.source for r in recs] == [str(beacons[0])] * 2 + [str(lonely)] * 2 + [str(beacons[1])] * 3
    assert not (tmp_path / "all.csv.parts").exists()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--plot", "."], "plot: figures are drawn for a single recording only"),
        (["--workers", "0"], "workers: must be >= 1, got 0"),
        (["--segment", "-1"], "segment: must be a positive number of seconds, got -1.0"),
    ],
)
def test_bad_batch_options_are_one_line_errors(beacons, tmp_path, capsys, extra, message):
    assert main(["rx", *map(str, beacons[:2]), "-o", str(tmp_path / "m.csv"), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("seamodem rx: error:") and message in err
