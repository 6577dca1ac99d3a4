"""Per-frame measurement: fine arrival time, every Doppler estimate and the in-band SNR of one detected frame.

Pilot fit and path resolution (:mod:`.doppler`, :mod:`.multipath`) give the
first arrival and the pilot (filter-bank) Doppler; the tone gives the ML and
eq 9 speeds (paper 000 eq 9, SPEC §4.3).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from .detect import Detection, doppler_bin_spacing_hz
from .doppler import PilotFit, ToneFit, fit_pilot, tone_frequency_ml, tone_segment, tone_track_eq9
from .frontend import FrontEndPlan
from .multipath import PathFit, direct_path_doppler, find_echoes, find_precursors, fit_paths

__all__ = ["FrameMeasurement", "measure_frame", "in_band_snr_db", "impulse_excess", "frame_span_s", "NOISE_GAP_S", "NOISE_WINDOW_S"]

#: a frame's waveform ends this long after its last symbol at most (tone and pulse tails) [s]
FRAME_TAIL_S = 0.02


@dataclass(frozen=True)
class FrameMeasurement:
    """Everything measured on one frame, before it is tied to an emission.

    Attributes
    ----------
    detection : Detection
    pilot : PilotFit
        Arrival time (of the first path), pilot (filter-bank) Doppler, gain,
        and the in-band SNR from the powers around and in the frame
        (:func:`in_band_snr_db`; from the pilot residual when no noise window
        is available).
    tone : ToneFit
        ML tone frequency and C/N0.
    paths : PathFit
        Paths resolved in the pilot correlation; the arrival is the first.
    v_tone_ml_mps, v_tone_eq9_mps : float
        Mean closing speed from the tone: ML and eq 9 [m/s].
    track_t_s, track_v_mps : numpy.ndarray
        The eq 9 v_r track over the frame interior (times [s], speeds [m/s]).
    complete : bool
        False when the recording ends before the frame does.
    echoes : PathFit or None
        ``paths`` with the echoes up to a pilot's length later
        (:func:`~seamodem.receive.multipath.find_echoes`, searched for every
        frame: ``paths`` itself when it finds none); None when not searched
        (a measurement made otherwise).
    """

    detection: Detection
    pilot: PilotFit
    tone: ToneFit
    paths: PathFit
    v_tone_ml_mps: float
    v_tone_eq9_mps: float
    track_t_s: np.ndarray
    track_v_mps: np.ndarray
    complete: bool
    echoes: PathFit | None = None

    @property
    def compensation_speed_mps(self) -> float:
        """The mean speed decoding compensates with: the tone ML, else (no tone) the pilot bank's."""
        return self.v_tone_ml_mps if math.isfinite(self.v_tone_ml_mps) else self.pilot.v_mps


#: fewer tone samples than this (a frame cut by the recording's end) give no tone Doppler
_MIN_TONE_SAMPLES = 16


