"""From equalised data symbols to payload bytes: demap, descramble, deinterleave, Viterbi, CRC."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from ..transmit.coding import code_order_llr, parse_info_block
from .demap import soft_demap
from .viterbi import viterbi_decode

__all__ = ["DecodedPayload", "code_order_llr", "decode_payload"]


@dataclass(frozen=True)
class DecodedPayload:
    """Outcome of decoding one frame's data.

    Attributes
    ----------
    payload : bytes
        Decoded payload (meaningful only when ``crc_ok``).
    crc_ok : bool
        The frame check passed; bytes are never reported valid otherwise.
    info_bits : numpy.ndarray
        Decoded information block (for bit-error counting).
    """

    payload: bytes
    crc_ok: bool
    info_bits: np.ndarray


def decode_payload(data_symbols: np.ndarray, noise_var: float | np.ndarray, config: FrameConfig) -> DecodedPayload:
    """Decode a frame's ``n_data`` equalised data symbols.

    Parameters
    ----------
    data_symbols : numpy.ndarray, shape (n_data,), complex
    noise_var : float or numpy.ndarray
        Complex noise variance per symbol (after equalisation), for the LLRs.
    config : FrameConfig

    Returns
    -------
    DecodedPayload
    """
    data_symbols = np.asarray(data_symbols)
    if data_symbols.shape != (config.n_data,):
        raise ValueError(f"expected {config.n_data} data symbols, got shape {data_symbols.shape}")
    llr = code_order_llr(soft_demap(data_symbols, noise_var, config.modulation), config)
    if config.fec == "none":
        info = (llr[: config.n_info_bits] < 0).astype(np.uint8)
    else:
        info = viterbi_decode(llr, config.n_info_bits)
    payload, ok = parse_info_block(info, config)
    return DecodedPayload(payload, ok, info)
