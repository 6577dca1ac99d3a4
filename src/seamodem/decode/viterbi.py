"""Soft-decision Viterbi decoder for the K = 7, rate 1/2 (133, 171) code of the transmitter."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..transmit.coding import CONSTRAINT_LENGTH, CONV_GENERATORS

__all__ = ["viterbi_decode", "trellis", "OUTPUTS", "NEXT_STATE"]

N_STATES = 1 << (CONSTRAINT_LENGTH - 1)


def trellis() -> tuple[np.ndarray, np.ndarray]:
    """Coded outputs per (state, input) as ±1, and the next state.

    State s holds the previous 6 inputs, u[n−1] in bit 5; the register
    (u[n] << 6) | s has u[n − i] in bit 6 − i, which the generator's bit 6 − i taps.

    Returns
    -------
    outputs : numpy.ndarray, shape (64, 2, 2)
        outputs[s, b, j] = 1 − 2·c_j.
    next_state : numpy.ndarray, shape (64, 2)
    """
    outputs = np.empty((N_STATES, 2, 2))
    next_state = np.empty((N_STATES, 2), dtype=np.int64)
    for s in range(N_STATES):
        for b in range(2):
            reg = (b << 6) | s
            for j, g in enumerate(CONV_GENERATORS):
                outputs[s, b, j] = 1 - 2 * (bin(reg & g).count("1") & 1)
            next_state[s, b] = (b << 5) | (s >> 1)
    return outputs, next_state


#: the code's trellis (:func:`trellis`), shared by this decoder and the BCJR's (:mod:`.bcjr`): coded
#: outputs per (state, input) as ±1, shape (64, 2, 2), and the next state per (state, input), shape (64, 2)
OUTPUTS, NEXT_STATE = trellis()


@njit(cache=True, nogil=True)
def _viterbi(llr, outputs, n_steps):
    n_states = outputs.shape[0]
    metric = np.full(n_states, -1e300)
    metric[0] = 0.0
    decisions = np.empty((n_steps, n_states), dtype=np.uint8)
    new = np.empty(n_states)
    for t in range(n_steps):
        l0 = llr[2 * t]
        l1 = llr[2 * t + 1]
        for ns in range(n_states):
            b = ns >> 5
            p0 = (ns & 31) << 1
            p1 = p0 | 1
            m0 = metric[p0] + 0.5 * (outputs[p0, b, 0] * l0 + outputs[p0, b, 1] * l1)
            m1 = metric[p1] + 0.5 * (outputs[p1, b, 0] * l0 + outputs[p1, b, 1] * l1)
            if m1 > m0:
                new[ns] = m1
                decisions[t, ns] = 1
            else:
                new[ns] = m0
                decisions[t, ns] = 0
        metric[:] = new
    bits = np.empty(n_steps, dtype=np.uint8)
    s = 0  # the tail terminates the trellis in state 0
    for t in range(n_steps - 1, -1, -1):
        bits[t] = s >> 5
        s = ((s & 31) << 1) | decisions[t, s]
    return bits


def viterbi_decode(llr: np.ndarray, n_info: int) -> np.ndarray:
    """Maximum-likelihood decoding of a zero-terminated block.

    Parameters
    ----------
    llr : numpy.ndarray, shape (≥ 2·(n_info + 6),)
        Code-order LLRs, L = log P(c = 0)/P(c = 1), c0 c1 per step (extra entries,
        e.g. the frame's fill bits, are ignored).
    n_info : int
        Information bits before the 6 tail bits.

    Returns
    -------
    numpy.ndarray, shape (n_info,), uint8
    """
    n_steps = n_info + CONSTRAINT_LENGTH - 1
    llr = np.ascontiguousarray(llr[: 2 * n_steps], dtype=np.float64)
    if llr.size < 2 * n_steps:
        raise ValueError(f"need {2 * n_steps} LLRs for {n_info} information bits, got {llr.size}")
    return _viterbi(llr, OUTPUTS, n_steps)[:n_info]
