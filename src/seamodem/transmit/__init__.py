"""Transmitter: pulse, constellations, pilot, payload coding, frame, beacon schedule.

Names are imported on first use (``seamodem.transmit.beacon`` and the others
still import as modules).
"""

from .._lazy import exports, lazy_module

_EXPORTS = exports(
    {
        "beacon": (
            "BeaconSchedule",
            "BeaconSignal",
            "payloads_from_bytes",
            "payloads_from_text",
            "rebuild_from_sidecar",
            "render_beacon",
            "write_beacon",
        ),
        "coding": ("conv_encode", "crc16_ccitt", "encode_payload", "parse_info_block", "code_order_llr"),
        "frame": ("Frame", "build_frame", "frame_baseband", "frame_sample_count", "frame_symbol_times", "frame_waveform"),
        "modulation": ("bits_to_symbols", "constellation", "symbols_to_bits"),
        "pilot": ("autocorrelation_sidelobes", "pilot_bits", "pilot_symbols"),
        "pulse": ("srrc_matrix", "srrc_pulse", "srrc_taps"),
    }
)
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_module(__name__, _EXPORTS, globals())
