"""Transmitter: pulse, constellations, pilot, payload coding, frame, beacon schedule."""

from .beacon import (
    BeaconSchedule,
    BeaconSignal,
    payloads_from_bytes,
    payloads_from_text,
    rebuild_from_sidecar,
    render_beacon,
    write_beacon,
)
from .coding import code_order_llr, conv_encode, crc16_ccitt, encode_payload, parse_info_block
from .frame import Frame, build_frame, frame_baseband, frame_sample_count, frame_symbol_times, frame_waveform
from .modulation import bits_to_symbols, constellation, symbols_to_bits
from .pilot import autocorrelation_sidelobes, pilot_bits, pilot_symbols
from .pulse import srrc_matrix, srrc_pulse, srrc_taps

__all__ = [
    "BeaconSchedule",
    "BeaconSignal",
    "payloads_from_bytes",
    "payloads_from_text",
    "rebuild_from_sidecar",
    "render_beacon",
    "write_beacon",
    "conv_encode",
    "crc16_ccitt",
    "encode_payload",
    "parse_info_block",
    "code_order_llr",
    "Frame",
    "build_frame",
    "frame_baseband",
    "frame_sample_count",
    "frame_symbol_times",
    "frame_waveform",
    "bits_to_symbols",
    "constellation",
    "symbols_to_bits",
    "autocorrelation_sidelobes",
    "pilot_bits",
    "pilot_symbols",
    "srrc_matrix",
    "srrc_pulse",
    "srrc_taps",
]