def measure_frame(
    bb: np.ndarray,
    tone: np.ndarray,
    detection: Detection,
    *,
    plan: FrontEndPlan,
    config: FrameConfig,
    pilot: np.ndarray,
    sound_speed_mps: float,
    v_max_mps: float,
    bb_t0_s: float = 0.0,
    tone_t0_s: float = 0.0,
) -> FrameMeasurement:
    """Fine arrival time and all Doppler estimates of one detected frame.

    Parameters
    ----------
    bb, tone : numpy.ndarray, complex
        Data-band and tone basebands from the front end ``plan``, first
        samples at ``bb_t0_s`` and ``tone_t0_s`` [s].
    detection : Detection
        Coarse start and Doppler bin.
    pilot : numpy.ndarray
        Pilot symbols.
    """
    c = sound_speed_mps
    fit = fit_pilot(
        bb,
        plan.fs_data,
        bb_t0_s,
        config=config,
        pilot=pilot,
        t_start_s=detection.t_start_s,
        doppler_hz=detection.doppler_hz,
        search_hz=doppler_bin_spacing_hz(config),
        sound_speed_mps=c,
    )
    paths = fit_paths(
        bb,
        plan.fs_data,
        bb_t0_s,
        config=config,
        pilot=pilot,
        t_start_s=fit.t_start_s,
        eps=fit.v_mps / c,
        es_n0=fit.es_n0,
    )
    paths = find_precursors(bb, plan.fs_data, bb_t0_s, config=config, pilot=pilot, paths=paths,
                            t_start_s=fit.t_start_s, eps=fit.v_mps / c, es_n0=fit.es_n0)
    # unresolved echoes pull the single-path fit towards them: take the first path's
    # delay, and its Doppler with the echoes' pilots removed. The echoes are searched
    # here, once (direct_path_doppler would search them itself, and the whole-frame
    # fit needs them again): given them and no more to find, it only refits amplitudes.
    # A lone path within the arrival fit's ±12 symbols is searched too: echoes up to a
    # pilot's length behind it overlap its pilot all the same (a bottom echo 2–3 ms late)
    echoes = find_echoes(bb, plan.fs_data, bb_t0_s, config=config, pilot=pilot, paths=paths, eps=fit.v_mps / c)
    if len(echoes.delays_s) > 1:
        eps = direct_path_doppler(
            bb,
            plan.fs_data,
            bb_t0_s,
            config=config,
            pilot=pilot,
            paths=echoes,
            eps=fit.v_mps / c,
            search=doppler_bin_spacing_hz(config) / config.carrier_hz,
            max_echoes=0,
        )
        fit = dataclasses.replace(fit, t_start_s=paths.first_s, v_mps=eps * c)
    scale = 1 + fit.v_mps / c
    x, t, w = tone_segment(tone, plan.fs_tone, tone_t0_s, config=config, t_start_s=fit.t_start_s, scale=scale)
    f_max = v_max_mps * config.tone_hz / c
    if np.count_nonzero(w > 0.5) < _MIN_TONE_SAMPLES:  # the recording ends just after the pilot
        tfit = ToneFit(offset_hz=math.nan, amplitude=complex(math.nan), c_n0_hz=math.nan)
        v_track, settle = np.zeros(0), 0
    else:
        tfit = tone_frequency_ml(
            x, t, w, search_hz=plan.tone.passband_hz, noise_bandwidth_hz=plan.noise_bandwidth_hz("tone")
        )
        v_track, settle = tone_track_eq9(x, plan.fs_tone, f_max_hz=f_max, tone_hz=config.tone_hz, sound_speed_mps=c)
    interior = slice(settle, max(settle, len(v_track) - settle))
    track_t = (t[:-1] + 0.5 / plan.fs_tone)[interior]
    track_v = v_track[interior]
    complete = fit.t_start_s + config.frame_duration_s / scale <= tone_t0_s + len(tone) / plan.fs_tone
    snr_db = in_band_snr_db(bb, plan, bb_t0_s, t_start_s=fit.t_start_s, duration_s=config.frame_duration_s / scale)
    if snr_db is not None:
        fit = dataclasses.replace(fit, snr_db=snr_db)
    return FrameMeasurement(
        detection=detection,
        pilot=fit,
        tone=tfit,
        paths=paths,
        v_tone_ml_mps=tfit.offset_hz * c / config.tone_hz,
        v_tone_eq9_mps=float(np.mean(track_v)) if track_v.size else math.nan,
        track_t_s=track_t,
        track_v_mps=track_v,
        complete=bool(complete),
        echoes=echoes,
    )


#: noise is measured in this window before and after a frame [s] (gap to the frame, length)
NOISE_GAP_S, NOISE_WINDOW_S = 0.005, 0.05


