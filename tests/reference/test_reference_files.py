"""Recordings as they come: every input format round-trips through ``seamodem rx --reference``, bad ones fail in one line."""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
import scipy.io
import soundfile

from seamodem.cli import main

from independent import add_noise, chirp_ping, received

SPEC = "lfm:19000-29000:0.05"
PING = partial(chirp_ping, f0=19e3, f1=29e3, duration_s=0.05, method="linear")
ARRIVALS = np.array([0.3137, 1.3389, 2.3021])  # emitted at 0, 1, 2 s: tof = 0.3137 s, 0.3389 s, 0.3021 s


def _signal(fs: float, seed: int = 0, snr_db: float = 20.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = received(PING, fs=fs, duration_s=3.0, arrivals_s=ARRIVALS, v_mps=1.0, ping_duration_s=0.05)
    return 0.2 * add_noise(x, fs=fs, ping=PING, band_hz=(19e3, 29e3), ping_duration_s=0.05, snr_db=snr_db, rng=rng)


def write_mat73(path: Path, variables: dict) -> None:
    """A MATLAB v7.3 file as MATLAB writes it: HDF5 behind a 512-byte header, arrays stored transposed."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            f[name] = np.asarray(value).T
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 12:00:00 2026 HDF5 schema 1.00 .".ljust(128))


def _rx(tmp_path, recording, *extra, capsys=None):
    out = tmp_path / "meas.csv"
    code = main(["rx", str(recording), "--reference", SPEC, "--emit-start", "0", "--emit-period", "1",
                 "-o", str(out), "-q", *extra])
    return code, out


def _check(out: Path, channel: int = 0):
    table = pd.read_csv(out)  # the default call opens it
    assert len(table) == 3
    np.testing.assert_allclose(table["t_arrival_s"], ARRIVALS, atol=1e-5)  # 20 dB: CRLB 2.2 µs, 4.5σ
    np.testing.assert_allclose(table["tof_s"], ARRIVALS - [0, 1, 2], atol=1e-5)
    assert np.all(table["sigma_range_m"] < 0.005)
    np.testing.assert_allclose(table["v_r_mps"], 1.0, atol=0.15)
    assert set(table["reference"]) == {"lfm_19-29k_50ms"} and set(table["channel"]) == {channel}
    meta = json.loads(out.with_name(out.name + ".json").read_text())
    assert meta["references"][0]["kind"] == "lfm" and meta["rows"] == 3
    return table, meta


@pytest.mark.parametrize("fs, fmt, subtype", [(96000, "WAV", "FLOAT"), (192000, "FLAC", "PCM_24"), (384000, "WAV", "PCM_16")])
def test_audio_formats_and_rates(tmp_path, fs, fmt, subtype):
    path = tmp_path / f"rec.{fmt.lower()}"
    soundfile.write(path, _signal(fs), fs, format=fmt, subtype=subtype)
    code, out = _rx(tmp_path, path)
    assert code == 0
    _, meta = _check(out)
    assert meta["sample_rate_hz"] == fs


def test_mat_v5_with_and_without_its_rate(tmp_path, capsys):
    x = _signal(96000)
    scipy.io.savemat(tmp_path / "a.mat", {"rec": x[:, None], "fs": 96000.0, "note": "hydrophone 1"})
    code, out = _rx(tmp_path, tmp_path / "a.mat", "--mat-variable", "rec")
    assert code == 0
    _check(out)
    scipy.io.savemat(tmp_path / "b.mat", {"samples": x[None, :]})  # one row, no rate: the longer axis is time
    code, out = _rx(tmp_path, tmp_path / "b.mat", "--sample-rate", "96000")
    assert code == 0
    _check(out)
    # a rate on the command line that disagrees with the file's: used, with a warning
    code, _ = _rx(tmp_path, tmp_path / "a.mat", "--mat-variable", "rec", "--sample-rate", "96000.5")
    assert code == 0 and "the file says 96000 Hz" in capsys.readouterr().err


def test_mat_v73_multichannel_best_channel_dc_and_clipping(tmp_path, capsys):
    """v7.3 (HDF5), 3 channels (only channel 2 holds the pings well), a DC offset, a clipped stretch."""
    fs = 96000
    strong = _signal(fs, seed=1)
    weak = _signal(fs, seed=2, snr_db=-3.0) * 0.3
    noise = np.random.default_rng(3).normal(0, 0.01, len(strong))
    data = np.stack([noise, weak, strong + 0.3], axis=1)  # MATLAB n_samples × 3, DC on the good channel
    data[100_000:100_050, 2] = 1.0  # a clipped stretch away from the pings
    write_mat73(tmp_path / "c.mat", {"x": data, "Fs": np.array([[fs]], dtype=float)})
    code, out = _rx(tmp_path, tmp_path / "c.mat", "--mat-variable", "x", "--all-channels")
    assert code == 0
    _check(out, channel=2)
    err = capsys.readouterr().err
    assert "channel 2: 50 clipped samples in 1 stretch" in err
    code, out = _rx(tmp_path, tmp_path / "c.mat", "--mat-variable", "x", "--channel", "2")
    assert code == 0
    _check(out, channel=2)


@pytest.mark.parametrize(
    "make, extra, message",
    [
        (lambda p: scipy.io.savemat(p, {"y": np.zeros(10), "fs": 96000.0}), ["--mat-variable", "x"], "has no variable 'x' (variables: fs, y)"),
        (lambda p: scipy.io.savemat(p, {"x": np.ones(1000) * (1 + 1j), "fs": 96000.0}), [], "is complex"),
        (lambda p: scipy.io.savemat(p, {"x": np.ones((100, 3, 2)), "fs": 96000.0}), [], "is 3-D"),
        (lambda p: scipy.io.savemat(p, {"x": np.ones(1000)}), [], "no sample rate in the file"),
        (lambda p: scipy.io.savemat(p, {"x": np.ones(48000), "fs": 48000.0}), [], "above the recording's Nyquist 24000 Hz"),
        (lambda p: write_mat73(p, {"x": np.ones(1000) * 1j, "fs": 96000.0}), [], "is complex"),
        (lambda p: p.write_bytes(b"MATLAB 5.0 MAT-file garbage"), [], "not a readable MATLAB file"),
        (lambda p: None, [], "recording not found"),
    ],
)
def test_bad_inputs_fail_in_one_line(tmp_path, capsys, make, extra, message):
    path = tmp_path / "bad.mat"
    make(path)
    code, out = _rx(tmp_path, path, *extra)
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists() and not out.with_name(out.name + ".json").exists()


def test_tx_then_rx_with_pre_and_postamble(tmp_path, capsys):
    """seamodem tx writes a pair schedule (TOML reference), seamodem rx pairs them: Doppler 0 to ~1e-7."""
    (tmp_path / "ref.toml").write_text(
        'kind = "lfm"\nname = "pkt"\nf_low_hz = 19000.0\nf_high_hz = 29000.0\nduration_s = 0.05\npostamble_s = 2.0\n'
    )
    wav = tmp_path / "beacon.wav"
    assert main(["tx", "--reference", str(tmp_path / "ref.toml"), "--count", "2", "--period", "3", "--start", "0.2",
                 "-o", str(wav), "-q"]) == 0
    side = json.loads(wav.with_suffix(".json").read_text())
    assert [f["role"] for f in side["frames"]] == ["preamble", "postamble"] * 2
    x, fs = soundfile.read(wav)
    soundfile.write(wav, x + np.random.default_rng(0).normal(0, 1e-3, len(x)), fs, subtype="FLOAT")
    out = tmp_path / "m.jsonl"
    assert main(["rx", str(wav), "--reference", str(wav.with_suffix(".json")), "-o", str(out), "-q"]) == 0
    table = pd.read_json(out, lines=True)
    assert list(table["role"]) == ["preamble", "postamble"] * 2
    assert list(table["frame_index"]) == [0, 0, 1, 1]
    np.testing.assert_allclose(table["tof_s"], 0.0, atol=2e-6)  # no channel: heard as emitted
    assert np.all(np.abs(table["v_r_pair_mps"]) < 3 * table["sigma_v_r_pair_mps"] + 1e-9)
    assert np.all(table["sigma_v_r_pair_mps"] < 1e-3)
    # a constant speed stated: the Doppler from the spacing alone, its σ the ridge spacing's (no Doppler-change term)
    out0 = tmp_path / "m0.jsonl"
    assert main(["rx", str(wav), "--reference", str(wav.with_suffix(".json")), "--max-accel", "0", "-o", str(out0), "-q"]) == 0
    table0 = pd.read_json(out0, lines=True)
    assert json.loads(out0.with_name(out0.name + ".json").read_text())["max_accel_mps2"] == 0.0
    assert np.all(np.abs(table0["v_r_pair_mps"]) < 3 * table0["sigma_v_r_pair_mps"] + 1e-9)
    assert np.all(table0["sigma_v_r_pair_mps"] < table["sigma_v_r_pair_mps"])


def test_option_errors(tmp_path, capsys):
    wav = tmp_path / "r.wav"
    soundfile.write(wav, np.zeros(1000), 96000)
    for extra, message in [
        (["--mat-variable", "x"], "is not a .mat file"),
        (["--channel", "0", "--all-channels"], "not both"),
        (["--v-max", "-1"], "v-max"),
        (["--max-accel", "-0.1"], "max-accel"),
        (["--max-accel", "nan"], "max-accel"),
    ]:
        code, out = _rx(tmp_path, wav, *extra)
        err = capsys.readouterr().err
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    code = main(["rx", str(wav), "--all-channels", "--emit-start", "0", "--emit-period", "1", "-o", str(tmp_path / "o.csv")])
    assert code == 2 and "only with --reference" in capsys.readouterr().err
    code = main(["rx", str(wav), "--max-accel", "0", "--emit-start", "0", "--emit-period", "1", "-o", str(tmp_path / "o.csv")])
    assert code == 2 and "max-accel: only with --reference" in capsys.readouterr().err


def test_without_emission_times_every_detection_is_written(tmp_path, capsys):
    """No sidecar, no --emit-start: the records (the receiver's writer) keep arrival and Doppler, range empty."""
    wav = tmp_path / "r.wav"
    soundfile.write(wav, _signal(96000.0), 96000, subtype="FLOAT")
    out = tmp_path / "m.csv"
    assert main(["rx", str(wav), "--reference", SPEC, "-o", str(out), "-q"]) == 0
    assert "emission times unknown" in capsys.readouterr().err
    table = pd.read_csv(out)
    np.testing.assert_allclose(table["t_arrival_s"], ARRIVALS, atol=1e-5)
    assert list(table["frame_index"]) == [-1] * 3 and table["range_m"].isna().all()
    meta = json.loads(out.with_name(out.name + ".json").read_text())
    assert meta["rows"] == 3 and meta["columns"] == list(table.columns) and meta["max_accel_mps2"] == 0.3


def test_channel_simulates_a_reference_schedule(tmp_path, capsys):
    """seamodem tx --reference → seamodem channel (geometry, echoes, 20 dB) → seamodem rx: ranges and speeds of the truth."""
    wav, chan = tmp_path / "beacon.wav", tmp_path / "heard.wav"
    assert main(["tx", "--reference", SPEC, "--count", "4", "--period", "1", "--start", "0.2", "-o", str(wav), "-q"]) == 0
    (tmp_path / "pass.toml").write_text(
        'mode = "geometry"\nseed = 3\n[environment]\nsound_speed_mps = 1500.0\nwater_depth_m = 30.0\n'
        '[beacon]\nposition_m = [0.0, 0.0, -10.0]\n[vehicle]\nstart_m = [-200.0, 80.0, -5.0]\nvelocity_mps = [2.0, 0.0, 0.0]\n'
        '[multipath]\nmax_bounces = 1\nsurface_reflection = -1.0\nbottom_reflection = 0.5\n[noise]\nkind = "white"\nsnr_db = 20.0\n'
    )
    assert main(["channel", str(wav), "--scenario", str(tmp_path / "pass.toml"), "-o", str(chan), "-q"]) == 0
    side = json.loads(chan.with_suffix(".json").read_text())
    assert side["format"] == "seamodem.reference-sidecar/1" and len(side["truth"]) == 4
    out = tmp_path / "m.csv"
    assert main(["rx", str(chan), "--reference", SPEC, "-o", str(out), "-q"]) == 0  # emissions from chan's own sidecar
    table = pd.read_csv(out)
    truth = pd.DataFrame(side["truth"])
    assert list(table["frame_index"]) == [0, 1, 2, 3]
    err_r = table["range_m"].to_numpy() - truth["range_m"].to_numpy()
    err_v = table["v_r_mps"].to_numpy() - truth["v_r_mps"].to_numpy()
    assert np.all(np.abs(err_r) < 3 * table["sigma_range_m"]) and np.all(np.abs(err_r) < 0.05)
    assert np.all(np.abs(err_v) < 3 * table["sigma_v_r_mps"]) and np.all(np.abs(err_v) < 0.5)
