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
from .transmit import __all__ as _transmit_all  # a lazy facade itself: cheap

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
        "transmit": _transmit_all,
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
