"""seamodem: underwater acoustic modems that communicate and navigate with the same signal.

The package follows the signal chain: ``transmit`` (frames, beacon schedules),
``channel`` (propagation, Doppler, noise), ``receive`` (detection, range,
Doppler, demodulation), ``decode`` (equaliser, turbo, Viterbi),
``navigation`` (estimators); ``batch`` scales receiving out, ``studies`` runs
the whole chain for a question (BER sweeps); plus ``io``, ``plots`` and the
``seamodem`` command line (docs/architecture.md).

The public API is re-exported here, flat (``from seamodem import build_frame``),
and imported on first use (PEP 562): ``import seamodem`` does not wait for
scipy, numba or matplotlib, so neither does the command line.

Examples
--------
>>> import seamodem
>>> seamodem.get_preset("jmse2024").symbol_rate_hz
6400.0
"""

from ._lazy import exports, lazy_module
from ._version import __version__

_EXPORTS = exports(
    {
        "config": ("PRESETS", "FrameConfig", "get_preset", "load_config", "save_config"),
        "dsp": ("bb2pb", "pb2bb"),
        "errors": ("ConfigError", "InputFileError", "PayloadError", "SeamodemError"),
        "channel": (
            "Scenario",
            "apply_doppler",
            "load_scenario",
            "read_replay_channel",
            "replay",
            "simulate",
            "simulate_file",
            "sound_speed_mackenzie",
            "thorp_absorption_db_per_km",
        ),
        "transmit": (
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
        ),
        "receive": (
            "Emissions",
            "MeasurementRecord",
            "Receiver",
            "ReceiverSettings",
            "compensate_frame",
            "measure_frame",
            "read_measurements",
            "receive_file",
            "two_way_range_m",
            "write_measurements",
        ),
    }
)
__all__ = ["__version__", *_EXPORTS]
__getattr__, __dir__ = lazy_module(__name__, _EXPORTS, globals())
