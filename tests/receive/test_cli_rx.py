"""``seamodem rx`` end to end, and every bad input of issue 4: one line, exit 2, no output file."""

import dataclasses
import math
import json

import numpy as np
import pytest
import soundfile

from seamodem import BeaconSchedule, get_preset, write_beacon
from seamodem.cli import main
from seamodem.receive import MeasurementRecord, read_measurements, write_measurements

CFG = get_preset("jmse2024")
FS = int(CFG.sample_rate_hz)
SHIFT = 19231  # samples of delay, ≈ 300 m
DELAY_S = SHIFT / FS


@pytest.fixture(scope="module")
def beacon(tmp_path_factory):
    """Three frames written by the transmitter, and a copy delayed by DELAY_S with noise."""
    d = tmp_path_factory.mktemp("rx")
    wav = d / "beacon.wav"
    sidecar = write_beacon(wav, CFG, BeaconSchedule(count=3, period_s=1.0, start_s=0.1), progress=False)
    x, fs = soundfile.read(wav)
    y = np.concatenate([np.zeros(SHIFT), x]) + 0.003 * np.random.default_rng(0).standard_normal(len(x) + SHIFT)
    delayed = d / "delayed.wav"
    soundfile.write(delayed, y, fs, subtype="FLOAT")
    side = dict(sidecar, recording=dict(sidecar["recording"], file="delayed.wav", n_samples=len(y)))
    (d / "delayed.json").write_text(json.dumps(side))
    return d, wav, delayed, sidecar


def _same(a, b) -> bool:
    """Records equal field by field, NaN equal to NaN (not decoded, unknown)."""
    da, db = a.to_dict(), b.to_dict()
    return da.keys() == db.keys() and all(
        (isinstance(v, float) and math.isnan(v) and math.isnan(db[k])) or v == db[k] for k, v in da.items()
    )


def _fail(capsys, argv, expected):
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and err.startswith("seamodem rx: error:")
    assert expected in err
    return err


def test_happy_path_csv_with_the_recordings_own_sidecar(beacon, tmp_path, capsys):
    _, _, delayed, _ = beacon
    out = tmp_path / "m.csv"
    assert main(["rx", str(delayed), "-o", str(out), "-q"]) == 0
    recs, header = read_measurements(out)
    assert header["sound_speed_mps"] == 1500.0 and header["config"]["name"] == "jmse2024"
    assert [r.frame_index for r in recs] == [0, 1, 2]
    # integer-sample delay, in-band SNR ≈ 40 dB: CRLB 0.2 mm, plus the pilot's 0.4 mm self-noise
    assert np.allclose([r.range_m for r in recs], 1500.0 * DELAY_S, atol=1e-3)
    assert np.allclose([r.v_r_mps for r in recs], 0.0, atol=1e-3)


def test_emit_schedule_jsonl_sound_speed_and_clock_offset(beacon, tmp_path):
    _, _, delayed, _ = beacon
    out = tmp_path / "m.jsonl"
    argv = ["rx", str(delayed), "--config", str(beacon[0] / "delayed.json"), "--emit-start", "0.1",
            "--emit-period", "1.0", "--sound-speed", "1480", "--clock-offset", "0.05", "-o", str(out), "-q"]
    assert main(argv) == 0
    recs, header = read_measurements(out)
    assert header["sound_speed_mps"] == 1480.0
    assert np.allclose([r.tof_s for r in recs], DELAY_S - 0.05, atol=1e-6)  # 1.5 mm at c
    assert np.allclose([r.range_m for r in recs], 1480.0 * (DELAY_S - 0.05), atol=1e-3)
    # the header holds every receiver setting, as ReceiverSettings.to_dict() gives them
    from seamodem.receive.settings import ReceiverSettings

    settings = ReceiverSettings.from_dict(header)
    assert settings == ReceiverSettings(sound_speed_mps=1480.0, clock_offset_s=0.05, decode=True)
    assert {k: header[k] for k in settings.to_dict()} == settings.to_dict()


def test_plots_are_written(beacon, tmp_path):
    _, _, delayed, _ = beacon
    assert main(["rx", str(delayed), "-o", str(tmp_path / "m.csv"), "--plot", str(tmp_path), "--plot-frames", "1",
                 "-q"]) == 0
    assert len(list(tmp_path.glob("frame_*.png"))) == 1


