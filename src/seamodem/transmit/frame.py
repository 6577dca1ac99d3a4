"""The frame of paper 000 eq 8: pilots and data, SRRC-shaped, plus a pure tone.

s(τ) = A_d Re[Σ_k x[k] √T g(τ − (Ng + k)T) e^{j2π f0 τ}] + A_t w(τ) cos(2π f_pt τ),

with τ the time since the frame start (the first sample of the leading guard),
0 ≤ τ < T_F, x = pilots then data, g the truncated unit-energy SRRC, w a
raised-cosine ramp of ``tone_ramp_s`` at both ends, and amplitudes such that
the data power is 1 − tone_power_share and the tone power tone_power_share
(mean over the frame; total 1 in model units).

The pulse is evaluated analytically at every sample time, so the waveform is
exact (up to the stated SRRC truncation) for any fs·T, and for a frame that
starts between two samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..config import FrameConfig
from .coding import encode_payload
from .modulation import bits_to_symbols
from .pilot import pilot_bits as _pilot_bits
from .pulse import srrc_matrix

__all__ = [
    "Frame",
    "build_frame",
    "frame_symbol_times",
    "frame_sample_count",
    "frame_baseband",
    "frame_waveform",
    "tone_envelope",
]


@dataclass(frozen=True, eq=False)
class Frame:
    """One frame's symbols and the payload they carry.

    Attributes
    ----------
    config : FrameConfig
    payload : bytes
    pilot_bits : numpy.ndarray, shape (n_pilot,)
        0 → +1, 1 → −1.
    data_symbols : numpy.ndarray, shape (n_data,), complex
    """

    config: FrameConfig
    payload: bytes
    pilot_bits: np.ndarray = field(repr=False)
    data_symbols: np.ndarray = field(repr=False)

    @property
    def pilot_symbols(self) -> np.ndarray:
        return (1.0 - 2.0 * self.pilot_bits).astype(complex)

    @property
    def symbols(self) -> np.ndarray:
        """Pilots then data, shape (n_pilot + n_data,)."""
        return np.concatenate([self.pilot_symbols, self.data_symbols])


def build_frame(config: FrameConfig, payload: bytes = b"", *, pilot_bits: np.ndarray | None = None) -> Frame:
    """Encode ``payload`` into a frame's symbols.

    Parameters
    ----------
    config : FrameConfig
    payload : bytes
        At most ``config.capacity_bytes``.
    pilot_bits : numpy.ndarray, optional
        Explicit pilot (e.g. read from a sidecar); default: the sequence that
        ``config.pilot_seed`` defines.

    Raises
    ------
    PayloadError
        If the payload does not fit.
    """
    if pilot_bits is None:
        pilot_bits = _pilot_bits(config.n_pilot, config.pilot_seed)
    pilot_bits = np.asarray(pilot_bits, dtype=np.uint8)
    if pilot_bits.shape != (config.n_pilot,):
        raise ValueError(f"pilot_bits must have n_pilot = {config.n_pilot} entries, got {pilot_bits.shape}")
    data = bits_to_symbols(encode_payload(payload, config), config.modulation)
    return Frame(config=config, payload=bytes(payload), pilot_bits=pilot_bits, data_symbols=data)


def frame_symbol_times(config: FrameConfig) -> np.ndarray:
    """Pulse centre of each pilot and data symbol after the frame start, (Ng + k)·T [s].

    Parameters
    ----------
    config : FrameConfig
        The frame configuration.

    Returns
    -------
    numpy.ndarray, shape (n_pilot + n_data,)
        Times [s], pilot symbols first.
    """
    return (config.n_guard + np.arange(config.n_pilot + config.n_data)) * config.symbol_period_s


def frame_sample_count(config: FrameConfig, offset_s: float = 0.0) -> int:
    """Samples m ≥ 0 with τ_m = offset + m/fs inside [0, T_F).

    Parameters
    ----------
    config : FrameConfig
        The frame configuration.
    offset_s : float, optional
        Time from the frame start to its first sample [s], in [0, 1/fs);
        default 0.

    Returns
    -------
    int
        Number of samples of the frame's waveform.
    """
    return int(np.ceil((config.frame_duration_s - offset_s) * config.sample_rate_hz - 1e-9))


@lru_cache(maxsize=8)
def _synthesis(config: FrameConfig, offset_s: float):
    n = frame_sample_count(config, offset_s)
    tau = offset_s + np.arange(n) / config.sample_rate_hz
    g = srrc_matrix(
        tau,
        frame_symbol_times(config),
        symbol_period_s=config.symbol_period_s,
        rolloff=config.rolloff,
        span_symbols=config.srrc_span_symbols,
    )
    carrier = np.exp(2j * np.pi * config.carrier_hz * tau)
    tone = tone_envelope(config, tau) * np.cos(2 * np.pi * config.tone_hz * tau)
    for a in (tau, carrier, tone):
        a.setflags(write=False)
    return tau, g, carrier, tone


def tone_envelope(config: FrameConfig, tau: np.ndarray) -> np.ndarray:
    """Tone amplitude envelope w(τ): 1 inside the frame, raised-cosine ramps at its ends."""
    tau = np.asarray(tau, dtype=float)
    w = ((tau >= 0) & (tau < config.frame_duration_s)).astype(float)
    ramp = config.tone_ramp_s
    if ramp > 0:
        edge = np.minimum(tau, config.frame_duration_s - tau)
        inside = (edge < ramp) & (w > 0)
        w[inside] = 0.5 * (1 - np.cos(np.pi * edge[inside] / ramp))
    return w


def _check_offset(config: FrameConfig, offset_s: float) -> float:
    offset_s = float(offset_s)
    if not 0.0 <= offset_s < 1.0 / config.sample_rate_hz:
        raise ValueError(f"offset_s must be in [0, 1/fs), got {offset_s!r}")
    return offset_s


def frame_baseband(frame: Frame, *, offset_s: float = 0.0) -> np.ndarray:
    """Complex baseband Σ x[k] √T g(τ − t_k) at τ_m = offset + m/fs (unit mean power).

    Parameters
    ----------
    frame : Frame
    offset_s : float
        Time from the frame start to the first sample, in [0, 1/fs) [s].

    Returns
    -------
    numpy.ndarray, shape (frame_sample_count(config, offset_s),), complex
    """
    cfg = frame.config
    _, g, _, _ = _synthesis(cfg, _check_offset(cfg, offset_s))
    return g @ frame.symbols


def frame_waveform(frame: Frame, *, offset_s: float = 0.0) -> np.ndarray:
    """Real passband frame s(τ) (eq 8) at τ_m = offset + m/fs, model units (mean power 1).

    Parameters
    ----------
    frame : Frame
    offset_s : float
        Time from the frame start to the first sample, in [0, 1/fs) [s].

    Returns
    -------
    numpy.ndarray, shape (frame_sample_count(config, offset_s),), float64
    """
    cfg = frame.config
    _, g, carrier, tone = _synthesis(cfg, _check_offset(cfg, offset_s))
    a_data = np.sqrt(2.0 * (1.0 - cfg.tone_power_share))
    a_tone = np.sqrt(2.0 * cfg.tone_power_share)
    return a_data * np.real((g @ frame.symbols) * carrier) + a_tone * tone
