"""A whole JANUS transmission: padding, optional wake-up tones, preamble, base packet, cargo.

``janus_waveform`` reproduces the reference transmitter sample for sample (S16 output through
:func:`~seamodem.transmit.janus.modulate.to_s16`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coding import PREAMBLE_BITS, conv_encode_janus, hop_slots, interleaver_permutation_janus
from .modulate import WUT_GAP_S, synthesize_chips, upconvert, wake_up_tones
from .packet import JanusPacket, bytes_to_bits
from .pset import JanusParameterSet

__all__ = ["JanusWaveform", "packet_chip_bits", "packet_tones", "janus_waveform", "N_PREAMBLE_CHIPS", "PAD_CHIPS"]

N_PREAMBLE_CHIPS = 32
#: zero padding before and after a packet, in chips (the reference's default)
PAD_CHIPS = 5


def packet_chip_bits(packet: JanusPacket) -> np.ndarray:
    """Chip bits after the preamble: the coded, interleaved base packet, then the cargo block if any."""
    blocks = [packet.to_bytes()] + ([packet.cargo] if packet.cargo else [])
    out = []
    for block in blocks:
        coded = conv_encode_janus(bytes_to_bits(block))
        out.append(coded[interleaver_permutation_janus(coded.size)])
    return np.concatenate(out)


def packet_tones(packet: JanusPacket, pset: JanusParameterSet) -> np.ndarray:
    """Tone index 2·slot + bit of every chip, preamble first, shape (n_chips,)."""
    bits = np.concatenate([PREAMBLE_BITS, packet_chip_bits(packet)])
    return 2 * hop_slots(bits.size, pset) + bits


@dataclass(frozen=True)
class JanusWaveform:
    """A synthesized JANUS transmission.

    Attributes
    ----------
    x_pb : numpy.ndarray, shape (n_samples,)
        Passband samples, float64, peak ≤ amplitude.
    fs : float
        Sample rate [Hz].
    preamble_start : int
        Sample of the first preamble chip.
    n_chips : int
        Chips from the preamble's first to the cargo's last.
    packet : JanusPacket
        What was sent.
    pset : JanusParameterSet
        With which parameters.
    """

    x_pb: np.ndarray
    fs: float
    preamble_start: int
    n_chips: int
    packet: JanusPacket
    pset: JanusParameterSet


def janus_waveform(
    packet: JanusPacket,
    pset: JanusParameterSet,
    fs: float,
    *,
    wake_up: bool = False,
    pad: bool = True,
    amplitude: float = 0.95,
) -> JanusWaveform:
    """Passband samples of one JANUS packet, as the reference transmitter makes them.

    Parameters
    ----------
    packet : JanusPacket
        Base packet and cargo.
    pset : JanusParameterSet
        Parameter set.
    fs : float
        Sample rate [Hz]; must hold the band.
    wake_up : bool
        Send the three wake-up tones and 0.4 s of silence first.
    pad : bool
        5 chips of silence before and after.
    amplitude : float
        Peak amplitude A of the carrier, in (0, 1].

    Returns
    -------
    JanusWaveform
    """
    pset.check_rate(fs)
    if not 0 < amplitude <= 1:
        raise ValueError(f"amplitude must be in (0, 1], got {amplitude!r}")
    lt = int(round(pset.chip_s * fs))
    silence = np.zeros(PAD_CHIPS * lt if pad else 0, dtype=complex)
    parts = [silence]
    if wake_up:
        parts += [wake_up_tones(pset, fs), np.zeros(int(round(WUT_GAP_S * fs)), dtype=complex)]
    start = sum(p.size for p in parts)
    tones = packet_tones(packet, pset)
    parts += [synthesize_chips(tones, pset, fs), silence]
    x_pb = upconvert(np.concatenate(parts), pset.fc_hz, fs, amplitude=amplitude)
    return JanusWaveform(x_pb=x_pb, fs=float(fs), preamble_start=start, n_chips=tones.size, packet=packet, pset=pset)