def test_other_sample_rate_is_resampled(beacon, tmp_path):
    """The same recording at 192 kHz (FFT-resampled, exact for this band) is measured alike."""
    d, _, delayed, _ = beacon
    from scipy.signal import resample_poly

    x, fs = soundfile.read(delayed)
    up = d / "up.wav"
    soundfile.write(up, resample_poly(x, 2, 1), 2 * fs, subtype="FLOAT")
    (d / "up.json").write_text((d / "delayed.json").read_text())
    out = tmp_path / "m.csv"
    assert main(["rx", str(up), "-o", str(out), "-q"]) == 0
    recs, _ = read_measurements(out)
    assert np.allclose([r.range_m for r in recs], 1500.0 * DELAY_S, atol=2e-3)


def test_missing_empty_non_audio_files(tmp_path, capsys, beacon):
    out = tmp_path / "m.csv"
    side = str(beacon[0] / "delayed.json")
    _fail(capsys, ["rx", str(tmp_path / "none.wav"), "--config", side, "-o", str(out)], "not found")
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    _fail(capsys, ["rx", str(empty), "--config", side, "-o", str(out)], "empty")
    text = tmp_path / "notes.wav"
    text.write_text("not audio at all\n" * 10)
    _fail(capsys, ["rx", str(text), "--config", side, "-o", str(out)], "not a readable audio file")
    assert not out.exists()


def _lying_header(data: bytes, declared: int) -> bytes:
    """The WAV ``data`` with its RIFF and data-chunk sizes set to ``declared`` (a streaming or crashed recorder)."""
    out = bytearray(data)
    i = out.find(b"data")
    out[4:8] = out[i + 4 : i + 8] = declared.to_bytes(4, "little")
    return bytes(out)


