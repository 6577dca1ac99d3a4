"""Beacon schedule: N frames every T_com seconds, rendered into one recording.

Emission times are on the recording's clock (t = 0 at its first sample). A
frame's first sample lies at its emission time; when that time falls between
two samples the frame is synthesised at the exact fractional offset.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np

from .._version import __version__
from .._progress import progress_bar
from ..config import DEFAULT_PAYLOAD_TEXT, FrameConfig
from ..errors import ConfigError, InputFileError, PayloadError
from ..io.files import atomic_outputs, check_writable
from ..io.sidecar import SIDECAR_FORMAT, sidecar_path, sidecar_payloads, sidecar_pilot_bits, write_json
from ..io.wav import write_wav_blocks
from .frame import Frame, build_frame, frame_sample_count, frame_waveform
from .pilot import pilot_bits as _pilot_bits

__all__ = [
    "BeaconSchedule",
    "BeaconSignal",
    "payloads_from_text",
    "payloads_from_bytes",
    "render_beacon",
    "write_beacon",
    "rebuild_from_sidecar",
]


@dataclass(frozen=True, kw_only=True)
class BeaconSchedule:
    """When the beacon emits: frame k at ``start_s + k·period_s`` [s].

    Parameters
    ----------
    count : int
        Number of frames, ≥ 1.
    period_s : float
        T_com [s], at least the frame duration (frames do not overlap).
    start_s : float
        Emission time of frame 0 on the recording's clock [s], ≥ 0.
    """

    count: int
    period_s: float
    start_s: float = 0.0

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise ConfigError("count", f"must be an integer >= 1, got {self.count!r}")
        for name in ("period_s", "start_s"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(name, f"must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.period_s <= 0:
            raise ConfigError("period_s", f"must be > 0, got {self.period_s!r}")
        if self.start_s < 0:
            raise ConfigError("start_s", f"must be >= 0, got {self.start_s!r}")

    def emission_times(self) -> np.ndarray:
        """Emission time of each frame [s], shape (count,)."""
        return self.start_s + self.period_s * np.arange(self.count)

    def check(self, config: FrameConfig) -> None:
        """Raise if frames of ``config`` would overlap under this schedule."""
        if self.count > 1 and self.period_s < config.frame_duration_s:
            raise ConfigError(
                "period_s",
                f"must be at least the frame duration {config.frame_duration_s:g} s, got {self.period_s:g}",
            )

    def duration_s(self, config: FrameConfig) -> float:
        """Recording length: the last period, or the end of the last frame if later [s]."""
        last = self.start_s + (self.count - 1) * self.period_s
        return max(self.start_s + self.count * self.period_s, last + config.frame_duration_s)


def payloads_from_text(text: str, count: int) -> list[bytes]:
    """One UTF-8 payload per frame; ``{index}`` in ``text`` becomes the frame index.

    Parameters
    ----------
    text : str
        The message, optionally with ``{index}``.
    count : int
        Number of frames.

    Returns
    -------
    list of bytes
        ``count`` payloads (their length is checked when frames are built).
    """
    return [text.replace("{index}", str(k)).encode("utf-8") for k in range(count)]


def payloads_from_bytes(data: bytes, capacity: int, count: int | None = None) -> list[bytes]:
    """Split ``data`` into consecutive frame payloads of at most ``capacity`` bytes.

    With ``count`` given, frames after the end of the data carry empty payloads;
    data that does not fit into ``count`` frames is an error.

    Parameters
    ----------
    data : bytes
        The data to send (e.g. a file's contents).
    capacity : int
        Payload capacity of one frame [bytes] (``config.capacity_bytes``).
    count : int or None, optional
        Number of frames; None uses as many as the data needs (at least 1).

    Returns
    -------
    list of bytes
        ``count`` payloads.

    Raises
    ------
    PayloadError
        The data needs more than ``count`` frames.
    """
    needed = max(1, math.ceil(len(data) / capacity))
    if count is None:
        count = needed
    if needed > count:
        raise PayloadError(
            f"payload: {len(data)} bytes need {needed} frames of {capacity} bytes, but count is {count}"
        )
    return [data[k * capacity : (k + 1) * capacity] for k in range(count)]


@dataclass(frozen=True, eq=False)
class BeaconSignal:
    """A rendered beacon recording: frames, where they start, and how long it is.

    Built by :func:`render_beacon`.

    Attributes
    ----------
    config : FrameConfig
        The frame configuration.
    schedule : BeaconSchedule
        Emission times of the frames.
    frames : tuple of Frame
        The encoded frames, in emission order.
    first_samples : numpy.ndarray, shape (n_frames,)
        Recording index of each frame's first sample.
    offsets_s : numpy.ndarray, shape (n_frames,)
        Time from each frame's emission to that sample [s], in [0, 1/fs).
    n_samples : int
        Length of the recording [samples].
    """

    config: FrameConfig
    schedule: BeaconSchedule
    frames: tuple[Frame, ...]
    first_samples: np.ndarray  # recording index of each frame's first sample
    offsets_s: np.ndarray  # time from emission to that sample, in [0, 1/fs)
    n_samples: int

    def frame_samples(self, k: int) -> np.ndarray:
        """Waveform of frame ``k`` on the recording's sample grid, model units."""
        return frame_waveform(self.frames[k], offset_s=float(self.offsets_s[k]))

    def peak(self) -> float:
        """Largest |s| over the recording, model units (frames do not overlap)."""
        return max(float(np.max(np.abs(self.frame_samples(k)))) for k in range(len(self.frames)))

    def blocks(self, *, scale: float = 1.0, block_size: int = 1 << 20, progress: bool | None = None) -> Iterator[np.ndarray]:
        """The recording, ``scale``·s(t), as consecutive float64 blocks (bounded memory).

        Parameters
        ----------
        scale : float, optional
            Gain from model units to full scale.
        block_size : int, optional
            Samples per block (the last may be shorter).
        progress : bool or None, optional
            Progress bar; None shows it on a terminal only.

        Yields
        ------
        numpy.ndarray, shape (block_size,)
            Consecutive samples; together ``n_samples`` long.
        """
        starts = self.first_samples
        lengths = np.array([frame_sample_count(self.config, o) for o in self.offsets_s])
        k = 0
        cache: dict[int, np.ndarray] = {}
        with progress_bar(total=self.n_samples, unit="sample", unit_scale=True, desc="tx", enabled=progress) as bar:
            for b0 in range(0, self.n_samples, block_size):
                b1 = min(b0 + block_size, self.n_samples)
                block = np.zeros(b1 - b0)
                while k < len(starts) and starts[k] + lengths[k] <= b0:
                    cache.pop(k, None)
                    k += 1
                j = k
                while j < len(starts) and starts[j] < b1:
                    if j not in cache:
                        cache[j] = scale * self.frame_samples(j)
                    s = cache[j]
                    lo, hi = max(b0, starts[j]), min(b1, starts[j] + len(s))
                    block[lo - b0 : hi - b0] += s[lo - starts[j] : hi - starts[j]]
                    j += 1
                bar.update(b1 - b0)
                yield block


def render_beacon(
    config: FrameConfig,
    schedule: BeaconSchedule,
    payloads: Sequence[bytes] | None = None,
    *,
    pilot_bits: np.ndarray | None = None,
) -> BeaconSignal:
    """Encode every frame of a schedule and place it on the recording's sample grid.

    Parameters
    ----------
    config : FrameConfig
    schedule : BeaconSchedule
    payloads : sequence of bytes, optional
        One per frame; default "seamodem frame {index}".
    pilot_bits : numpy.ndarray, optional
        Explicit pilot; default from ``config.pilot_seed``.

    Raises
    ------
    ConfigError, PayloadError
        Overlapping frames, a payload count that differs from ``schedule.count``,
        a payload above capacity.
    """
    schedule.check(config)
    if payloads is None:
        payloads = payloads_from_text(DEFAULT_PAYLOAD_TEXT, schedule.count)
    if len(payloads) != schedule.count:
        raise PayloadError(f"payload: {len(payloads)} payloads given for {schedule.count} frames")
    if pilot_bits is None:
        pilot_bits = _pilot_bits(config.n_pilot, config.pilot_seed)
    frames = tuple(build_frame(config, p, pilot_bits=pilot_bits) for p in payloads)
    fs = config.sample_rate_hz
    emit = schedule.emission_times()
    # first sample at or after each emission time; tolerate float noise of 1e-9 sample
    first = np.ceil(emit * fs - 1e-9).astype(np.int64)
    offsets = np.clip((first - emit * fs) / fs, 0.0, np.nextafter(1.0 / fs, 0.0))
    n_samples = int(np.ceil(schedule.duration_s(config) * fs - 1e-9))
    return BeaconSignal(config, schedule, frames, first, offsets, n_samples)


def _wav_rate(config: FrameConfig) -> int:
    if not float(config.sample_rate_hz).is_integer():
        raise ConfigError(
            "sample_rate_hz",
            f"must be a whole number of Hz to be written to WAV, got {config.sample_rate_hz!r}",
        )
    return int(config.sample_rate_hz)


def _sidecar(signal: BeaconSignal, wav_name: str, subtype: str, scale: float, peak: float, command: str) -> dict:
    cfg = signal.config
    emit = signal.schedule.emission_times()
    return {
        "format": SIDECAR_FORMAT,
        "created_by": f"seamodem {__version__}",
        "command": command,
        "config": cfg.to_dict(),
        "pilot": {
            "seed": cfg.pilot_seed,
            "bits": "".join(str(int(b)) for b in signal.frames[0].pilot_bits),
        },
        "schedule": asdict(signal.schedule),
        "recording": {
            "file": wav_name,
            "sample_rate_hz": _wav_rate(cfg),
            "n_samples": signal.n_samples,
            "duration_s": signal.n_samples / cfg.sample_rate_hz,
            "subtype": subtype,
            "scale": scale,
            "peak": peak,
        },
        "frames": [
            {
                "frame_index": k,
                "t_emit_s": float(emit[k]),
                "payload_hex": fr.payload.hex(),
                "payload_bytes": len(fr.payload),
            }
            for k, fr in enumerate(signal.frames)
        ],
    }


def write_beacon(
    path: str | Path,
    config: FrameConfig,
    schedule: BeaconSchedule,
    payloads: Sequence[bytes] | None = None,
    *,
    subtype: str = "FLOAT",
    peak: float = 0.5,
    command: str = "",
    progress: bool | None = None,
) -> dict[str, Any]:
    """Write the beacon recording to ``path`` (WAV) and its sidecar beside it.

    Parameters
    ----------
    path : str or Path
        Output WAV; the sidecar is the same name with ``.json``.
    subtype : {"FLOAT", "PCM_16", "PCM_24"}
        Sample format.
    peak : float
        Largest |sample| in the file, in (0, 1] of full scale; recorded with the
        scale factor in the sidecar.
    command : str
        Command line recorded in the sidecar.

    Returns
    -------
    dict
        The sidecar.

    Notes
    -----
    Both files appear together or not at all (atomic rename).
    """
    path = check_writable(path)
    if not (isinstance(peak, (int, float)) and 0 < peak <= 1):
        raise ConfigError("peak", f"must be in (0, 1] of full scale, got {peak!r}")
    fs = _wav_rate(config)
    signal = render_beacon(config, schedule, payloads)
    scale = float(peak / signal.peak())
    sidecar = _sidecar(signal, path.name, subtype, scale, float(peak), command)
    with atomic_outputs(path, sidecar_path(path)) as (tmp_wav, tmp_json):
        write_wav_blocks(tmp_wav, signal.blocks(scale=scale, progress=progress), fs=fs, subtype=subtype)
        write_json(tmp_json, sidecar)
    return sidecar


def rebuild_from_sidecar(sidecar: dict[str, Any]) -> np.ndarray:
    """Rebuild the recording's samples (float64, before the WAV's sample format) from a sidecar alone.

    Parameters
    ----------
    sidecar : dict
        A ``seamodem tx`` sidecar (see :func:`seamodem.io.read_sidecar`) that
        records the payloads and pilot bits.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        The recording, scaled by the sidecar's ``recording.scale``.

    Raises
    ------
    InputFileError
        The sidecar lacks the payloads or the pilot bits.
    """
    config = FrameConfig.from_dict(sidecar["config"])
    schedule = BeaconSchedule(**sidecar["schedule"])
    payloads, bits = sidecar_payloads(sidecar), sidecar_pilot_bits(sidecar)
    if payloads is None or bits is None:
        raise InputFileError("sidecar: lacks the payloads or pilot bits needed to rebuild the recording")
    signal = render_beacon(config, schedule, payloads, pilot_bits=bits)
    return np.concatenate(list(signal.blocks(scale=float(sidecar["recording"]["scale"]), progress=False)))
