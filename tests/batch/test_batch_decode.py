"""decode_files: several recordings and segmented long ones, on every backend, resumable."""

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import soundfile

import seamodem.batch.decode as batch_decode
from seamodem import BeaconSchedule, get_preset, render_beacon
from seamodem.batch import decode_files, min_overlap_s
from seamodem.batch.decode import Recording
from seamodem.errors import ConfigError
from seamodem.receive import Emissions, ReceiverSettings, receive_file
from seamodem.receive.records import read_measurements

distributed = pytest.importorskip("distributed")

CFG = get_preset("jmse2024")
FS = int(CFG.sample_rate_hz)
PERIOD_S = 1.0
EMIT = Emissions(start_s=0.0, period_s=PERIOD_S)
C = 1500.0


def write_recording(path, *, count, first_emit_s, delay_s, seed, noise=0.003):
    """Frames emitted at first_emit_s + k·PERIOD_S, heard delay_s later, in white noise."""
    sig = render_beacon(CFG, BeaconSchedule(count=count, period_s=PERIOD_S, start_s=first_emit_s))
    x = np.concatenate(list(sig.blocks(progress=False)))
    x *= 0.5 / np.max(np.abs(x))
    shift = round(delay_s * FS)
    y = np.concatenate([np.zeros(shift), x, np.zeros(FS // 2)])
    y += noise * np.random.default_rng(seed).standard_normal(len(y))
    soundfile.write(path, y, FS, subtype="FLOAT")
    return shift / FS


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("batch")
    paths = []
    for i, delay in enumerate((0.1, 0.15, 0.2)):
        p = d / f"rec{i}.wav"
        write_recording(p, count=4 + i, first_emit_s=0.0, delay_s=delay, seed=i)
        paths.append(p)
    return paths


def as_rows(records):
    """Records as JSON text: exact floats (repr), and NaN equal to NaN (unlike in a dict compare)."""
    return json.dumps([r.to_dict() for r in records])


def test_multi_file_decode_is_identical_on_every_backend_and_matches_receive_file(recordings, dask_client):
    serial = decode_files(recordings, CFG, emissions=EMIT, backend="serial", progress=False)
    procs = decode_files(recordings, CFG, emissions=EMIT, backend="processes", workers=2, progress=False)
    dask = decode_files(recordings, CFG, emissions=EMIT, backend="dask", scheduler=dask_client, progress=False)
    assert serial.ok and procs.ok and dask.ok
    # bit for bit
    assert as_rows(serial.records) == as_rows(procs.records) == as_rows(dask.records)
    # each whole recording gives exactly what the single-file receiver gives, tagged with its source
    expected = []
    for p in recordings:
        expected += [replace(r, source=str(p)) for r in receive_file(p, CFG, emissions=EMIT, progress=False)]
    assert as_rows(serial.records) == as_rows(expected)
    assert [r.source for r in serial.records] == [str(recordings[0])] * 4 + [str(recordings[1])] * 5 + [
        str(recordings[2])
    ] * 6


@pytest.mark.parametrize("phase_s", [-0.2, -0.001, 0.0, 0.001, 0.15])
def test_frames_across_every_segment_boundary_are_found_once(tmp_path, phase_s):
    """Segments of 1 s and a frame every 1 s arriving ``phase_s`` from each boundary.

    phase −0.2 / +0.15: the boundary cuts the frame; ±1 ms and 0: the arrival
    itself sits at the boundary, where both neighbours see the frame.
    """
    path = tmp_path / "long.wav"
    delay = 0.3 + phase_s  # emission at 0.7 + k → arrival at 1.0 + k + phase
    delay = write_recording(path, count=6, first_emit_s=0.7, delay_s=delay, seed=3)
    emit = Emissions(start_s=0.7, period_s=PERIOD_S)
    whole = list(receive_file(path, CFG, emissions=emit, progress=False))
    assert [r.frame_index for r in whole] == list(range(6))
    np.testing.assert_allclose([r.tof_s for r in whole], delay, atol=1e-6)  # SNR ≈ 40 dB: CRLB ≈ 0.1 µs
    for segment_s in (1.0, 2.0):
        result = decode_files([path], CFG, emissions=emit, segment_s=segment_s, backend="serial", progress=False)
        assert result.ok and result.n_parts == int(np.ceil(len(soundfile.read(path)[0]) / FS / segment_s))
        assert [r.frame_index for r in result.records] == [r.frame_index for r in whole]
        # the front end starts at another sample in a segment: the estimates agree to a few ns, not bit for bit
        np.testing.assert_allclose([r.t_arrival_s for r in result.records], [r.t_arrival_s for r in whole],
                                   rtol=0, atol=1e-7)
        np.testing.assert_allclose([r.tof_s for r in result.records], [r.tof_s for r in whole], rtol=0, atol=1e-7)
        np.testing.assert_allclose([r.v_r_mps for r in result.records], [r.v_r_mps for r in whole], rtol=0,
                                   atol=1e-5)
        assert [r.t_emit_s for r in result.records] == [r.t_emit_s for r in whole]


def test_segmented_decode_is_identical_across_backends(recordings, dask_client):
    kw = {"emissions": EMIT, "segment_s": 2.0, "progress": False}
    a = decode_files(recordings, CFG, backend="serial", **kw)
    b = decode_files(recordings, CFG, backend="processes", workers=2, **kw)
    c = decode_files(recordings, CFG, backend="dask", scheduler=dask_client, **kw)
    assert a.n_parts > len(recordings)
    assert as_rows(a.records) == as_rows(b.records) == as_rows(c.records)
    assert len(a.records) == 4 + 5 + 6


def test_overlap_shorter_than_a_frame_is_refused(recordings):
    rec = Recording(recordings[0], CFG, EMIT)
    assert min_overlap_s(rec) > CFG.frame_duration_s
    with pytest.raises(ConfigError, match="overlap: must be at least a frame's span"):
        decode_files([rec], segment_s=1.0, overlap_s=CFG.frame_duration_s, backend="serial")


def test_failed_file_is_reported_and_resume_skips_finished_parts(recordings, tmp_path):
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF....WAVEnot audio")
    files = [recordings[0], bad, recordings[1]]
    out = tmp_path / "all.csv"
    first = decode_files(files, CFG, emissions=EMIT, output=out, backend="processes", workers=2, progress=False)
    assert not first.ok and [f.label for f in first.failures] == [str(bad)]
    assert "not a readable audio file" in first.failures[0].error
    written, header = read_measurements(out)
    assert [r.source for r in written] == [str(recordings[0])] * 4 + [str(recordings[1])] * 5  # nothing lost
    assert header["recordings"] == [str(p) for p in files]
    parts = out.with_name("all.csv.parts")
    assert len(list(parts.glob("*.json"))) == 2

    # the bad file is replaced by a real one: a rerun decodes only it
    bad.unlink()
    good = tmp_path / "good.wav"
    write_recording(good, count=3, first_emit_s=0.0, delay_s=0.07, seed=9)
    files[1] = good
    calls = []
    second = decode_files(files, CFG, emissions=EMIT, output=out, resume=True, backend="serial",
                          progress=lambda done, total: calls.append(total))
    assert second.ok and second.n_resumed == 2 and calls == [1]
    fresh = decode_files(files, CFG, emissions=EMIT, backend="serial", progress=False)
    # parts read back from the manifest are the same numbers as decoded now
    assert as_rows(second.records) == as_rows(fresh.records)
    assert as_rows(read_measurements(out)[0]) == as_rows(fresh.records)
    assert not parts.exists()  # all done: the manifest is removed


def test_resume_ignores_parts_of_other_options(recordings, tmp_path):
    out = tmp_path / "m.jsonl"
    decode_files(recordings[:1], CFG, emissions=EMIT, output=out, backend="serial", progress=False)
    other = decode_files(recordings[:1], CFG, emissions=EMIT, output=out, resume=True, backend="serial",
                         progress=False, settings=ReceiverSettings(sound_speed_mps=1480.0))
    assert other.n_resumed == 0  # the manifest was removed, and its key holds the sound speed anyway
    assert other.records[0].range_m == pytest.approx(1480.0 * other.records[0].tof_s)


_real_decode_part = batch_decode.decode_part


def decode_part_dying_once(part):
    """The real task, except that the worker decoding the second recording dies the first time."""
    marker = Path(os.environ["SEAMODEM_TEST_MARKER"])
    if part.file_index == 1 and not marker.exists():
        marker.write_text("x")
        os._exit(1)
    return _real_decode_part(part)


def test_worker_killed_while_decoding_a_file_then_the_file_is_retried(recordings, tmp_path, monkeypatch):
    monkeypatch.setenv("SEAMODEM_TEST_MARKER", str(tmp_path / "died"))
    monkeypatch.setattr(batch_decode, "decode_part", decode_part_dying_once)
    out = tmp_path / "all.csv"
    result = decode_files(recordings, CFG, emissions=EMIT, output=out, backend="processes", workers=2,
                          progress=False)
    assert (tmp_path / "died").exists()
    assert result.ok and len(result.records) == 4 + 5 + 6
    reference = decode_files(recordings, CFG, emissions=EMIT, backend="serial", progress=False)
    assert as_rows(result.records) == as_rows(reference.records)


def test_manifest_part_is_plain_json(recordings, tmp_path):
    out = tmp_path / "m.csv"
    bad = tmp_path / "missing.wav"
    decode_files([recordings[0], bad], CFG, emissions=EMIT, output=out, backend="serial", progress=False)
    (part,) = out.with_name("m.csv.parts").glob("*.json")
    data = json.loads(part.read_text())
    assert data["format"] == "seamodem.batch-part/1" and data["source"] == str(recordings[0])
    assert len(data["records"]) == 4