@pytest.mark.parametrize("variant", ["ffffffff", "zero", "cut in half"])
def test_recordings_whose_header_lies_are_decoded_as_far_as_they_go(beacon, tmp_path, capsys, variant):
    """Every frame complete in the file decodes as in the clean file; the header's lie is one warning line."""
    _, _, delayed, _ = beacon
    side = str(beacon[0] / "delayed.json")
    clean = tmp_path / "clean.csv"
    assert main(["rx", str(delayed), "--config", side, "-o", str(clean), "-q"]) == 0
    capsys.readouterr()
    data = delayed.read_bytes()
    body = {"ffffffff": _lying_header(data, 0xFFFFFFFF), "zero": _lying_header(data, 0),
            "cut in half": data[: len(data) // 2 + 1]}[variant]  # +1: the last sample is cut in the middle
    wav = tmp_path / "lying.wav"
    wav.write_bytes(body)
    out = tmp_path / "m.csv"
    assert main(["rx", str(wav), "--config", side, "-o", str(out), "-q"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    header_lines = [line for line in err if "the header says" in line]
    assert len(header_lines) == 1 and header_lines[0].startswith("seamodem rx: warning: recording ")
    n_present = (len(body) - data.find(b"data") - 8) // 4  # FLOAT mono: 4 bytes a sample after the data chunk's head
    assert f"the file holds {n_present} samples" in header_lines[0]
    want, _ = read_measurements(clean)
    got, _ = read_measurements(out)
    end_s = n_present / FS
    complete = [r for r in want if r.t_arrival_s + CFG.frame_duration_s + 0.1 < end_s]
    assert len(complete) == (3 if variant != "cut in half" else 1)
    if variant != "cut in half":
        # the same samples reach the receiver: records equal, digit for digit (NaN where both are unknown)
        assert all(_same(a, b) for a, b in zip(got[: len(complete)], complete, strict=True))
    for a, b in zip(got[: len(complete)], complete, strict=True):
        assert (a.frame_index, a.crc_ok, a.payload_hex, a.payload_text) == (b.frame_index, True, b.payload_hex,
                                                                           b.payload_text)
        # a shorter file ends on a shorter block, whose FFT size differs: rounding-level changes (seen: 1.2e-7)
        np.testing.assert_allclose([a.t_arrival_s, a.range_m, a.v_r_mps, a.snr_db, a.detection_rho],
                                   [b.t_arrival_s, b.range_m, b.v_r_mps, b.snr_db, b.detection_rho], rtol=1e-6)


def test_nan_sample_is_an_error_naming_where_it_is(tmp_path, capsys, beacon):
    _, _, delayed, _ = beacon
    out = tmp_path / "m.csv"
    x, fs = soundfile.read(delayed)
    x[100_000] = np.nan
    nan = tmp_path / "nan.wav"
    soundfile.write(nan, x, fs, subtype="FLOAT")
    _fail(capsys, ["rx", str(nan), "--config", str(beacon[0] / "delayed.json"), "-o", str(out)],
          "NaN or infinite samples (first at sample 100000)")
    assert not out.exists() and not out.with_name("m.csv.json").exists()


def test_empty_data_and_header_only_files_are_one_line_errors(tmp_path, capsys, beacon):
    _, _, delayed, _ = beacon
    out = tmp_path / "m.csv"
    data = delayed.read_bytes()
    header_only = tmp_path / "header.wav"
    header_only.write_bytes(_lying_header(data[: data.find(b"data") + 8], 0))
    _fail(capsys, ["rx", str(header_only), "--config", str(beacon[0] / "delayed.json"), "-o", str(out)],
          "holds no samples")
    assert not out.exists()


def test_sidecar_that_does_not_match(tmp_path, capsys, beacon):
    _, _, delayed, sidecar = beacon
    late = dict(sidecar, frames=[dict(f, t_emit_s=f["t_emit_s"] + 100.0) for f in sidecar["frames"]])
    bad = tmp_path / "late.json"
    bad.write_text(json.dumps(late))
    out = tmp_path / "m.csv"
    _fail(capsys, ["rx", str(delayed), "--config", str(bad), "-o", str(out)], "does not match")
    assert not out.exists()


def test_no_emission_times_and_multichannel(tmp_path, capsys, beacon):
    x, fs = soundfile.read(beacon[2])
    lone = tmp_path / "lone.wav"
    soundfile.write(lone, x, fs)
    out = tmp_path / "m.csv"
    _fail(capsys, ["rx", str(lone), "-o", str(out)], "emission times unknown")
    stereo = tmp_path / "stereo.wav"
    soundfile.write(stereo, np.stack([x, x], axis=1), fs, subtype="FLOAT")
    _fail(capsys, ["rx", str(stereo), "--emit-start", "0.1", "--emit-period", "1", "-o", str(out)], "--channel")
    assert main(["rx", str(stereo), "--emit-start", "0.1", "--emit-period", "1", "--channel", "1", "-o", str(out),
                 "-q"]) == 0
    assert len(read_measurements(out)[0]) == 3


@pytest.mark.parametrize("kind", ["zeros", "noise", "clipped"])
def test_degraded_recordings_warn(tmp_path, capsys, kind):
    n = 3 * FS
    rng = np.random.default_rng(1)
    x = {"zeros": np.zeros(n), "noise": 0.1 * rng.standard_normal(n), "clipped": np.clip(rng.standard_normal(n), -1, 1)}[
        kind
    ]
    wav = tmp_path / "x.wav"
    soundfile.write(wav, x, FS, subtype="PCM_16")
    out = tmp_path / "m.csv"
    assert main(["rx", str(wav), "--emit-start", "0", "--emit-period", "1", "-o", str(out), "-q"]) == 0
    err = capsys.readouterr().err
    assert "no frame found" in err
    assert {"zeros": "silent", "noise": "no frame", "clipped": "clipped"}[kind] in err
    recs, header = read_measurements(out)
    assert recs == [] and header["format"] == "seamodem.measurements/2" and header["rows"] == 0  # honest empty


def test_records_round_trip(tmp_path):
    rec = MeasurementRecord(
        frame_index=3, t_emit_s=9.0, t_arrival_s=9.2, tof_s=0.2, range_m=300.0, v_r_mps=-1.25, snr_db=11.0,
        v_r_tone_eq9_mps=-1.2, v_r_bank_mps=-1.3, detection_z=500.0, detection_rho=0.6, sigma_range_m=0.002,
        sigma_v_r_mps=6e-4, sigma_v_r_bank_mps=0.02, tone_c_n0_dbhz=50.0, two_way=True, crc_ok=None,
    )
    decoded = dataclasses.replace(
        rec, two_way=False, crc_ok=True, payload_hex="68692c2031", payload_text="hi, 1", eq_snr_db=12.5,
        decode_passes=2, ber=0.0, raw_ber=0.0125,
    )
    failed = dataclasses.replace(decoded, crc_ok=False, payload_hex="", payload_text="", ber=0.25)

    for suffix in ("csv", "jsonl"):
        path = tmp_path / f"m.{suffix}"
        write_measurements(path, [rec, decoded, failed], {"sound_speed_mps": 1500.0})
        back, header = read_measurements(path)
        assert len(back) == 3 and header["sound_speed_mps"] == 1500.0
        assert all(_same(a, b) for a, b in zip(back, [rec, decoded, failed]))
        assert back[0].crc_ok is None and back[1].crc_ok is True and back[2].crc_ok is False


def test_two_way_ranging_from_the_command_line(tmp_path):
    """Polls at 0.1 + 2k s; the beacon, 300 m away, replies 0.5 s after hearing each poll."""
    d, turnaround, c = 300.0, 0.5, 1500.0
    first_reply = 0.1 + turnaround + 2 * d / c  # the reply's frame start at the vehicle
    wav = tmp_path / "replies.wav"
    write_beacon(wav, CFG, BeaconSchedule(count=2, period_s=2.0, start_s=first_reply), progress=False)
    out = tmp_path / "m.csv"
    argv = ["rx", str(wav), "--emit-start", "0.1", "--emit-period", "2", "--turnaround", str(turnaround), "-o",
            str(out), "-q"]
    assert main(argv) == 0
    recs, header = read_measurements(out)
    assert header["turnaround_s"] == turnaround
    assert [r.frame_index for r in recs] == [0, 1] and all(r.two_way for r in recs)
    assert np.allclose([r.range_m for r in recs], d, atol=1e-3)  # noise-free: the 0.4 mm self-noise, halved


def test_arrival_before_the_first_emission_is_reported_not_written(beacon, tmp_path, capsys):
    """Issue 14: emissions from 1.1 s on, the first frame arrives at 0.3 s: no emission, so no range."""
    _, _, delayed, _ = beacon
    out = tmp_path / "m.csv"
    assert main(["rx", str(delayed), "--emit-start", "1.1", "--emit-period", "1", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "wrote" in captured.out and "2 frames measured" in captured.out
    assert "1 arrival(s) before the first emission not written" in captured.out
    warning = [line for line in captured.err.splitlines() if "before the first emission" in line]
    assert len(warning) == 1 and warning[0].startswith("seamodem rx: warning: 1 arrival(s)")
    import pandas as pd

    df = pd.read_csv(out)
    assert list(df["frame_index"]) == [0, 1]
    assert np.isfinite(df[["t_emit_s", "tof_s", "range_m"]].to_numpy()).all()
    meta = json.loads(out.with_name("m.csv.json").read_text())
    assert meta["rows"] == 2 and len(meta["unmatched_arrivals_s"]) == 1
    assert meta["unmatched_arrivals_s"][0] == pytest.approx(0.1 + DELAY_S, abs=1e-3)


def test_plot_folder_is_created_and_channel_numbering_is_named(beacon, tmp_path, capsys):
    _, _, delayed, _ = beacon
    figures = tmp_path / "new" / "figures"
    assert main(["rx", str(delayed), "-o", str(tmp_path / "m.csv"), "--plot", str(figures), "--plot-frames", "1",
                 "-q"]) == 0
    assert len(list(figures.glob("frame_*.png"))) == 1
    x, fs = soundfile.read(delayed)
    stereo = tmp_path / "stereo.wav"
    soundfile.write(stereo, np.stack([x, x], axis=1), fs, subtype="FLOAT")
    err = _fail(capsys, ["rx", str(stereo), "--config", str(beacon[0] / "delayed.json"), "--channel", "2", "-o",
                         str(tmp_path / "s.csv")], "channel 2 does not exist")
    assert "numbered from 0 (0 to 1)" in err


def test_a_mat_frame_recording_takes_its_rate_and_variable_from_the_options(tmp_path, capsys):
    """A frame recording saved as .mat (field recorders' way) without a rate: --sample-rate and --mat-variable
    reach it, as with --reference (they were refused: 'only with --reference')."""
    import shutil

    import pandas as pd
    import soundfile
    from scipy.io import savemat

    wav = tmp_path / "b.wav"
    assert main(["tx", "--count", "2", "--period", "1", "-o", str(wav), "-q"]) == 0
    x, fs = soundfile.read(wav)
    savemat(tmp_path / "rec.mat", {"hydrophone": x[:, None]})
    shutil.copy(tmp_path / "b.json", tmp_path / "rec.json")
    out = tmp_path / "m.csv"
    assert main(["rx", str(tmp_path / "rec.mat"), "-o", str(out), "-q"]) == 2  # no rate in the file
    assert "sample-rate" in capsys.readouterr().err
    assert main(["rx", str(tmp_path / "rec.mat"), "--sample-rate", str(fs), "--mat-variable", "hydrophone",
                 "-o", str(out), "-q"]) == 0
    table = pd.read_csv(out)
    assert len(table) == 2 and table["crc_ok"].all()
