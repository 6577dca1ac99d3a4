"""Payload decoding: adaptive equalisation, soft demapping, deinterleaving, Viterbi, CRC."""

from .demap import soft_demap
from .equalizer import DfeResult, DfeSettings, dfe_equalize, mmse_dfe_taps
from .frame import decode_frame, fractional_samples
from .bcjr import bcjr_decode
from .payload import DecodedPayload, code_order_llr, decode_payload
from .turbo import TurboResult, estimate_channel, turbo_equalize
from .viterbi import viterbi_decode

__all__ = [
    "bcjr_decode",
    "TurboResult",
    "estimate_channel",
    "turbo_equalize",
    "decode_frame",
    "fractional_samples",
    "DfeResult",
    "DfeSettings",
    "dfe_equalize",
    "mmse_dfe_taps",
    "soft_demap", "DecodedPayload", "code_order_llr", "decode_payload", "viterbi_decode"]
