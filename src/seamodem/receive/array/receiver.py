"""The array receiver: a multichannel recording in, measurement records with the direction of arrival out.

Orchestration only: front end (:mod:`.frontend`), detection
(:mod:`.detector`), per frame the correlations (:mod:`.correlation`),
direction (:mod:`.doa`) and combining (:mod:`.combine`), then the
single-hydrophone receiver's per-frame stage
(:class:`~seamodem.receive.frame.FrameMeasurer`) on the combined basebands.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...config import FrameConfig
from ...errors import ConfigError, InputFileError
from ...transmit.pilot import pilot_symbols
from ..frame import (BasebandBuffers, FrameMeasurer, ReceiverWarning, RecordLookahead, detector_options,
                     one_blas_thread)
from ..measure import NOISE_WINDOW_S
from ..records import MeasurementRecord
from ..settings import Emissions, ReceiverSettings
from .combine import COMBINE_PAD_S, mrc_weights, splice_beam
from .correlation import baseband_correlation
from .detector import ArrayDetector
from .doa import DoaEstimate, estimate_doa
from .frontend import front_end_array
from .geometry import array_geometry


def receive_array(
    x: np.ndarray,
    fs: float,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    emissions: Emissions,
    settings: ReceiverSettings | None = None,
    complex_gains: np.ndarray | None = None,
    reference_channel: int = 0,
    position_sigma_m: float = 0.0,
    combine: bool = True,
    payloads=None,
    pilot: np.ndarray | None = None,
    assume: str | None = None,
) -> tuple[list[MeasurementRecord], list[DoaEstimate | None]]:
    """Measurement records with the direct path's direction of arrival, from a multichannel recording.

    One pass over the recording:

    1. every channel through the receiver's front end (impulses blanked as
       found on ``reference_channel``) to its decimated data and tone basebands;
    2. detection on all channels at once (:class:`ArrayDetector`: array gain
       at the single detector's false-alarm rate);
    3. per frame: :func:`baseband_correlation`, :func:`estimate_doa` at the
       detection's time and Doppler bin;
    4. ``combine``: maximal-ratio combining of the frame's basebands
       (:func:`~seamodem.receive.array.combine.mrc_weights`) spliced into the
       reference channel's, and the single-hydrophone receiver's measurement
       and decoding (:class:`~seamodem.receive.frame.FrameMeasurer`, same
       settings) run once on it: range (to the array's body origin), Doppler, SNR and payload
       come from the combined channels. Otherwise from the reference
       channel's baseband (range to that element).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples, n_channels)
        Real passband channels at ``fs`` [Hz].
    fs : float
        Sample rate [Hz].
    config : FrameConfig
        The transmitted frame.
    positions_m : numpy.ndarray, shape (n_channels, 3)
        Nominal element positions in the body frame [m].
    emissions : Emissions
        When frames (or, two-way, polls) were emitted.
    settings : ReceiverSettings, optional
        As the single-hydrophone receiver's (default: ``ReceiverSettings()``).
    complex_gains : numpy.ndarray, optional
        Channel calibration (:func:`calibrate_array`), divided out.
    reference_channel : int
        The channel impulses are found on, whose noise level the combined
        frame keeps and whose record a frame without a direction gets.
    position_sigma_m : float
        Uncertainty of the nominal element positions [m] (:func:`estimate_doa`).
    combine : bool
        Measure and decode the maximal-ratio combined frame (else the
        reference channel's).
    payloads : sequence of bytes, optional
        The payload sent in each frame, by frame_index, to count bit errors when decoding.
    pilot : numpy.ndarray, optional
        Pilot symbols (default: from the config's seed).
    assume : str, optional
        For a flat (planar) array, which side of its plane the beacon is:
        "below" or "above"; for a line, "port" or "starboard" (:func:`estimate_doa`).

    Returns
    -------
    records : list of MeasurementRecord
        With ``azimuth_body_rad``, ``elevation_body_rad``, their σ's and
        ``n_channels`` filled; a frame whose pilot the recording cuts keeps
        the reference channel's record (NaN direction, ``n_channels`` 1).
    doas : list of DoaEstimate or None
        One per record (None without a direction).
    """
    x = np.asarray(x, float)
    if x.ndim != 2 or x.shape[1] < 2:
        raise InputFileError(f"a receiver array needs a multichannel recording, got shape {x.shape}")
    positions_m = array_geometry(positions_m, assume).positions_m
    if positions_m.shape[0] != x.shape[1]:
        raise ConfigError("array", f"{positions_m.shape[0]} element positions for a recording of {x.shape[1]} channels")
    s = ReceiverSettings() if settings is None else settings
    c = s.sound_speed_mps
    pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
    aperture_m = float(np.max(np.linalg.norm(positions_m[:, None] - positions_m[None], axis=-1)))
    spread = math.ceil(aperture_m / c * fs) + 1  # a click's spread over the elements [samples]
    # one BLAS thread for the whole pass (the per-frame work is many small products: frame.one_blas_thread)
    with one_blas_thread():
        plan, bb, tone, blanker = front_end_array(x, fs, config, s, reference_channel, spread)
        if complex_gains is not None:
            g = np.asarray(complex_gains, complex)[None, :]
            bb, tone = bb / g, tone / g
        det = ArrayDetector(config, plan.fs_data, x.shape[1], **detector_options(s, pilot))
        detections = det.find_all(bb)
        measurer = FrameMeasurer(config, plan, emissions=emissions, settings=s, pilot=pilot, payloads=payloads,
                                 blanker=blanker)
        span = measurer.span_s
        lookahead = RecordLookahead(measurer, s.lookahead_frames)
        y_bb, y_tone = bb[:, reference_channel].copy(), tone[:, reference_channel].copy()
        f_data, f_tone = plan.data.centre_hz, plan.tone.centre_hz
        records: list[MeasurementRecord] = []
        out_doas: list[DoaEstimate | None] = []
        for d in detections:
            v0 = d.doppler_hz * c / config.carrier_hz
            try:
                corr = baseband_correlation(bb, plan.fs_data, f_data, config=config, pilot=pilot,
                                            t_arrival_s=d.t_start_s, v_mps=v0, sound_speed_mps=c)
            except ConfigError:
                corr = None  # the pilot is cut by the recording's edge: no direction
            doa = None if corr is None else estimate_doa(corr, positions_m, config=config, sound_speed_mps=c, v_mps=v0,
                                                         position_sigma_m=position_sigma_m, assume=assume)
            if combine and doa is not None:
                w = mrc_weights(doa.amplitudes, doa.snr, reference_channel)
                rel = doa.lags_s - doa.t0_s  # each channel to the body origin's time: the range is the origin's
                t_a = d.t_start_s
                t_end = t_a + config.frame_duration_s * (1 + 2 * s.v_max_mps / c) + COMBINE_PAD_S
                splice_beam(y_bb, bb, plan.fs_data, f_data, t_a - COMBINE_PAD_S, t_end, rel, w)
                splice_beam(y_tone, tone, plan.fs_tone, f_tone, t_a - COMBINE_PAD_S, t_end, rel, w)
            # the measurement sees the frame's neighbourhood only, as in the streaming receiver's buffers
            t_lo, t_hi = d.t_start_s - 2 * COMBINE_PAD_S - NOISE_WINDOW_S, d.t_start_s + span + COMBINE_PAD_S
            i_bb, i_tone = max(0, math.floor(t_lo * plan.fs_data)), max(0, math.floor(t_lo * plan.fs_tone))
            window = BasebandBuffers(y_bb[i_bb: max(i_bb, math.ceil(t_hi * plan.fs_data))],
                                     y_tone[i_tone: max(i_tone, math.ceil(t_hi * plan.fs_tone))],
                                     bb_start=i_bb, tone_start=i_tone)
            rec = measurer.measure(d, window)
            out_doas.append(doa)
            if doa is not None:
                rec = dataclasses.replace(
                    rec, azimuth_body_rad=doa.azimuth_rad, elevation_body_rad=doa.elevation_rad,
                    sigma_azimuth_body_rad=doa.sigma_azimuth_rad, sigma_elevation_body_rad=doa.sigma_elevation_rad,
                    n_channels=int(x.shape[1]))
            records.extend(lookahead.push(rec))
        records.extend(lookahead.flush())
    return records, out_doas


def open_array_source(path, positions_m: np.ndarray, assume: str | None = None):
    """The recording of an array, checked: one channel per element; a flat or linear array's assumption warned.

    Parameters
    ----------
    path : str, Path or RecordingSource
        The recording (audio file or ``.mat``, :func:`~seamodem.io.mat.open_recording`), or an open source.
    positions_m : numpy.ndarray, shape (n_elements, 3)
        Nominal element positions [m].
    assume : str, optional
        As :func:`receive_array`.

    Returns
    -------
    RecordingSource

    Raises
    ------
    InputFileError
        Unreadable file, or not one channel per element.
    """
    import warnings

    from ...io.mat import open_recording
    from ...io.source import RecordingSource

    geometry = array_geometry(positions_m, assume)
    source = path if isinstance(path, RecordingSource) else open_recording(path)
    n_el = np.asarray(positions_m).shape[0]
    if source.n_channels != n_el:
        raise InputFileError(f"{path}: has {source.n_channels} channel(s), the array {n_el} elements")
    if geometry.ambiguity:
        warnings.warn(geometry.ambiguity, ReceiverWarning, stacklevel=3)
    return source


def receive_array_file(
    path,
    config: FrameConfig,
    positions_m: np.ndarray,
    *,
    emissions: Emissions,
    settings: ReceiverSettings | None = None,
    complex_gains: np.ndarray | None = None,
    position_sigma_m: float = 0.0,
    pilot: np.ndarray | None = None,
    payloads=None,
    assume: str | None = None,
) -> list[MeasurementRecord]:
    """:func:`receive_array` on a multichannel recording (one channel per element, read whole).

    Read through the io layer (:func:`~seamodem.io.mat.open_recording`: audio
    files and ``.mat``). A flat or linear array's assumption (``assume``,
    :func:`array_geometry`) is warned about once (a
    :class:`~seamodem.receive.frame.ReceiverWarning`).

    Parameters
    ----------
    path : str, Path or RecordingSource
        The recording, or an open source (a stream: read to its end, then received; ``seamodem rx -``
        receives a stream in segments instead, ``seamodem.batch.live``).
    config, positions_m, emissions, settings, complex_gains, position_sigma_m, pilot, payloads, assume
        As :func:`receive_array`.

    Returns
    -------
    list of MeasurementRecord
        One per frame, with the direction of arrival.

    Raises
    ------
    InputFileError
        Unreadable file, NaN or infinite samples, or not one channel per element.
    """
    source = open_array_source(path, positions_m, assume)
    n_el = source.n_channels
    if source.n_samples is None:  # a stream: read to its end
        x = np.concatenate(list(source.blocks(list(range(n_el)))) or [np.zeros((0, n_el))])
    else:
        x = np.empty((source.n_samples, n_el))  # filled block by block: one copy of the recording in memory
        pos = 0
        for block in source.blocks(list(range(n_el))):
            x[pos:pos + len(block)] = block
            pos += len(block)
    fs = source.sample_rate_hz
    records, _ = receive_array(x, float(fs), config, positions_m, emissions=emissions, settings=settings,
                               complex_gains=complex_gains, position_sigma_m=position_sigma_m, pilot=pilot,
                               payloads=payloads, assume=assume)
    return records