def in_band_snr_db(bb: np.ndarray, plan: FrontEndPlan, t0_s: float, *, t_start_s: float, duration_s: float):
    """In-band SNR of SPEC §1 from powers: (frame power − noise power) / noise power in B.

    The noise PSD comes from the data baseband just before and just after the
    frame (the smaller of the two medians, so that a neighbouring frame or a
    late echo in one window does not count as noise); the signal power is the
    frame's mean power minus the noise. Unlike the pilot residual, echoes count
    as signal here, as the SPEC defines it. Returns None when neither noise
    window is available (frames back to back, start or end of the recording).

    Notes
    -----
    |bb|² of complex Gaussian noise is exponential: mean = median/ln 2. Its mean
    is S·ENBW (S the baseband PSD, ENBW the front end's noise bandwidth), the
    in-band noise S·B.
    """
    fs = plan.fs_data
    windows = (
        (t_start_s - NOISE_GAP_S - NOISE_WINDOW_S, t_start_s - NOISE_GAP_S),
        (t_start_s + duration_s + NOISE_GAP_S, t_start_s + duration_s + NOISE_GAP_S + NOISE_WINDOW_S),
    )
    levels = []
    for a, b in windows:
        lo, hi = int(math.ceil((a - t0_s) * fs)), int(math.floor((b - t0_s) * fs))
        if lo >= 0 and hi <= len(bb) and hi - lo >= 0.8 * NOISE_WINDOW_S * fs:
            levels.append(np.median(np.abs(bb[lo:hi]) ** 2) / math.log(2))
    lo = max(0, int(math.ceil((t_start_s + 0.01 - t0_s) * fs)))
    hi = min(len(bb), int(math.floor((t_start_s + duration_s - 0.01 - t0_s) * fs)))
    if not levels or hi <= lo:
        return None
    noise = min(levels)
    signal = np.mean(np.abs(bb[lo:hi]) ** 2) - noise
    in_band = noise * (plan.data.passband_hz * 2) / plan.noise_bandwidth_hz("data")
    return 10 * math.log10(max(signal, 1e-30 * noise) / max(in_band, np.finfo(float).tiny))


def power_excess(power: np.ndarray) -> float | None:
    """Mean over median-implied mean of noise powers |x|² (× ln 2: 1 for Gaussian noise, whose |x|² is
    exponential); None when the median is 0 or there are none. Impulses raise the mean, not the median."""
    median = float(np.median(power)) if np.size(power) else 0.0
    return float(np.mean(power)) * math.log(2) / median if median > 0 else None


def impulse_excess(bb: np.ndarray, plan: FrontEndPlan, t0_s: float, *, t_start_s: float, duration_s: float) -> float:
    """Mean over median-implied noise power in the noise windows around a frame (≥ 1; 1 when unknown).

    Gaussian noise has |bb|² exponential, mean = median/ln 2, so the ratio is 1
    (within ±10 % over a 50 ms window). Impulses that blanking left raise the
    mean, not the median: the ratio is how much more noise the frame's
    estimates see than :func:`in_band_snr_db` (a median) reports, and the
    record's CRLB-based σ are inflated by its square root.
    """
    fs = plan.fs_data
    ratios = []
    for a, b in (
        (t_start_s - NOISE_GAP_S - NOISE_WINDOW_S, t_start_s - NOISE_GAP_S),
        (t_start_s + duration_s + NOISE_GAP_S, t_start_s + duration_s + NOISE_GAP_S + NOISE_WINDOW_S),
    ):
        lo, hi = int(math.ceil((a - t0_s) * fs)), int(math.floor((b - t0_s) * fs))
        if lo >= 0 and hi <= len(bb) and hi - lo >= 0.8 * NOISE_WINDOW_S * fs:
            ratio = power_excess(np.abs(bb[lo:hi]) ** 2)
            if ratio is not None:
                ratios.append(ratio)
    return max(1.0, min(ratios)) if ratios else 1.0


def frame_span_s(config: FrameConfig, *, v_max_mps: float, sound_speed_mps: float) -> float:
    """Longest a received frame lasts, with its tails and the noise window after it [s].

    A frame may be stretched by |v|/c; the receiver measures a frame once this
    much of the recording past its start has arrived.
    """
    stretch = 1 + v_max_mps / sound_speed_mps
    return config.frame_duration_s * stretch + FRAME_TAIL_S + (NOISE_GAP_S + NOISE_WINDOW_S)
