"""Payload decoding: soft demapping, deinterleaving, Viterbi, CRC (equalisation to come)."""

from .demap import soft_demap
from .payload import DecodedPayload, code_order_llr, decode_payload
from .viterbi import viterbi_decode

__all__ = ["soft_demap", "DecodedPayload", "code_order_llr", "decode_payload", "viterbi_decode"]
