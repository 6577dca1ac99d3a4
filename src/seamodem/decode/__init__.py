"""Payload decoding blocks: adaptive equalisation, soft demapping, deinterleaving, Viterbi, BCJR, turbo, CRC.

Pure functions of symbols and settings; they import nothing from
:mod:`seamodem.receive` (which drives them on a measured frame in
:mod:`seamodem.receive.demodulate`).
"""

from .bcjr import bcjr_decode
from .demap import soft_demap
from .equalizer import DfeResult, DfeSettings, dfe_equalize, mmse_dfe_taps
from .payload import DecodedPayload, code_order_llr, decode_payload
from .turbo import TurboResult, estimate_channel, turbo_equalize
from .viterbi import viterbi_decode

__all__ = [
    "bcjr_decode",
    "soft_demap",
    "DfeResult",
    "DfeSettings",
    "dfe_equalize",
    "mmse_dfe_taps",
    "DecodedPayload",
    "code_order_llr",
    "decode_payload",
    "TurboResult",
    "estimate_channel",
    "turbo_equalize",
    "viterbi_decode",
]
