"""seamodem: underwater acoustic modems that communicate and navigate with the same signal.

The package follows the signal chain: ``transmit`` (frames, beacon schedules),
``channel`` (propagation, Doppler, noise), ``receive`` (detection, range,
Doppler, decoding), ``navigation`` (estimators); plus ``io``, ``plots`` and the
``seamodem`` command line. The public API is re-exported here.
"""

from ._version import __version__
from .config import PRESETS, FrameConfig, get_preset, load_config, save_config
from .dsp import bb2pb, pb2bb
from .errors import ConfigError, InputFileError, PayloadError, SeamodemError
from .channel import (
    Scenario,
    apply_doppler,
    load_scenario,
    read_replay_channel,
    replay,
    simulate,
    simulate_file,
    sound_speed_mackenzie,
    thorp_absorption_db_per_km,
)
from .transmit import *  # noqa: F403
from .transmit import __all__ as _transmit_all
from .receive import (
    Emissions,
    MeasurementRecord,
    Receiver,
    compensate_frame,
    measure_frame,
    read_measurements,
    receive_file,
    two_way_range_m,
    write_measurements,
)

__all__ = [
    "__version__",
    "PRESETS",
    "FrameConfig",
    "get_preset",
    "load_config",
    "save_config",
    "bb2pb",
    "pb2bb",
    "ConfigError",
    "InputFileError",
    "PayloadError",
    "SeamodemError",
    "Scenario",
    "apply_doppler",
    "load_scenario",
    "read_replay_channel",
    "replay",
    "simulate",
    "simulate_file",
    "sound_speed_mackenzie",
    "thorp_absorption_db_per_km",
    *_transmit_all,
    "Emissions",
    "MeasurementRecord",
    "Receiver",
    "compensate_frame",
    "measure_frame",
    "read_measurements",
    "receive_file",
    "two_way_range_m",
    "write_measurements",
]
