"""The JANUS receiver on the reference implementation's WAVs, and on a Doppler-shifted noisy packet."""

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from scipy.interpolate import CubicSpline

from seamodem.receive.janus import JanusSettings, receive_janus
from seamodem.transmit.janus import JanusPacket, get_parameter_set, janus_waveform

DATA = Path(__file__).resolve().parents[1] / "data" / "janus"
NAMES = ["pset1_48k_default", "pset1_96k_default", "pset1_48k_appfields", "pset1_48k_cargo_hello",
         "pset1_96k_cargo8", "pset1_48k_wut_cargo8"]


def _dump(path: Path) -> dict:
    """Fields a reference program printed: packet bytes, class-16 fields, cargo bytes."""
    out = {}
    for line in path.read_text().splitlines():
        parts = [p.strip() for p in line.split(":", 2)]
        if len(parts) < 3:
            continue
        key, value = parts[1], parts[2]
        if key == "Bytes (hex)":
            out["packet"] = bytes.fromhex(value.replace("|", " "))
        elif key == "Cargo (hex)":
            out["cargo"] = bytes.fromhex(value)
        elif key in ("StationIdentifier", "ParameterSetIdentifier"):
            out[key] = int(value)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_decodes_reference_wavs_as_the_reference_receiver(name):
    x, fs = sf.read(DATA / f"{name}.wav")
    expected = _dump(DATA / f"{name}.rx.txt")
    if "packet" not in expected:
        # the reference receiver missed this one (wake-up tones): compare with what its transmitter sent
        expected = _dump(DATA / f"{name}.tx.txt")
        assert name == "pset1_48k_wut_cargo8"
    (rec,) = receive_janus(x, fs)
    assert bytes.fromhex(rec.packet_hex) == expected["packet"]
    assert rec.crc_ok
    assert bytes.fromhex(rec.cargo_hex) == expected.get("cargo", b"")
    if "StationIdentifier" in expected:
        assert (rec.station_id, rec.pset_id) == (expected["StationIdentifier"], expected["ParameterSetIdentifier"])
    # the packet starts after 5 silent chips (and, with wake-up tones, 3 tones and 0.4 s); 1 µs = 1.5 mm
    lead = 5 * 300 + (3 * 1204 + 19200 if "wut" in name else 0)
    assert rec.t_arrival_s == pytest.approx(lead / 48000, abs=1e-6)
    assert abs(rec.v_r_mps) < 1e-4


def _scaled(x: np.ndarray, fs: float, eps: float, delay_s: float) -> np.ndarray:
    """x((1 + ε)(t − delay)): a closing speed c·ε and a delay, by cubic interpolation (fine at 48 kHz for 13 kHz)."""
    t = np.arange(int(len(x) / (1 + eps) + delay_s * fs) + 100) / fs
    u = (1 + eps) * (t - delay_s)
    y = CubicSpline(np.arange(len(x)) / fs, x)(u)
    y[(u < 0) | (u > (len(x) - 1) / fs)] = 0
    return y


def test_doppler_and_noise_packet_decoded_and_measured():
    rng = np.random.default_rng(7)
    fs, c, v = 48000, 1500.0, -3.2
    w = janus_waveform(JanusPacket.class16_app0(station_id=7, cargo=b"seamodem"), get_parameter_set(1), fs)
    delay = 0.25
    y = _scaled(w.x_pb, fs, v / c, delay)
    # −9 dB over 0..fs/2: the reference receiver's last point with 8 of 8 decoded
    y = y + rng.normal(0, np.sqrt(np.mean(w.x_pb**2) / 10 ** (-9 / 10)), y.size)
    (rec,) = receive_janus(y, fs, JanusSettings(sound_speed_mps=c))
    assert rec.station_id == 7 and bytes.fromhex(rec.cargo_hex) == b"seamodem"
    t_true = delay + w.preamble_start / fs / (1 + v / c)
    # 4 σ: a single draw, σ calibrated on benchmarks/bench_janus.py
    assert abs(rec.t_arrival_s - t_true) < 4 * rec.sigma_range_m / c
    assert abs(rec.v_r_mps - v) < 4 * rec.sigma_v_r_mps


def test_noise_alone_gives_no_packet():
    rng = np.random.default_rng(3)
    assert receive_janus(rng.normal(size=48000 * 3), 48000) == []


def test_streaming_in_small_blocks_finds_what_the_whole_recording_gives():
    from seamodem.receive.janus import JanusReceiver

    rng = np.random.default_rng(11)
    fs = 48000
    pset = get_parameter_set(1)
    # a long cargo (64 bytes: 1040 chips, 7.6 s with its base packet) spans several 5 s windows
    packets = [JanusPacket.class16_app0(station_id=k, cargo=bytes(range(64)) if k == 2 else b"") for k in range(5)]
    x = np.zeros(40 * fs)
    starts = [0.3, 2.0, 4.1, 13.0, 39.6]  # the last one cut by the end: 27 of its 144 base-packet chips
    for t, p in zip(starts, packets):
        w = janus_waveform(p, pset, fs).x_pb
        k = int(t * fs)
        x[k : k + w.size] = w[: x.size - k]
    x += rng.normal(0, 0.05, x.size)
    whole = receive_janus(x, fs)
    rx = JanusReceiver(fs, window_s=5.0)
    streamed = [r for block in np.array_split(x, 97) for r in rx.process(block)] + rx.flush()
    assert [r.station_id for r in whole] == [0, 1, 2, 3]
    assert bytes.fromhex(whole[2].cargo_hex) == bytes(range(64))
    assert [r.packet_hex for r in streamed] == [r.packet_hex for r in whole]
    assert [r.cargo_hex for r in streamed] == [r.cargo_hex for r in whole]
    # the same samples, but the front end's FFT over another stretch shapes the noise's band edge
    # slightly differently: arrivals agree well inside their σ
    for a, b in zip(streamed, whole):
        assert abs(a.t_arrival_s - b.t_arrival_s) < 0.5 * b.sigma_range_m / 1500


@pytest.mark.parametrize("v", [4.8, -4.8])
def test_near_the_edge_of_the_doppler_search(v):
    rng = np.random.default_rng(21)
    fs, c = 48000, 1500.0
    w = janus_waveform(JanusPacket.class16_app0(station_id=5), get_parameter_set(1), fs)
    y = _scaled(w.x_pb, fs, v / c, 0.1)
    y = y + rng.normal(0, np.sqrt(np.mean(w.x_pb**2)), y.size)  # 0 dB over 0..fs/2
    (rec,) = receive_janus(y, fs)
    assert rec.station_id == 5
    assert abs(rec.v_r_mps - v) < 4 * rec.sigma_v_r_mps


def test_clicks_neither_make_packets_nor_hide_one():
    rng = np.random.default_rng(5)
    fs = 48000
    w = janus_waveform(JanusPacket.class16_app0(station_id=8), get_parameter_set(1), fs)
    rms = np.sqrt(np.mean(w.x_pb**2))
    y = np.concatenate([np.zeros(fs), w.x_pb, np.zeros(fs)])
    y = y + rng.normal(0, rms / np.sqrt(10 ** (-6 / 10)), y.size)
    # 100 clicks of 1 ms, 30 times the packet's rms, before, during and after it
    for k in rng.integers(0, y.size - 48, 100):
        y[k : k + 48] += 30 * rms * rng.choice([-1, 1]) * np.exp(-np.arange(48) / 10)
    recs = receive_janus(y, fs)
    assert [r.station_id for r in recs] == [8]
