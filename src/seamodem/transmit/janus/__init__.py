"""JANUS (STANAG 4748) transmitter: parameter sets, the base packet and CRC-8, the (753, 561) code,
interleaving, frequency hopping and continuous-phase chip synthesis, sample-exact with the
reference implementation's output."""

from .coding import (
    JANUS_CONSTRAINT_LENGTH,
    JANUS_GENERATORS,
    PREAMBLE_BITS,
    block_chips,
    conv_encode_janus,
    hop_slots,
    interleave_stride,
    interleaver_permutation_janus,
)
from .frame import N_PREAMBLE_CHIPS, PAD_CHIPS, JanusWaveform, janus_waveform, packet_chip_bits, packet_tones
from .modulate import WUT_GAP_S, chip_bounds, chip_envelope, synthesize_chips, to_s16, upconvert, wake_up_tones
from .packet import MAX_CARGO_BYTES, JanusPacket, bits_to_bytes, bytes_to_bits, cargo_index, cargo_size, crc8
from .pset import PARAMETER_SETS, JanusParameterSet, get_parameter_set, primitive_root

__all__ = [
    "JANUS_CONSTRAINT_LENGTH", "JANUS_GENERATORS", "PREAMBLE_BITS", "block_chips", "conv_encode_janus", "hop_slots",
    "interleave_stride", "interleaver_permutation_janus", "N_PREAMBLE_CHIPS", "PAD_CHIPS", "JanusWaveform",
    "janus_waveform", "packet_chip_bits", "packet_tones", "WUT_GAP_S", "chip_bounds", "chip_envelope",
    "synthesize_chips", "to_s16", "upconvert", "wake_up_tones", "MAX_CARGO_BYTES", "JanusPacket", "bits_to_bytes",
    "bytes_to_bits", "cargo_index", "cargo_size", "crc8", "PARAMETER_SETS", "JanusParameterSet",
    "get_parameter_set", "primitive_root",
]
