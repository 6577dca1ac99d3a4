"""The receiver: recording → one measurement record per frame, streamed.

Pipeline (paper 000 Fig. 4, SPEC §4): front end (:mod:`.frontend`) → pilot
detection with a stated false-alarm rate and first-arrival logic
(:mod:`.detect`) → sub-sample arrival and pilot Doppler, tone Doppler by eq 9
and by maximum likelihood (:mod:`.doppler`) → record (:mod:`.records`).

Memory is bounded: the front end holds a few FFT blocks, the receiver the
basebands of about one frame plus one second of detection context, however
long the recording.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import soundfile

from .._progress import progress_bar
from ..config import FrameConfig
from ..errors import ConfigError, InputFileError
from ..io.wav import wav_channel
from ..transmit.pilot import pilot_symbols
from .bounds import delay_crlb_s, pilot_velocity_crlb_mps, tone_velocity_crlb_mps
from .detect import Detection, PilotDetector, doppler_bin_spacing_hz
from .doppler import PilotFit, ToneFit, fit_pilot, tone_frequency_ml, tone_segment, tone_track_eq9
from .frontend import FrontEnd, FrontEndPlan, plan_front_end
from .multipath import PathFit, direct_path_doppler, fit_paths
from .records import MeasurementRecord
from .two_way import two_way_range_m

__all__ = [
    "Emissions",
    "FrameMeasurement",
    "measure_frame",
    "Receiver",
    "receive_file",
    "ReceiverWarning",
    "in_band_snr_db",
]


class ReceiverWarning(UserWarning):
    """A degraded but usable result (clipped input, no frame found, truncated frame...)."""


@dataclass(frozen=True)
class Emissions:
    """When frames were emitted: an explicit list, or a PPS-synchronised period.

    Parameters
    ----------
    times_s : numpy.ndarray, optional
        Emission time of each frame (sidecar) [s], increasing; frame_index is
        the position in this list.
    start_s, period_s : float, optional
        Frame k emitted at start + k·period (``--emit-start``, ``--emit-period``).
    """

    times_s: np.ndarray | None = None
    start_s: float | None = None
    period_s: float | None = None

    def __post_init__(self):
        if self.times_s is None:
            if self.start_s is None or self.period_s is None:
                raise ConfigError("emissions", "give emission times, or both start and period")
            if not (math.isfinite(self.period_s) and self.period_s > 0):
                raise ConfigError("emit_period", f"must be > 0, got {self.period_s!r}")
            if not math.isfinite(self.start_s):
                raise ConfigError("emit_start", f"must be finite, got {self.start_s!r}")
        else:
            times = np.asarray(self.times_s, dtype=float)
            if times.ndim != 1 or times.size == 0 or np.any(np.diff(times) <= 0) or not np.all(np.isfinite(times)):
                raise ConfigError("emissions", "emission times must be a non-empty increasing list of finite numbers")
            object.__setattr__(self, "times_s", times)

    def frame_for(self, t_s: float) -> tuple[int, float]:
        """(frame_index, t_emit_s) of the latest emission at or before ``t_s``; (−1, nan) if none."""
        slack = 1e-6  # a frame heard at tof ≈ 0 may measure a hair early
        if self.times_s is None:
            k = math.floor((t_s - self.start_s + slack) / self.period_s)
            return (k, self.start_s + k * self.period_s) if k >= 0 else (-1, math.nan)
        k = int(np.searchsorted(self.times_s, t_s + slack, side="right")) - 1
        return (k, float(self.times_s[k])) if k >= 0 else (-1, math.nan)


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
    if len(paths.delays_s) > 1:
        # unresolved echoes pull the single-path fit towards them: take the first path's
        # delay, and its Doppler with the echoes' pilots removed
        eps = direct_path_doppler(
            bb,
            plan.fs_data,
            bb_t0_s,
            config=config,
            pilot=pilot,
            paths=paths,
            eps=fit.v_mps / c,
            search=doppler_bin_spacing_hz(config) / config.carrier_hz,
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


class Receiver:
    """Streaming receiver: feed passband blocks, get measurement records.

    Parameters
    ----------
    config : FrameConfig
        The transmitted frame (pilot, tone, symbol rate).
    emissions : Emissions
        When frames (or, two-way, polls) were emitted.
    sound_speed_mps : float
        c [m/s].
    clock_offset_s : float
        Receiver clock minus beacon clock [s], removed from the one-way tof.
    turnaround_s : float, optional
        Beacon's reply delay: two-way ranging (paper 004 §III.B); then the
        emissions are the vehicle's polls and the clock offset is not used.
    v_max_mps : float
        Largest |v_r| searched [m/s].
    false_alarms_per_hour : float
        Detector design rate in white noise (sets the threshold).
    pilot : numpy.ndarray, optional
        Pilot symbols (default: from the config's seed).
    on_frame : callable, optional
        Called with (FrameMeasurement, bb, bb_t0_s, fs_bb) for every frame:
        the data baseband around it, its first sample's time [s] and its
        rate [Hz], e.g. to plot the frame or to compensate it.
    decode : bool
        Also equalise and decode each complete frame's payload (issue 5):
        compensation at the tone's mean speed (eq 10–11), fractionally spaced
        DFE with PLL, turbo passes while the CRC fails. Fills ``crc_ok``,
        ``payload_hex``, ``payload_text``, ``eq_snr_db`` (and ``ber``,
        ``raw_ber`` when ``payloads`` are given).
    dfe_settings : DfeSettings, optional
        A fixed equaliser; default: sized per frame to the delay spread of the
        frame's delay spread measured on the pilots
        (:func:`seamodem.decode.frame.channel_span_symbols`, :func:`~seamodem.decode.frame.dfe_for_span`).
    turbo_passes : int
        Most equaliser passes per frame (1: DFE only).
    payloads : sequence of bytes, optional
        The payload sent in each frame, by frame_index (from the sidecar), to
        count bit errors.
    follow_track : bool
        Compensation (eq 10–11) follows the eq 9 speed track smoothed to its
        least-squares line through the ML mean speed (the frame's
        acceleration); False: the constant mean speed. At ±0.2 m/s² both give
        the same raw BER (measured, 20 frames at 6 and 15 dB): the PLL absorbs
        the 0.26 rad of quadratic phase a constant speed leaves.

    Examples
    --------
    >>> from seamodem import get_preset
    >>> cfg = get_preset("jmse2024")
    >>> rx = Receiver(cfg, emissions=Emissions(start_s=0.0, period_s=3.0))
    >>> list(rx.run([np.zeros(96153)], fs=96153))
    []
    """

    def __init__(
        self,
        config: FrameConfig,
        *,
        emissions: Emissions,
        sound_speed_mps: float = 1500.0,
        clock_offset_s: float = 0.0,
        turnaround_s: float | None = None,
        v_max_mps: float = 5.0,
        false_alarms_per_hour: float = 0.01,
        pilot: np.ndarray | None = None,
        on_frame=None,
        decode: bool = False,
        dfe_settings=None,
        turbo_passes: int = 3,
        payloads=None,
        follow_track: bool = True,
    ):
        for name, value in (("sound_speed", sound_speed_mps), ("v_max", v_max_mps)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(name, f"must be a positive number, got {value!r}")
        if not (math.isfinite(clock_offset_s)):
            raise ConfigError("clock_offset", f"must be finite, got {clock_offset_s!r}")
        if turnaround_s is not None and not (math.isfinite(turnaround_s) and turnaround_s >= 0):
            raise ConfigError("turnaround", f"must be >= 0, got {turnaround_s!r}")
        if not (false_alarms_per_hour > 0):
            raise ConfigError("false_alarms_per_hour", f"must be > 0, got {false_alarms_per_hour!r}")
        self.config = config
        self.emissions = emissions
        self.sound_speed_mps = float(sound_speed_mps)
        self.clock_offset_s = float(clock_offset_s)
        self.turnaround_s = turnaround_s
        self.v_max_mps = float(v_max_mps)
        self.false_alarms_per_hour = float(false_alarms_per_hour)
        self.pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
        self.on_frame = on_frame
        if isinstance(turbo_passes, bool) or not isinstance(turbo_passes, int) or turbo_passes < 1:
            raise ConfigError("turbo_passes", f"must be an integer >= 1, got {turbo_passes!r}")
        self.decode = bool(decode)
        self.dfe_settings = dfe_settings
        self.turbo_passes = turbo_passes
        self.follow_track = bool(follow_track)
        self.payloads = None if payloads is None else list(payloads)

    def _decode(self, m: FrameMeasurement, bb: np.ndarray, t0_s: float, fs: float, frame_index: int):
        """Payload of a measured frame (None when not decoding or the frame is cut)."""
        if not self.decode or not m.complete:
            return None
        from ..decode.frame import decode_received

        sent = None
        if self.payloads is not None and 0 <= frame_index < len(self.payloads):
            sent = self.payloads[frame_index]
        return decode_received(
            bb,
            fs,
            t0_s,
            config=self.config,
            pilot=self.pilot,
            t_start_s=m.pilot.t_start_s,
            v_mps=m.compensation_speed_mps,
            sound_speed_mps=self.sound_speed_mps,
            settings=self.dfe_settings,
            passes=self.turbo_passes,
            sent_payload=sent,
            track_t_s=m.track_t_s if self.follow_track else None,
            track_v_mps=m.track_v_mps if self.follow_track else None,
        )

    def _record(self, m: FrameMeasurement, bb: np.ndarray, t0_s: float, fs: float) -> MeasurementRecord:
        c = self.sound_speed_mps
        t_arr = m.pilot.t_start_s
        if self.turnaround_s is None:
            k, t_emit = self.emissions.frame_for(t_arr - self.clock_offset_s)
            tof = t_arr - t_emit - self.clock_offset_s
        else:
            k, t_emit = self.emissions.frame_for(t_arr - self.turnaround_s)
            tof = float(two_way_range_m(t_emit, t_arr, turnaround_s=self.turnaround_s, sound_speed_mps=1.0))
        sigma_tau = float(delay_crlb_s(self.config, m.pilot.snr_db))
        if self.turnaround_s is not None:
            sigma_tau /= 2  # the reply's arrival is the only measured time; the poll's emission is known
        return MeasurementRecord(
            frame_index=int(k),
            t_emit_s=float(t_emit),
            t_arrival_s=float(t_arr),
            tof_s=float(tof),
            range_m=float(c * tof),
            v_r_mps=m.v_tone_ml_mps,
            snr_db=float(m.pilot.snr_db),
            v_r_tone_eq9_mps=m.v_tone_eq9_mps,
            v_r_bank_mps=float(m.pilot.v_mps),
            detection_z=m.detection.z,
            detection_rho=m.detection.rho,
            sigma_range_m=c * sigma_tau,
            sigma_v_r_mps=float(tone_velocity_crlb_mps(self.config, m.tone.c_n0_hz, sound_speed_mps=c)),
            sigma_v_r_bank_mps=float(pilot_velocity_crlb_mps(self.config, m.pilot.snr_db, sound_speed_mps=c)),
            tone_c_n0_dbhz=10 * math.log10(max(m.tone.c_n0_hz, 1e-30)),
            two_way=self.turnaround_s is not None,
            **_payload_fields(self._decode(m, bb, t0_s, fs, int(k))),
        )

    def run(self, blocks: Iterable[np.ndarray], *, fs: float) -> Iterator[MeasurementRecord]:
        """Records of the frames in consecutive real passband ``blocks`` at rate ``fs``, as found."""
        cfg = self.config
        plan = plan_front_end(cfg, fs, v_max_mps=self.v_max_mps, sound_speed_mps=self.sound_speed_mps)
        fe = FrontEnd(plan)
        det = PilotDetector(
            cfg,
            plan.fs_data,
            v_max_mps=self.v_max_mps,
            sound_speed_mps=self.sound_speed_mps,
            false_alarms_per_hour=self.false_alarms_per_hour,
            pilot=self.pilot,
        )
        self.plan, self.detector = plan, det
        # a frame may be stretched by |v|/c; the tone and pulse tails need a little more
        frame_span = cfg.frame_duration_s * (1 + self.v_max_mps / self.sound_speed_mps) + 0.02
        frame_span += NOISE_GAP_S + NOISE_WINDOW_S  # the noise window after the frame
        state = _Buffers()
        scan_from = 0
        pending: list[Detection] = []

        def ready(final: bool):
            nonlocal pending
            t_end = min(state.bb_end / plan.fs_data, state.tone_end / plan.fs_tone)
            keep = []
            for d in pending:
                if final or d.t_start_s + frame_span <= t_end:
                    m = measure_frame(
                        state.bb,
                        state.tone,
                        d,
                        plan=plan,
                        config=cfg,
                        pilot=self.pilot,
                        sound_speed_mps=self.sound_speed_mps,
                        v_max_mps=self.v_max_mps,
                        bb_t0_s=state.bb_start / plan.fs_data,
                        tone_t0_s=state.tone_start / plan.fs_tone,
                    )
                    if not m.complete:
                        warnings.warn(
                            f"frame at {m.pilot.t_start_s:.3f} s is cut by the end of the recording: "
                            "its Doppler uses the part received",
                            ReceiverWarning,
                            stacklevel=3,
                        )
                    if self.on_frame is not None:
                        self.on_frame(m, state.bb, state.bb_start / plan.fs_data, plan.fs_data)
                    yield self._record(m, state.bb, state.bb_start / plan.fs_data, plan.fs_data)
                else:
                    keep.append(d)
            pending = keep

        for block in blocks:
            bb, tone = fe.push(block)
            state.append(bb, tone)
            found, scan_from = det.find(state.bb, state.bb_start, scan_from, final=False)
            pending.extend(found)
            yield from ready(final=False)
            oldest = min([scan_from - det.context - det.length] + [int((d.t_start_s - NOISE_GAP_S - NOISE_WINDOW_S) * plan.fs_data) - 64 for d in pending])
            state.trim(oldest, plan)
        bb, tone = fe.flush()
        state.append(bb, tone)
        found, scan_from = det.find(state.bb, state.bb_start, scan_from, final=True)
        pending.extend(found)
        yield from ready(final=True)


def _payload_fields(dec) -> dict:
    """The record's payload columns from a FrameDecode (or their empty values)."""
    if dec is None:
        return {}
    text = ""
    if dec.crc_ok:
        try:
            text = dec.payload.decode("utf-8")
        except UnicodeDecodeError:
            text = ""
        if not text.isprintable():
            text = ""
    return {
        "crc_ok": dec.crc_ok,
        "payload_hex": dec.payload.hex() if dec.crc_ok else "",
        "payload_text": text,
        "eq_snr_db": dec.eq_snr_db,
        "decode_passes": dec.passes,
        "ber": dec.ber,
        "raw_ber": dec.raw_ber,
    }


class _Buffers:
    """Recent data and tone baseband samples with their global start indices."""

    def __init__(self):
        self.bb = np.zeros(0, complex)
        self.tone = np.zeros(0, complex)
        self.bb_start = 0
        self.tone_start = 0

    @property
    def bb_end(self) -> int:
        return self.bb_start + len(self.bb)

    @property
    def tone_end(self) -> int:
        return self.tone_start + len(self.tone)

    def append(self, bb, tone):
        self.bb = np.concatenate([self.bb, bb])
        self.tone = np.concatenate([self.tone, tone])

    def trim(self, oldest_bb: int, plan: FrontEndPlan):
        cut = max(0, oldest_bb - self.bb_start)
        self.bb = self.bb[cut:]
        self.bb_start += cut
        oldest_tone = int(math.floor(self.bb_start * plan.data.decimation / plan.tone.decimation))
        cut = max(0, oldest_tone - self.tone_start)
        self.tone = self.tone[cut:]
        self.tone_start += cut


def _file_blocks(path: Path, info, channel: int, block: int, progress: bool | None) -> Iterator[np.ndarray]:
    """Blocks of one channel, checked for NaN, truncation and clipping as they are read."""
    clipped = 0
    n_read = 0
    silent = True
    pcm = info.subtype.startswith("PCM")
    with soundfile.SoundFile(str(path)) as f, progress_bar(
        total=info.frames, desc="rx", unit="sample", unit_scale=True, enabled=progress
    ) as bar:
        while True:
            try:
                data = f.read(block, dtype="float64", always_2d=True)
            except (soundfile.LibsndfileError, RuntimeError) as exc:
                raise InputFileError(f"recording {path} is truncated or corrupt: {exc}") from None
            if data.shape[0] == 0:
                break
            x = np.ascontiguousarray(data[:, channel])
            if not np.all(np.isfinite(x)):
                raise InputFileError(f"recording {path} contains NaN or infinite samples (near sample {n_read})")
            silent = silent and not np.any(x)
            clipped += int(np.count_nonzero(np.abs(x) >= (1.0 - 2.0**-15 if pcm else 1.0)))
            n_read += len(x)
            bar.update(len(x))
            yield x
    if n_read < info.frames:
        raise InputFileError(f"recording {path} is truncated: header says {info.frames} samples, read {n_read}")
    if silent:
        warnings.warn(f"recording {path} is silent (all samples are zero)", ReceiverWarning, stacklevel=2)
    if clipped:
        warnings.warn(
            f"recording {path}: {clipped} samples are clipped at full scale; measurements may be biased",
            ReceiverWarning,
            stacklevel=2,
        )


def receive_file(
    path: str | Path,
    config: FrameConfig,
    *,
    emissions: Emissions,
    channel: int | None = None,
    progress: bool | None = None,
    **receiver_options,
) -> Iterator[MeasurementRecord]:
    """Measurement records of every frame in an audio file, yielded as frames are found.

    Parameters
    ----------
    path : str or Path
        WAV (or any format soundfile reads); any sample rate that holds the band.
    config : FrameConfig
    emissions : Emissions
    channel : int, optional
        Channel of a multichannel file (required then).
    progress : bool, optional
        Progress bar (default: on a terminal).
    **receiver_options
        Passed to :class:`Receiver` (sound_speed_mps, clock_offset_s, turnaround_s, v_max_mps, ...).

    Raises
    ------
    InputFileError
        Missing, empty, non-audio, truncated or NaN-bearing file; bad channel.

    Warns
    -----
    ReceiverWarning
        Silent or clipped recording; no frame found.
    """
    path = Path(path)
    info, ch = wav_channel(path, channel=channel)
    rx = Receiver(config, emissions=emissions, **receiver_options)
    blocks = _file_blocks(path, info, ch, 1 << 20, progress)
    n = 0
    for rec in rx.run(blocks, fs=info.samplerate):
        n += 1
        yield rec
    if n == 0:
        warnings.warn(f"no frame found in {path}", ReceiverWarning, stacklevel=2)
