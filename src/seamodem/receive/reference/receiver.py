"""The streaming reference receiver: front end, detectors and fits per channel (:class:`ReferenceReceiver`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ...errors import ConfigError
from ...transmit.reference import ReferenceWaveform, Replica, reference_crlb, reference_replica
from ..settings import ReceiverSettings, ReferenceSettings
from .band import BandDecimator, BandPlan, plan_band
from .detect import ReferenceDetector
from .fit import NOISE_GAP_S, NOISE_WINDOW_S, fit_reference
from .records import FittedPing

__all__ = ["ReferenceReceiver", "best_per_detection", "keep_matching_reference"]


class _Channel:
    """One channel's front end, baseband buffer and one detector per reference."""

    def __init__(self, plan: BandPlan, detectors: list[ReferenceDetector]):
        self.decimator = BandDecimator(plan)
        self.detectors = detectors
        self.buf = np.zeros(0, complex)
        self.buf_start = 0
        self.scan = [0] * len(detectors)


class ReferenceReceiver:
    """Streaming receiver of several references on one or all channels of a recording.

    Parameters
    ----------
    references : list of ReferenceWaveform
        The pings sought (distinct names).
    fs : float
        Input rate [Hz].
    settings : ReceiverSettings, optional
        Speed of sound, largest |v_r| and false-alarm rate (shared among references and channels),
        plus the reference receiver's own fields when a
        :class:`~seamodem.receive.settings.ReferenceSettings` (a plain
        :class:`~seamodem.receive.settings.ReceiverSettings` is taken as one, and validated as one);
        default ``ReferenceSettings()``.
    n_channels : int
        Channels fed to :meth:`run` (the best per detection is kept).
    replicas : list of Replica, optional
        Built from the references when not given (templates read their file).

    Attributes
    ----------
    settings : ReferenceSettings
        The settings as used.
    plan : BandPlan
        The front end's band, rates and filter.
    references : list of ReferenceWaveform
        The references, in the replicas' order.

    Raises
    ------
    ConfigError
        No reference, two with one name, a band beyond the recording's Nyquist, or invalid settings.

    Examples
    --------
    >>> from seamodem.receive.settings import ReceiverSettings
    >>> from seamodem.transmit.reference import parse_reference
    >>> rx = ReferenceReceiver([parse_reference("lfm:19000-29000:0.05")], 96000.0,
    ...                        settings=ReceiverSettings(sound_speed_mps=1480.0, v_max_mps=3.0))
    >>> rx.settings.eps_max == 3.0 / 1480.0, rx.plan.decimation
    (True, 6)
    """

    def __init__(
        self,
        references: list[ReferenceWaveform],
        fs: float,
        *,
        settings: ReceiverSettings | None = None,
        n_channels: int = 1,
        replicas: list[Replica] | None = None,
    ):
        if not references:
            raise ConfigError("reference", "give at least one reference waveform")
        names = [r.name for r in references]
        if len(set(names)) != len(names):
            raise ConfigError("reference", f"names must be distinct, got {names}")
        self.settings = ReferenceSettings() if settings is None else ReferenceSettings.from_settings(settings)
        sound_speed_mps, v_max_mps = self.settings.sound_speed_mps, self.settings.v_max_mps
        self.replicas = replicas or [reference_replica(r) for r in references]
        self.references = [rep.reference for rep in self.replicas]
        self.fs, self.c, self.v_max = float(fs), float(sound_speed_mps), float(v_max_mps)
        self.plan = plan_band(self.references, fs, v_max_mps=v_max_mps, sound_speed_mps=sound_speed_mps)
        rate = self.settings.false_alarms_per_hour / (len(self.references) * n_channels)
        self.bounds = [reference_crlb(rep) for rep in self.replicas]
        proto = [
            ReferenceDetector(rep, self.plan, v_max_mps=v_max_mps, sound_speed_mps=sound_speed_mps,
                              false_alarms_per_hour=rate, min_rho=self.settings.min_rho)
            for rep in self.replicas
        ]
        self.channels = [_Channel(self.plan, proto) for _ in range(n_channels)]
        # scan in chunks of several seconds: each scan also re-reads the noise context and a ping's length
        self.chunk = int(4 * max(d.length for d in proto) + 8 * self.plan.fs_bb)
        self.keep = int(max(d.length + d.window + d.context for d in proto) + 1.2 * (NOISE_GAP_S + NOISE_WINDOW_S) * self.plan.fs_bb)

    def _process(self, ch: _Channel, index: int, *, final: bool) -> list[FittedPing]:
        found = []
        fs = self.plan.fs_bb
        for i, det in enumerate(ch.detectors):
            if not final and ch.buf_start + len(ch.buf) - ch.scan[i] < self.chunk:
                continue
            dets, ch.scan[i] = det.find(ch.buf, ch.buf_start, ch.scan[i], final=final)
            for d in dets:
                fit = fit_reference(
                    ch.buf, fs, ch.buf_start / fs, replica=det.replica, carrier_hz=self.plan.centre_hz, detection=d,
                    search_eps=det.eps[1] - det.eps[0] if len(det.eps) > 1 else self.v_max / self.c,
                    noise_bandwidth_hz=self.plan.noise_bandwidth_hz, eps_max=self.v_max / self.c, bound=self.bounds[i],
                )
                found.append(FittedPing(self.references[i], d, fit, index))
        # the fine fit and the next scan need the tail: keep what the slowest detector still needs
        oldest = min(ch.scan) - self.keep
        cut = max(0, min(oldest - ch.buf_start, len(ch.buf)))
        ch.buf = ch.buf[cut:]
        ch.buf_start += cut
        return found

    def run(self, blocks: Iterable[np.ndarray]) -> Iterator[FittedPing]:
        """Fitted detections of every reference, channel by channel, as blocks (n, n_channels) arrive.

        Parameters
        ----------
        blocks : iterable of numpy.ndarray
            The recording in blocks of shape (n, n_channels) (or (n,) for one channel), at ``fs``.

        Yields
        ------
        FittedPing
            Each detection with its fine fit, as soon as it is complete; the last ones after the input ends.
        """
        for block in blocks:
            block = np.asarray(block, dtype=float).reshape(len(block), -1)
            for j, ch in enumerate(self.channels):
                y = ch.decimator.push(block[:, j])
                ch.buf = np.concatenate([ch.buf, y])
                yield from self._process(ch, j, final=False)
        for j, ch in enumerate(self.channels):
            ch.buf = np.concatenate([ch.buf, ch.decimator.flush()])
            yield from self._process(ch, j, final=True)


