"""Channel simulator: time-varying Doppler, multipath geometry, noise, clock errors (SPEC §3).

Modules follow the physics: ``propagation`` (sound speed, absorption, losses),
``profiles`` (prescribed v_r(t)), ``geometry`` (trajectories, image sources),
``model`` (each path's delay and gain over time), ``fluctuation`` (random path
gains with a Doppler spread), ``noise``, ``resample`` (the band-limited
interpolation kernel), ``truth`` (ground truth per frame), ``scenario`` (TOML
files; its tables in ``scenario_sections``), ``simulate`` (the block-wise pipeline;
``render`` its two passes, ``files`` its input and output files) and ``replay`` (measured
channels in the uwa-channels format), ``two_way`` (poll/reply exchanges for
two-way ranging).
"""

from .fluctuation import GaussianDopplerProcess
from .geometry import ImageSource, SampledTrack, StraightLine, WaypointTrack, image_sources, read_track_csv
from .model import ChannelModel, GeometryModel, PathInfo, ProfileModel, build_model
from .noise import AlphaStableNoise, AmbientNoise, GaussianMixtureNoise, NoiseSource, WhiteNoise, ambient_psd_db
from .profiles import ConstantProfile, DopplerProfile, RampProfile, SampledProfile, SinusoidalProfile, SumProfile
from .propagation import (
    absorption_gain,
    rough_surface_gain,
    sound_speed_mackenzie,
    spreading_gain,
    thorp_absorption_db_per_km,
)
from .replay import ReplayChannel, read_replay_channel, replay, replay_file
from .resample import apply_doppler, interpolate, render_paths
from .scenario import (
    Beacon,
    Clock,
    Doppler,
    Environment,
    Fluctuation,
    Multipath,
    Noise,
    Replay,
    Scenario,
    TwoWay,
    Vehicle,
    load_scenario,
    parse_scenario,
)
from .simulate import SimulationResult, make_noise_source, simulate, simulate_file
from .truth import arrival_times, frame_truth, in_band_power
from .two_way import ReplySchedule, RetimedInput, reply_schedule, two_way_truth

__all__ = [
    "GaussianDopplerProcess",
    "ImageSource",
    "SampledTrack",
    "StraightLine",
    "WaypointTrack",
    "image_sources",
    "read_track_csv",
    "ChannelModel",
    "GeometryModel",
    "PathInfo",
    "ProfileModel",
    "build_model",
    "AlphaStableNoise",
    "AmbientNoise",
    "GaussianMixtureNoise",
    "NoiseSource",
    "WhiteNoise",
    "ambient_psd_db",
    "ConstantProfile",
    "DopplerProfile",
    "RampProfile",
    "SampledProfile",
    "SinusoidalProfile",
    "SumProfile",
    "absorption_gain",
    "rough_surface_gain",
    "sound_speed_mackenzie",
    "spreading_gain",
    "thorp_absorption_db_per_km",
    "ReplayChannel",
    "read_replay_channel",
    "replay",
    "replay_file",
    "apply_doppler",
    "interpolate",
    "render_paths",
    "Beacon",
    "Clock",
    "Doppler",
    "Environment",
    "Fluctuation",
    "Multipath",
    "Noise",
    "Replay",
    "Scenario",
    "TwoWay",
    "Vehicle",
    "load_scenario",
    "parse_scenario",
    "SimulationResult",
    "make_noise_source",
    "simulate",
    "simulate_file",
    "arrival_times",
    "frame_truth",
    "in_band_power",
    "ReplySchedule",
    "RetimedInput",
    "reply_schedule",
    "two_way_truth",
]
