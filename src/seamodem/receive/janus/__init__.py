"""JANUS (STANAG 4748) receiver: preamble detection over time scales, non-coherent FH-BFSK soft demodulation,
de-interleaving, Viterbi decoding, CRC, cargo, and range / v_r from every packet."""

from .demod import BlockDecision, chip_energies, chip_llrs, decode_block
from .detect import (
    DETECTION_THRESHOLD,
    JanusCandidate,
    find_preambles,
    preamble_statistic,
    refine_candidate,
    tone_shares,
)
from .frontend import baseband_rate, to_baseband
from .measure import ChipCorrelations, ScaleDelayFit, chip_correlations, fit_delay_scale
from .receiver import MIN_CARGO_MARGIN, MIN_MARGIN, JanusSettings, receive_janus, receive_segment
from .records import JANUS_FIELDS, JanusRecord
from .stream import JanusReceiver

__all__ = [
    "BlockDecision", "chip_energies", "chip_llrs", "decode_block", "DETECTION_THRESHOLD", "JanusCandidate",
    "find_preambles", "preamble_statistic", "refine_candidate", "tone_shares", "baseband_rate", "to_baseband", "ChipCorrelations",
    "ScaleDelayFit", "chip_correlations", "fit_delay_scale", "MIN_MARGIN", "MIN_CARGO_MARGIN", "JanusSettings",
    "receive_janus", "receive_segment", "JanusReceiver", "JANUS_FIELDS", "JanusRecord",
]
