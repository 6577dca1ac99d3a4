"""Soft-in soft-out decoder (max-log BCJR) for the K = 7 (133, 171) code: the decoder half of turbo equalisation."""

from __future__ import annotations

import numpy as np
from numba import njit

from .viterbi import NEXT_STATE, OUTPUTS

__all__ = ["bcjr_decode"]


@njit(cache=True, nogil=True)
def _bcjr(llr, outputs, next_state, n_steps):
    n_states = outputs.shape[0]
    neg = -1e300
    alpha = np.full((n_steps + 1, n_states), neg)
    beta = np.full((n_steps + 1, n_states), neg)
    alpha[0, 0] = 0.0
    beta[n_steps, 0] = 0.0  # terminated in state 0
    gamma = np.empty((n_steps, n_states, 2))
    for t in range(n_steps):
        l0 = 0.5 * llr[2 * t]
        l1 = 0.5 * llr[2 * t + 1]
        for s in range(n_states):
            for b in range(2):
                gamma[t, s, b] = outputs[s, b, 0] * l0 + outputs[s, b, 1] * l1
    for t in range(n_steps):
        for s in range(n_states):
            a = alpha[t, s]
            if a <= neg:
                continue
            for b in range(2):
                ns = next_state[s, b]
                m = a + gamma[t, s, b]
                if m > alpha[t + 1, ns]:
                    alpha[t + 1, ns] = m
    for t in range(n_steps - 1, -1, -1):
        for s in range(n_states):
            best = neg
            for b in range(2):
                m = beta[t + 1, next_state[s, b]] + gamma[t, s, b]
                if m > best:
                    best = m
            beta[t, s] = best
    info = np.empty(n_steps)
    coded = np.empty(2 * n_steps)
    for t in range(n_steps):
        best_u = np.full(2, neg)  # by input bit
        best_c = np.full((2, 2), neg)  # by coded bit j, value 0/1
        for s in range(n_states):
            a = alpha[t, s]
            if a <= neg:
                continue
            for b in range(2):
                m = a + gamma[t, s, b] + beta[t + 1, next_state[s, b]]
                if m > best_u[b]:
                    best_u[b] = m
                for j in range(2):
                    c = 0 if outputs[s, b, j] > 0 else 1
                    if m > best_c[j, c]:
                        best_c[j, c] = m
        info[t] = best_u[0] - best_u[1]
        coded[2 * t] = best_c[0, 0] - best_c[0, 1]
        coded[2 * t + 1] = best_c[1, 0] - best_c[1, 1]
    return info, coded


def bcjr_decode(llr: np.ndarray, n_info: int) -> tuple[np.ndarray, np.ndarray]:
    """A-posteriori LLRs of the information and coded bits (max-log-MAP).

    Parameters
    ----------
    llr : numpy.ndarray, shape (≥ 2·(n_info + 6),)
        Channel LLRs in code order, L = log P(c = 0)/P(c = 1).
    n_info : int
        Information bits before the 6 tail bits.

    Returns
    -------
    info_llr : numpy.ndarray, shape (n_info,)
        A-posteriori LLRs of the information bits (sign → hard decision).
    coded_extrinsic : numpy.ndarray, shape (2·(n_info + 6),)
        A-posteriori minus channel LLRs of the coded bits: what the code adds,
        fed back to the equaliser as a-priori information.

    Notes
    -----
    Max-log-MAP: forward/backward recursions with max instead of log-sum-exp;
    the hard decisions equal the Viterbi path.
    """
    n_steps = n_info + 6
    llr = np.ascontiguousarray(llr[: 2 * n_steps], dtype=np.float64)
    if llr.size < 2 * n_steps:
        raise ValueError(f"need {2 * n_steps} LLRs for {n_info} information bits, got {llr.size}")
    info, coded = _bcjr(llr, OUTPUTS, NEXT_STATE, n_steps)
    return info[:n_info], coded - llr


