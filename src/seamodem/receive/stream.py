"""The streaming receiver: passband blocks in, one measurement record per frame out, memory bounded.

Pipeline (paper 000 Fig. 4, SPEC §4): front end (:mod:`.frontend`) → pilot
detection with a stated false-alarm rate and first-arrival logic
(:mod:`.detect`) → each frame, once its span has arrived, to the per-frame
stage (:class:`~seamodem.receive.frame.FrameMeasurer`: measurement
(:mod:`.measure`), demodulation when asked (:mod:`.demodulate`), record
(:mod:`.records`)). This module holds only the streaming loop.

The front end holds a few FFT blocks, the receiver the basebands of about one
frame plus one second of detection context, however long the recording.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np

from ..config import FrameConfig
from ..transmit.pilot import pilot_symbols
from .detect import Detection, PilotDetector
from .frame import (  # noqa: F401  (direct_path_share, tone_fallback_sigma_mps: importable from here as before)
    BasebandBuffers,
    FrameMeasurer,
    ReceiverWarning,
    RecordLookahead,
    detector_options,
    direct_path_share,
    receiver_front_end,
    tone_fallback_sigma_mps,
)
from .frontend import FrontEnd
from .measure import NOISE_GAP_S, NOISE_WINDOW_S
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings

__all__ = ["Receiver", "ReceiverWarning"]


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

    Attributes
    ----------
    plan : FrontEndPlan
        The front end of the last :meth:`run` (set when it starts).
    blanker : ImpulseBlanker or None
        Its impulse blanker (None with ``blank_impulses`` off).
    detector : PilotDetector
        Its detector.
    measurer : FrameMeasurer
        Its per-frame measurement stage (:mod:`.frame`).

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

    def run(self, blocks: Iterable[np.ndarray], *, fs: float) -> Iterator[MeasurementRecord]:
        """Records of the frames in consecutive real passband ``blocks`` at rate ``fs``, as found.

        Sets :attr:`plan`, :attr:`blanker`, :attr:`detector` and
        :attr:`measurer` for this recording.

        Parameters
        ----------
        blocks : iterable of numpy.ndarray
            Consecutive real passband samples, any block lengths.
        fs : float
            Their sample rate [Hz].

        Yields
        ------
        MeasurementRecord
            One per frame, in the order their spans arrive.
        """
        cfg, s = self.config, self.settings
        plan, blanker = receiver_front_end(cfg, fs, s)
        fe = FrontEnd(plan)
        det = PilotDetector(cfg, plan.fs_data, **detector_options(s, self.pilot))
        measurer = FrameMeasurer(cfg, plan, emissions=self.emissions, settings=s, pilot=self.pilot,
                                 payloads=self.payloads, blanker=blanker, on_frame=self.on_frame)
        self.plan, self.blanker, self.detector, self.measurer = plan, blanker, det, measurer
        self._lookahead = RecordLookahead(measurer, s.lookahead_frames)
        state = BasebandBuffers()
        scan_from = 0
        pending: list[Detection] = []
        for block in blocks:
            state.append(*fe.push(block if blanker is None else blanker.push(block)))
            found, scan_from = det.find(state.bb, state.bb_start, scan_from, final=False)
            pending.extend(found)
            yield from self._measure_ready(pending, state, final=False)
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
        yield from self._measure_ready(pending, state, final=True)
        yield from self._lookahead.flush()

    def _measure_ready(self, pending: list[Detection], state: BasebandBuffers, *, final: bool
                       ) -> Iterator[MeasurementRecord]:
        """Records of the pending detections whose whole span has arrived (all of them when ``final``).

        The detections measured are removed from ``pending``; the others wait for more samples.
        """
        plan, span_s = self.plan, self.measurer.span_s
        t_end = min(state.bb_end / plan.fs_data, state.tone_end / plan.fs_tone)
        ready = [d for d in pending if final or d.t_start_s + span_s <= t_end]
        pending[:] = [d for d in pending if not (final or d.t_start_s + span_s <= t_end)]
        for d in ready:
            yield from self._lookahead.push(self.measurer.measure(d, state))
