import json

import numpy as np
import pytest
import soundfile

from seamodem import get_preset
from seamodem.errors import ConfigError, InputFileError, PayloadError
from seamodem.io.sidecar import read_sidecar
from seamodem.transmit.beacon import (
    BeaconSchedule,
    payloads_from_bytes,
    payloads_from_text,
    rebuild_from_sidecar,
    render_beacon,
    write_beacon,
)
from seamodem.transmit.frame import build_frame, frame_waveform

CFG = get_preset("jmse2024")


def test_sidecar_alone_rebuilds_the_exact_recording(tmp_path):
    out = tmp_path / "b.wav"
    payloads = [b"alpha", b"", bytes(range(101))]
    write_beacon(out, CFG, BeaconSchedule(count=3, period_s=0.5, start_s=0.1), payloads)
    sidecar = read_sidecar(tmp_path / "b.json")
    x, fs = soundfile.read(out, dtype="float32")
    assert fs == 96153 and x.size == sidecar["recording"]["n_samples"]
    rebuilt = rebuild_from_sidecar(json.loads((tmp_path / "b.json").read_text()))
    np.testing.assert_array_equal(rebuilt.astype(np.float32), x)
    assert [bytes.fromhex(f["payload_hex"]) for f in sidecar["frames"]] == payloads
    assert np.max(np.abs(x)) == pytest.approx(0.5, rel=1e-6)


@pytest.mark.parametrize("damage", ["payload", "bits"])
def test_rebuild_needs_the_payloads_and_the_pilot(tmp_path, damage):
    sc = write_beacon(tmp_path / "b.wav", CFG, BeaconSchedule(count=2, period_s=0.5), [b"a", b"b"])
    if damage == "payload":
        del sc["frames"][1]["payload_hex"]
    else:
        sc["pilot"]["bits"] = "01x"
    with pytest.raises(InputFileError, match="lacks the payloads or pilot bits"):
        rebuild_from_sidecar(sc)


def test_pcm16_scaling_recorded(tmp_path):
    out = tmp_path / "p.wav"
    sc = write_beacon(out, CFG, BeaconSchedule(count=1, period_s=1.0), [b"pcm"], subtype="PCM_16", peak=0.9)
    info = soundfile.info(out)
    assert info.subtype == "PCM_16" and sc["recording"]["subtype"] == "PCM_16"
    x, _ = soundfile.read(out, dtype="float64")
    rebuilt = rebuild_from_sidecar(sc)
    assert np.max(np.abs(x - rebuilt)) <= 1 / 32768  # one LSB of quantisation
    model = frame_waveform(build_frame(CFG, b"pcm"))
    np.testing.assert_allclose(x[: model.size], sc["recording"]["scale"] * model, atol=1 / 32768)


def test_frames_start_at_their_emission_times_even_between_samples():
    fs = CFG.sample_rate_hz
    start = 0.25 + 0.4 / fs  # between two samples
    sig = render_beacon(CFG, BeaconSchedule(count=2, period_s=1.0 + 0.1 / fs, start_s=start), [b"a", b"b"])
    x = np.concatenate(list(sig.blocks(progress=False)))
    for k, t_e in enumerate(sig.schedule.emission_times()):
        n0 = int(np.ceil(t_e * fs))
        assert (n0 - 1) / fs < t_e <= n0 / fs
        tau = np.arange(n0, n0 + 5000) / fs - t_e  # exact local times of those samples
        ref = frame_waveform(build_frame(CFG, [b"a", b"b"][k]), offset_s=tau[0])[:5000]
        np.testing.assert_allclose(x[n0 : n0 + 5000], ref, atol=1e-12)
        assert np.all(x[n0 - 200 : n0] == 0)


def test_recording_length_and_silence_between_frames():
    sig = render_beacon(CFG, BeaconSchedule(count=4, period_s=0.5), None)
    assert sig.n_samples == int(np.ceil(2.0 * CFG.sample_rate_hz))
    x = np.concatenate(list(sig.blocks(block_size=10007, progress=False)))  # blocks cut through frames
    whole = np.concatenate(list(sig.blocks(progress=False)))
    np.testing.assert_array_equal(x, whole)
    gap = slice(int(0.31 * CFG.sample_rate_hz), int(0.49 * CFG.sample_rate_hz))
    assert np.all(x[gap] == 0)


def test_schedule_validation():
    with pytest.raises(ConfigError, match="^count"):
        BeaconSchedule(count=0, period_s=3)
    with pytest.raises(ConfigError, match="^period_s"):
        BeaconSchedule(count=2, period_s=-1)
    with pytest.raises(ConfigError, match="^start_s"):
        BeaconSchedule(count=2, period_s=1, start_s=-0.5)
    with pytest.raises(ConfigError, match="^period_s: must be at least the frame duration"):
        render_beacon(CFG, BeaconSchedule(count=2, period_s=0.2))


def test_payload_helpers():
    assert payloads_from_text("f{index}", 3) == [b"f0", b"f1", b"f2"]
    chunks = payloads_from_bytes(bytes(250), 101)
    assert [len(c) for c in chunks] == [101, 101, 48]
    assert [len(c) for c in payloads_from_bytes(b"abc", 101, 3)] == [3, 0, 0]
    with pytest.raises(PayloadError, match="need 3 frames"):
        payloads_from_bytes(bytes(250), 101, 2)
    with pytest.raises(PayloadError, match="capacity"):
        render_beacon(CFG, BeaconSchedule(count=1, period_s=1), [bytes(102)])


def test_non_integer_rate_cannot_be_written_to_wav(tmp_path):
    cfg = CFG.replace(sample_rate_hz=96153.5)
    with pytest.raises(ConfigError, match="^sample_rate_hz: must be a whole number"):
        write_beacon(tmp_path / "x.wav", cfg, BeaconSchedule(count=1, period_s=1))
    assert list(tmp_path.iterdir()) == []
