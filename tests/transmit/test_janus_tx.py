"""The JANUS transmitter against the reference implementation's WAVs (tests/data/janus, see its README.md)."""

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from seamodem.transmit.janus import (
    JanusPacket,
    cargo_index,
    cargo_size,
    conv_encode_janus,
    crc8,
    get_parameter_set,
    hop_slots,
    interleave_stride,
    janus_waveform,
    to_s16,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "janus"

#: each reference file and the packet the reference transmitter was asked for (its README's options)
REFERENCES = {
    "pset1_48k_default": (JanusPacket(), False),
    "pset1_96k_default": (JanusPacket(), False),
    "pset1_48k_appfields": (JanusPacket.class16_app0(station_id=42, pset_id=1, mobility=True, forward=True), False),
    "pset1_48k_cargo_hello": (JanusPacket.class16_app0(cargo=b"Hello JANUS"), False),
    "pset1_96k_cargo8": (JanusPacket.class16_app0(cargo=b"ABCDEFGH"), False),
    "pset1_48k_wut_cargo8": (JanusPacket.class16_app0(cargo=b"ABCDEFGH"), True),
}


def _dump_bytes(name: str) -> bytes:
    """The 8 packet bytes the reference transmitter printed."""
    for line in (DATA / f"{name}.tx.txt").read_text().splitlines():
        if "Bytes (hex)" in line:
            return bytes.fromhex(line.split(":", 2)[2].replace("|", " "))
    raise AssertionError(f"no packet bytes in {name}.tx.txt")


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_sample_exact_with_reference(name):
    packet, wake_up = REFERENCES[name]
    ref, fs = sf.read(DATA / f"{name}.wav", dtype="int16")
    assert packet.to_bytes() == _dump_bytes(name)
    ours = to_s16(janus_waveform(packet, get_parameter_set(1), fs, wake_up=wake_up).x_pb)
    assert ours.shape == ref.shape
    # sample-exact: 0 LSB difference anywhere
    assert np.array_equal(ours, ref)


def test_crc8_examples_from_facts():
    assert crc8(bytes.fromhex("32100000000000")) == 0x55
    assert crc8(bytes.fromhex("32011523456789")) == 0xA7


def test_cargo_sizes_and_padding():
    assert [cargo_size(i) for i in range(7)] == [0, 1, 2, 4, 8, 16, 24]
    assert cargo_size(63) == 480
    assert cargo_index(11) == 5 and cargo_index(8) == 4
    assert JanusPacket.class16_app0(cargo=b"Hello JANUS").cargo == b"Hello JANUS" + bytes(5)
    with pytest.raises(ValueError, match="cargo must be 0 to 480"):
        cargo_index(481)


def test_fields_round_trip():
    p = JanusPacket.class16_app0(station_id=42, pset_id=1, mobility=True, forward=True)
    q = JanusPacket.from_bytes(p.to_bytes())
    assert q == p
    f = q.fields()
    assert (f["station_id"], f["pset_id"], f["cargo_size"]) == (42, 1, 0)


def test_hopping_and_interleaver_from_facts():
    assert hop_slots(18, get_parameter_set(1)).tolist() == [2, 4, 8, 3, 6, 12, 11, 9, 5, 10, 7, 1, 6, 7, 7, 12, 3, 0]
    assert [interleave_stride(n) for n in (144, 32, 48, 80, 272, 400, 528, 1040)] == [13, 7, 7, 11, 19, 23, 23, 37]


def test_encoder_impulse_response_is_the_generators():
    # a single 1 followed by zeros outputs the generators' taps, newest first: 753 and 561 octal
    c = conv_encode_janus(np.array([1])).reshape(-1, 2)
    assert int("".join(map(str, c[:, 0])), 2) == 0o753
    assert int("".join(map(str, c[:, 1])), 2) == 0o561


def test_rate_that_cannot_hold_the_band_is_refused():
    with pytest.raises(ValueError, match="fs must exceed"):
        janus_waveform(JanusPacket(), get_parameter_set(1), 24000)