def best_per_detection(found: list[FittedPing], *, tolerance_s: float) -> list[FittedPing]:
    """Of detections of one reference within ``tolerance_s`` on different channels, the one with the highest E/N0.

    Parameters
    ----------
    found : list of FittedPing
        Detections of every channel.
    tolerance_s : float
        Detections of one reference closer than this are one ping [s].

    Returns
    -------
    list of FittedPing
        One detection per ping, in order of arrival.
    """
    out: list[FittedPing] = []
    for f in sorted(found, key=lambda f: (f.reference.name, f.fit.t_arrival_s)):
        last = out[-1] if out else None
        if last is not None and last.reference.name == f.reference.name and abs(f.fit.t_arrival_s - last.fit.t_arrival_s) < tolerance_s:
            if f.fit.e_n0 > last.fit.e_n0:
                out[-1] = f
            continue
        out.append(f)
    return sorted(out, key=lambda f: f.fit.t_arrival_s)


def keep_matching_reference(found: list[FittedPing]) -> list[FittedPing]:
    """Of overlapping detections of different references (similar pings), the one with the best normalised correlation.

    Two references that share a band (an LFM and an HFM of the same sweep)
    correlate partly with each other's pings; the reference that was sent
    matches with ρ ≈ S/(S + N), the other with less.

    Parameters
    ----------
    found : list of FittedPing
        Detections of every reference.

    Returns
    -------
    list of FittedPing
        Without the detections of a reference that overlap (within half a ping) a better-matching one,
        in order of arrival.
    """
    out: list[FittedPing] = []
    for f in sorted(found, key=lambda f: f.fit.t_arrival_s):
        last = out[-1] if out else None
        if last is not None and last.reference.name != f.reference.name:
            if f.fit.t_arrival_s - last.fit.t_arrival_s < 0.5 * max(f.reference.duration_s, last.reference.duration_s):
                if f.detection.rho > last.detection.rho:
                    out[-1] = f
                continue
        out.append(f)
    return out
