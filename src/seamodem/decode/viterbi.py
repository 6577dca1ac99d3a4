"""Soft-decision Viterbi decoder for the K = 7, rate 1/2 (133, 171) code of the transmitter (and any rate-1/2 code's trellis)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..transmit.coding import CONSTRAINT_LENGTH, CONV_GENERATORS

__all__ = ["viterbi_decode", "trellis", "OUTPUTS", "NEXT_STATE"]

N_STATES = 1 << (CONSTRAINT_LENGTH - 1)


def trellis(
    generators: tuple[int, ...] = CONV_GENERATORS, constraint_length: int = CONSTRAINT_LENGTH
) -> tuple[np.ndarray, np.ndarray]:
    """Coded outputs per (state, input) as ±1, and the next state.

    State s holds the previous K − 1 inputs, u[n−1] in bit K − 2; the register
    (u[n] << (K − 1)) | s has u[n − i] in bit K − 1 − i, which the generator's bit K − 1 − i taps.

    Parameters
    ----------
    generators : tuple of int
        The two generator polynomials (default: the transmitter's 133, 171).
    constraint_length : int
        K (default 7).

    Returns
    -------
    outputs : numpy.ndarray, shape (2**(K−1), 2, 2)
        outputs[s, b, j] = 1 − 2·c_j.
    next_state : numpy.ndarray, shape (2**(K−1), 2)
    """
    m = constraint_length - 1
    n_states = 1 << m
    outputs = np.empty((n_states, 2, 2))
    next_state = np.empty((n_states, 2), dtype=np.int64)
    for s in range(n_states):
        for b in range(2):
            reg = (b << m) | s
            for j, g in enumerate(generators):
                outputs[s, b, j] = 1 - 2 * (bin(reg & g).count("1") & 1)
            next_state[s, b] = (b << (m - 1)) | (s >> 1)
    return outputs, next_state


#: the code's trellis (:func:`trellis`), shared by this decoder and the BCJR's (:mod:`.bcjr`): coded
#: outputs per (state, input) as ±1, shape (64, 2, 2), and the next state per (state, input), shape (64, 2)
OUTPUTS, NEXT_STATE = trellis()


@njit(cache=True, nogil=True)
def _viterbi(llr, outputs, n_steps):
    n_states = outputs.shape[0]
    half = n_states >> 1
    top = 0
    while (1 << (top + 1)) < n_states:
        top += 1
    metric = np.full(n_states, -1e300)
    metric[0] = 0.0
    decisions = np.empty((n_steps, n_states), dtype=np.uint8)
    new = np.empty(n_states)
    for t in range(n_steps):
        l0 = llr[2 * t]
        l1 = llr[2 * t + 1]
        for ns in range(n_states):
            b = ns >> top
            p0 = (ns & (half - 1)) << 1
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
        bits[t] = s >> top
        s = ((s & (half - 1)) << 1) | decisions[t, s]
    return bits


def viterbi_decode(llr: np.ndarray, n_info: int, *, outputs: np.ndarray = OUTPUTS) -> np.ndarray:
    """Maximum-likelihood decoding of a zero-terminated block.

    Parameters
    ----------
    llr : numpy.ndarray, shape (≥ 2·(n_info + 6),)
        Code-order LLRs, L = log P(c = 0)/P(c = 1), c0 c1 per step (extra entries,
        e.g. the frame's fill bits, are ignored).
    n_info : int
        Information bits before the K − 1 tail bits.
    outputs : numpy.ndarray, shape (2**(K−1), 2, 2)
        The code's trellis outputs (:func:`trellis`); default the transmitter's K = 7 code.

    Returns
    -------
    numpy.ndarray, shape (n_info,), uint8
    """
    n_steps = n_info + int(np.log2(outputs.shape[0]))
    llr = np.ascontiguousarray(llr[: 2 * n_steps], dtype=np.float64)
    if llr.size < 2 * n_steps:
        raise ValueError(f"need {2 * n_steps} LLRs for {n_info} information bits, got {llr.size}")
    return _viterbi(llr, outputs, n_steps)[:n_info]
