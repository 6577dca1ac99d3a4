"""The streaming receiver: passband blocks in, one measurement record per frame out, memory bounded.

Pipeline (paper 000 Fig. 4, SPEC §4): front end (:mod:`.frontend`) → pilot
detection with a stated false-alarm rate and first-arrival logic
(:mod:`.detect`) → measurement of each frame (:mod:`.measure`) →
demodulation when asked (:mod:`.demodulate`) → record (:mod:`.records`).

The front end holds a few FFT blocks, the receiver the basebands of about one
frame plus one second of detection context, however long the recording.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from ..config import FrameConfig
from ..transmit.frame import build_frame
from ..transmit.modulation import constellation
from ..transmit.pilot import pilot_symbols
from .bounds import delay_crlb_s, pilot_velocity_crlb_mps, tone_velocity_crlb_mps
from .demodulate import FrameDecode, demodulate, payload_fields
from .detect import Detection, PilotDetector
from .frontend import FrontEnd, FrontEndPlan, plan_front_end
from .impulse import ImpulseBlanker
from .measure import NOISE_GAP_S, NOISE_WINDOW_S, FrameMeasurement, frame_span_s, impulse_excess, measure_frame
from .multipath import find_echoes
from .wholeframe import WholeFrameFit, fit_whole_frame
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings
from .two_way import two_way_range_m

_BLAS = None


def _one_blas_thread():
    """Context: one BLAS thread while a frame is measured and decoded.

    The receiver's linear algebra is many small products; OpenBLAS's second thread busy-waits after each
    of them. Measured on 10 deep-echo frames (12 dB, decoding on): 172–188 → 95 ms CPU per frame with the
    records bit-identical; on the demo's 60 s recording the wall time did not change (4.7 s). The limit is
    set per frame, never across a ``yield``, so the caller's own BLAS is untouched.
    """
    global _BLAS
    if _BLAS is None:
        from threadpoolctl import ThreadpoolController

        _BLAS = ThreadpoolController()
    return _BLAS.limit(limits=1, user_api="blas")

__all__ = ["Receiver", "ReceiverWarning"]


#: a fit on decisions is not used when its direct-path Es/N0 is below this share of the measured SNR's
_DECISIONS_MIN_ES_N0_SHARE = 0.1


def direct_path_share(m: FrameMeasurement) -> float:
    """The first path's share of the power of the paths resolved in the pilot (1 for a lone path).

    The in-band SNR (SPEC §1) counts every path as signal; an estimate of the
    first path alone (the pilot's arrival, the pilot bank with the echoes
    removed) has only this share of it.
    """
    paths = m.echoes if m.echoes is not None else m.paths
    power = np.abs(np.asarray(paths.amplitudes)) ** 2
    if power.size < 2 or not np.all(np.isfinite(power)) or power.sum() <= 0:
        return 1.0
    first = int(np.argmin(np.abs(np.asarray(paths.delays_s) - paths.first_s)))
    return float(max(power[first] / power.sum(), 1e-3))


def tone_fallback_sigma_mps(sigma_tone: float, sigma_bank: float, gap: float, *, echoes: bool) -> float:
    """σ of the tone ML as the direct path's v_r [m/s], without a whole-frame fit.

    Parameters
    ----------
    sigma_tone : float
        The tone's CRLB at its C/N0 [m/s].
    sigma_bank : float
        The pilot bank's σ (the direct path's own, pilot-only estimate) [m/s].
    gap : float
        |tone − bank| [m/s].
    echoes : bool
        Whether the pilot resolved paths after the first.

    Notes
    -----
    Model: tone = v + b + n_t, bank = v + n_b, b the tone's multipath bias.
    With echoes resolved the tone sums paths whose Doppler differs by less
    than its resolution (1/T ≈ 3 Hz, 25 cm/s at 20 kHz): b is not observable
    in the tone (two paths of amplitude ratio ρ, a relative phase uniform and
    slow over the frame: b has an RMS of Δv·ρ/√(2(1 − ρ²)), 1.5 Δv at ρ = 0.9;
    0.8 Δv for Δv = 5 cm/s over 0.3 s in tests/receive/test_sigma_rules.py), and the tone's error is
    (tone − bank) + (bank − v): its second moment given the gap is
    gap² + σ_bank², with σ_tone² for the tone's own noise. Without resolved
    echoes b is small unless the gap shows it, and only a gap beyond 3 of the
    bank's σ is counted. In the benchmark's deep echoes (tone RMSE 34 mm/s,
    CRLB 1–20 mm/s) this puts 0.92–0.98 of the tone estimates within 3σ
    against 0.29–0.47 with the second form alone.
    """
    if echoes:
        return math.sqrt(sigma_tone**2 + gap**2 + sigma_bank**2)
    return math.sqrt(sigma_tone**2 + max(0.0, gap**2 - 9 * sigma_bank**2))


class ReceiverWarning(UserWarning):
    """A degraded but usable result (clipped input, no frame found, truncated frame...)."""


class Receiver:
    """Streaming receiver: feed passband blocks, get measurement records.

    Parameters
    ----------
    config : FrameConfig
        The transmitted frame (pilot, tone, symbol rate).
    emissions : Emissions
        When frames (or, two-way, polls) were emitted.
    settings : ReceiverSettings
        Sound speed, clock offset, turnaround, v_max, false-alarm rate,
        decoding and equaliser (default: ``ReceiverSettings()``).
    pilot : numpy.ndarray, optional
        Pilot symbols (default: from the config's seed).
    payloads : sequence of bytes, optional
        The payload sent in each frame, by frame_index (from the sidecar), to
        count bit errors when decoding.
    on_frame : callable, optional
        Called with (FrameMeasurement, bb, bb_t0_s, fs_bb) for every frame:
        the data baseband around it, its first sample's time [s] and its
        rate [Hz], e.g. to plot the frame or to compensate it.

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
        settings: ReceiverSettings | None = None,
        pilot: np.ndarray | None = None,
        payloads=None,
        on_frame: Callable | None = None,
    ):
        self.config = config
        self.emissions = emissions
        self.settings = ReceiverSettings() if settings is None else settings
        self.pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
        self.payloads = None if payloads is None else list(payloads)
        self.on_frame = on_frame
        self._blanker: ImpulseBlanker | None = None

    def _record(self, m: FrameMeasurement, bb: np.ndarray, t0_s: float, fs: float) -> MeasurementRecord:
        s = self.settings
        c = s.sound_speed_mps
        t_arr = m.pilot.t_start_s
        if s.turnaround_s is None:
            k, t_emit = self.emissions.frame_for(t_arr - s.clock_offset_s)
        else:
            k, t_emit = self.emissions.frame_for(t_arr - s.turnaround_s)
        # impulses that blanking left are noise the median-based SNR does not see; the pilot's estimates
        # (arrival, bank) have only the direct path's share of the in-band SNR, which counts echoes as signal
        excess = impulse_excess(bb, self.plan, t0_s, t_start_s=t_arr, duration_s=self.config.frame_duration_s)
        snr_direct_db = m.pilot.snr_db + 10 * math.log10(direct_path_share(m))
        sigma_tau = float(delay_crlb_s(self.config, snr_direct_db)) * math.sqrt(excess)
        sent = None
        if self.payloads is not None and 0 <= k < len(self.payloads):
            sent = self.payloads[k]
        dec = demodulate(m, bb, t0_s, fs, config=self.config, pilot=self.pilot, settings=s, sent_payload=sent)
        doppler, timing = self._doppler(m, dec, bb, t0_s, fs, excess, snr_direct_db)
        sigma_bank = doppler.pop("sigma_bank")
        # the direct path's data-aided arrival over the frame; on decisions, only when its σ is the smaller
        # (a fit on decisions mostly wrong: 23 mm off, σ 29 mm, where the pilot's arrival was 1 mm off)
        if timing is not None and (doppler["v_r_source"] == "whole_frame" or timing[1] < sigma_tau):
            t_arr, sigma_tau = timing
        if s.turnaround_s is None:
            tof = t_arr - t_emit - s.clock_offset_s
        else:
            tof = float(two_way_range_m(t_emit, t_arr, turnaround_s=s.turnaround_s, sound_speed_mps=1.0))
            sigma_tau /= 2  # the reply's arrival is the only measured time; the poll's emission is known
        return MeasurementRecord(
            frame_index=int(k),
            t_emit_s=float(t_emit),
            t_arrival_s=float(t_arr),
            tof_s=float(tof),
            range_m=float(c * tof),
            snr_db=float(m.pilot.snr_db),
            v_r_tone_eq9_mps=m.v_tone_eq9_mps,
            v_r_bank_mps=float(m.pilot.v_mps),
            detection_z=m.detection.z,
            detection_rho=m.detection.rho,
            sigma_range_m=c * sigma_tau,
            sigma_v_r_bank_mps=sigma_bank,
            tone_c_n0_dbhz=10 * math.log10(max(m.tone.c_n0_hz, 1e-30)),
            two_way=s.turnaround_s is not None,
            blanked_fraction=self._blanked_fraction(m),
            **doppler,
            **payload_fields(dec),
        )

    def _blanked_fraction(self, m: FrameMeasurement) -> float:
        if self._blanker is None:
            return math.nan
        fs = self.plan.fs
        start = m.pilot.t_start_s
        return self._blanker.blanked_fraction(int(start * fs), int((start + self.config.frame_duration_s) * fs))

    def _doppler(self, m: FrameMeasurement, dec: FrameDecode | None, bb, t0_s: float, fs: float,
                 excess: float, snr_direct_db: float) -> tuple[dict, tuple[float, float] | None]:
        """v_r_mps, its σ and source (and the bank's σ, ``sigma_bank``): the direct path's whole-frame Doppler
        when decoded, else the tone ML; and (arrival [s], its σ [s]) of the direct path from the whole-frame
        fit, or None.

        The tone sums every path; it is flagged as multipath-biased when it and
        the direct path's own estimate (whole-frame fit, else the pilot bank)
        differ by more than 3 combined σ. Without the whole-frame fit, the
        tone's σ covers its bias as far as the frame shows it
        (:func:`tone_fallback_sigma_mps`). A fit on
        decisions (CRC failed) has its σ grown by its gap to the pilot bank
        beyond 3 of the bank's σ (runs of wrong decisions bias it unseen by
        its own scatter); it is not used when it then disagrees with the tone
        by more than 3 combined σ (the tone's with that gap), or when its σ is
        not below the tone's: the tone is then the estimate, and the pilot's
        arrival the range.
        """
        c = self.settings.sound_speed_mps
        v_tone = m.v_tone_ml_mps
        sigma_tone = float(tone_velocity_crlb_mps(self.config, m.tone.c_n0_hz, sound_speed_mps=c))
        sigma_bank = float(pilot_velocity_crlb_mps(self.config, snr_direct_db, sound_speed_mps=c)) * math.sqrt(excess)
        gap = abs(v_tone - m.pilot.v_mps)
        sigma_tone_gap = tone_fallback_sigma_mps(sigma_tone, sigma_bank, gap, echoes=len(m.paths.delays_s) > 1)
        fit = self._whole_frame(m, dec, bb, t0_s, fs) if dec is not None and self.settings.whole_frame_doppler else None
        inflation = 1.0
        if fit is not None and fit[2] == "whole_frame_decisions":
            # decided symbols can be wrong in runs and pull the fit away: they bias every segment alike,
            # which the segments' scatter does not see (1 frame in 100 at 6–12 dB in the benchmark's deep
            # echoes, raw BER 0.16–0.5: −435 mm/s with σ 21 mm/s). The pilot bank does not use them: its
            # gap to the fit beyond 3 of its σ is added to the fit's σ (as to the tone's), and to the
            # timing's in proportion; the fit is then kept only when the tone agrees and its σ is the smaller
            v, sigma = float(fit[0].v_mps[fit[1]]), float(fit[0].sigma_v_mps[fit[1]])
            grown = math.sqrt(sigma**2 + max(0.0, (v - m.pilot.v_mps) ** 2 - 9 * sigma_bank**2))
            inflation = grown / sigma if sigma > 0 else 1.0
            # decisions that do not explain the frame: the fit's direct-path Es/N0 (from its residual) far
            # below what the measured SNR gives that path (amplitude ∝ 1 − 2q for a share q of wrong BPSK
            # decisions: below 0.1 is q ≳ 1/3). Benchmark: such fits 0.001–0.06 of it and 9–863 mm/s off;
            # fits on good decisions 0.38–0.89, decoded frames ≥ 0.26 in α-stable noise (its mean power is
            # its tail's). Its bias is then as unobservable as the tone's among echoes, and its σ is found
            # the same way (tone_fallback_sigma_mps): the one with the smaller σ is used
            expected = 10 ** (snr_direct_db / 10) * (1 + self.config.rolloff)
            if float(fit[0].es_n0[fit[1]]) < _DECISIONS_MIN_ES_N0_SHARE * expected:
                grown = math.sqrt(sigma**2 + (v - m.pilot.v_mps) ** 2 + sigma_bank**2)
                inflation = grown / sigma if sigma > 0 else 1.0
                if math.isfinite(v_tone) and not grown < sigma_tone_gap:
                    fit = None
            elif math.isfinite(v_tone) and not (abs(v - v_tone) <= 3 * math.hypot(grown, sigma_tone_gap)
                                                and grown < sigma_tone_gap):
                fit = None
        if fit is not None and math.isfinite(fit[0].v_mps[fit[1]]):
            wf, first, source = fit
            v, sigma = float(wf.v_mps[first]), float(wf.sigma_v_mps[first]) * inflation
            biased = abs(v_tone - v) > 3 * math.hypot(sigma_tone, sigma)
            return dict(v_r_mps=v, sigma_v_r_mps=sigma, sigma_bank=sigma_bank, v_r_source=source, v_r_tone_mps=v_tone,
                        tone_multipath_biased=bool(biased) if math.isfinite(v_tone) else None,
                        v_r_paths_spread_mps=float(np.ptp(wf.v_mps)), n_paths=len(wf.v_mps)), \
                (float(wf.delays_s[first]), float(wf.sigma_delay_s[first]) * inflation)
        if not math.isfinite(v_tone):  # no tone (frame cut just after its pilot): the bank
            return dict(v_r_mps=float(m.pilot.v_mps), sigma_v_r_mps=sigma_bank, sigma_bank=sigma_bank, v_r_source="bank",
                        v_r_tone_mps=v_tone, n_paths=len(m.paths.delays_s)), None
        return dict(v_r_mps=v_tone, sigma_v_r_mps=sigma_tone_gap, sigma_bank=sigma_bank, v_r_source="tone",
                    v_r_tone_mps=v_tone, tone_multipath_biased=bool(gap > 3 * math.hypot(sigma_tone, sigma_bank)),
                    n_paths=len(m.paths.delays_s)), None

    def _whole_frame(self, m: FrameMeasurement, dec: FrameDecode, bb, t0_s: float, fs: float):
        """(WholeFrameFit, index of the first path, source) of a decoded frame, or None."""
        cfg, c = self.config, self.settings.sound_speed_mps
        if dec.crc_ok:
            data = build_frame(cfg, dec.payload).data_symbols
            trusted = np.ones(cfg.n_data, bool)
            source = "whole_frame"
        else:
            # pilots and the data decisions that lie close to their constellation point
            points = constellation(cfg.modulation)
            soft = np.asarray(dec.equalized)[: cfg.n_data]
            nearest = np.argmin(np.abs(soft[:, None] - points[None, :]), axis=1)
            data = points[nearest]
            half_gap = 0.5 * np.min(np.abs(points[1:] - points[0]))
            trusted = np.abs(soft - data) < 0.5 * half_gap
            source = "whole_frame_decisions"
        symbols = np.concatenate([self.pilot, data])
        reference = np.concatenate([np.ones(cfg.n_pilot, bool), trusted])
        eps = m.pilot.v_mps / c
        paths = m.echoes if m.echoes is not None else find_echoes(bb, fs, t0_s, config=cfg, pilot=self.pilot,
                                                                  paths=m.paths, eps=eps)
        try:
            wf: WholeFrameFit = fit_whole_frame(bb, fs, t0_s, config=cfg, symbols=symbols, reference=reference,
                                                delays_s=paths.delays_s, v_mps=m.compensation_speed_mps,
                                                sound_speed_mps=c)
        except ValueError:  # too few trusted symbols
            return None
        first = int(np.argmin(np.abs(wf.delays_s - paths.first_s)))
        return wf, first, source

    def run(self, blocks: Iterable[np.ndarray], *, fs: float) -> Iterator[MeasurementRecord]:
        """Records of the frames in consecutive real passband ``blocks`` at rate ``fs``, as found."""
        cfg, s = self.config, self.settings
        plan = plan_front_end(cfg, fs, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)
        fe = FrontEnd(plan)
        self._blanker = ImpulseBlanker(threshold=s.impulse_threshold) if s.blank_impulses else None
        det = PilotDetector(
            cfg,
            plan.fs_data,
            v_max_mps=s.v_max_mps,
            sound_speed_mps=s.sound_speed_mps,
            false_alarms_per_hour=s.false_alarms_per_hour,
            pilot=self.pilot,
        )
        self.plan, self.detector = plan, det
        span = frame_span_s(cfg, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)
        state = _Buffers()
        scan_from = 0
        pending: list[Detection] = []
        blanker = self._blanker
        for block in blocks:
            state.append(*fe.push(block if blanker is None else blanker.push(block)))
            found, scan_from = det.find(state.bb, state.bb_start, scan_from, final=False)
            pending.extend(found)
            yield from self._measure_ready(pending, state, plan, span, final=False)
            oldest = min(
                [scan_from - det.context - det.length]
                + [int((d.t_start_s - NOISE_GAP_S - NOISE_WINDOW_S) * plan.fs_data) - 64 for d in pending]
            )
            state.trim(oldest, plan)
            if blanker is not None:
                blanker.forget_before(state.bb_start * plan.data.decimation)
        if blanker is not None:
            state.append(*fe.push(blanker.flush()))
        state.append(*fe.flush())
        found, scan_from = det.find(state.bb, state.bb_start, scan_from, final=True)
        pending.extend(found)
        yield from self._measure_ready(pending, state, plan, span, final=True)

    def _measure_ready(
        self, pending: list[Detection], state: _Buffers, plan: FrontEndPlan, span_s: float, *, final: bool
    ) -> Iterator[MeasurementRecord]:
        """Records of the pending detections whose whole span has arrived (all of them when ``final``).

        The detections measured are removed from ``pending``; the others wait for more samples.
        """
        t_end = min(state.bb_end / plan.fs_data, state.tone_end / plan.fs_tone)
        ready = [d for d in pending if final or d.t_start_s + span_s <= t_end]
        pending[:] = [d for d in pending if not (final or d.t_start_s + span_s <= t_end)]
        bb_t0 = state.bb_start / plan.fs_data
        for d in ready:
            with _one_blas_thread():
                record = self._measure_one(d, state, plan, bb_t0)
            yield record

    def _measure_one(self, d: Detection, state: _Buffers, plan: FrontEndPlan, bb_t0: float) -> MeasurementRecord:
        """Measure (and decode) one detection whose span has arrived."""
        m = measure_frame(
            state.bb,
            state.tone,
            d,
            plan=plan,
            config=self.config,
            pilot=self.pilot,
            sound_speed_mps=self.settings.sound_speed_mps,
            v_max_mps=self.settings.v_max_mps,
            bb_t0_s=bb_t0,
            tone_t0_s=state.tone_start / plan.fs_tone,
        )
        if not m.complete:
            warnings.warn(
                f"frame at {m.pilot.t_start_s:.3f} s is cut by the end of the recording: "
                "its Doppler uses the part received",
                ReceiverWarning,
                stacklevel=4,  # the caller iterating Receiver.run
            )
        if self.on_frame is not None:
            self.on_frame(m, state.bb, bb_t0, plan.fs_data)
        return self._record(m, state.bb, bb_t0, plan.fs_data)


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
