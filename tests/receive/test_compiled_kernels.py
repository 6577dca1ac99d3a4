"""Compiled receiver kernels against the plain numpy / complex-arithmetic forms they replaced.

The speed-ups of session 5 (issue 15/17 speed goals) must not move any result:
each kernel is checked bit for bit (or, for the dichotomy score, to rounding)
against a reference written the way the code was before.
"""

import math

import numpy as np
import pytest

from seamodem import get_preset
from seamodem.decode.equalizer import _dfe
from seamodem.receive.doppler import _srrc_table, matched_filter, table_read
from seamodem.receive.multipath import _ls_residual_energy
from seamodem.transmit.pulse import srrc_truncation_energy

CFG = get_preset("jmse2024")


def test_table_read_is_the_uniform_table_bit_for_bit():
    table = _srrc_table(0.4, 16)
    rng = np.random.default_rng(3)
    for x in (rng.uniform(-20, 20, 20000), rng.uniform(-16, 16, (40, 300)),
              np.array([-16.0, 16.0, 0.0, 15.99999999, -17.0, 17.0, 16.0000001, -16.0000001])):
        assert np.array_equal(table_read(table, x), table(x))


def _matched_filter_numpy(r, fs, t0_s, tk, *, scale, carrier_offset_hz, t_ref_s):
    """The matched filter as written before it was compiled (numpy, dense gather, einsum)."""
    T = CFG.symbol_period_s / scale
    n_half = CFG.srrc_span_symbols // 2
    half = n_half * T
    n_lo = max(0, int(math.floor((np.min(tk) - half - t0_s) * fs)))
    n_hi = min(len(r), int(math.ceil((np.max(tk) + half - t0_s) * fs)) + 1)
    x = r[n_lo:n_hi]
    if carrier_offset_hz:
        x = x * np.exp(-2j * np.pi * carrier_offset_hz * (t0_s + np.arange(n_lo, n_hi) / fs - t_ref_s))
    width = int(math.ceil(2 * half * fs)) + 2
    first = np.ceil((tk - half - t0_s) * fs - 1e-9).astype(np.int64)
    idx = first[:, None] + np.arange(width)[None, :]
    u = t0_s + idx / fs - tk[:, None]
    inside = (idx >= n_lo) & (idx < n_hi) & (np.abs(u) <= half)
    g = _srrc_table(float(CFG.rolloff), n_half)(u / T) * (inside / math.sqrt(T))
    samples = x[np.clip(idx - n_lo, 0, n_hi - n_lo - 1)]
    norm = np.sqrt(T / srrc_truncation_energy(float(CFG.rolloff), n_half)) / (fs * T)
    return np.einsum("kn,kn->k", g, samples) * norm


@pytest.mark.parametrize("scale, offset_hz", [(1.0, 0.0), (1.002, 56.0)])
def test_compiled_matched_filter_is_the_numpy_form_bit_for_bit(scale, offset_hz):
    rng = np.random.default_rng(1)
    fs = 13736.142857
    r = rng.standard_normal(6000) + 1j * rng.standard_normal(6000)
    # symbols near both ends too: supports cut by the recording's edges
    tk = -0.001 + np.arange(160) * CFG.symbol_period_s / scale + 1.234e-5
    got = matched_filter(r, fs, 0.0, tk, config=CFG, scale=scale, carrier_offset_hz=offset_hz, t_ref_s=0.05)
    want = _matched_filter_numpy(r, fs, 0.0, tk, scale=scale, carrier_offset_hz=offset_hz, t_ref_s=0.05)
    assert np.array_equal(got, want)


def test_normal_equation_residual_equals_lstsq_and_flags_collinear_columns():
    rng = np.random.default_rng(2)
    m = 900
    t = np.arange(m)
    store = np.stack([np.sinc((t - c) / 7.3) for c in (300.0, 310.5, 333.2, 300.0)])
    corr = store[:3].T @ (rng.standard_normal(3) + 1j * rng.standard_normal(3))
    corr = corr + 0.01 * (rng.standard_normal(m) + 1j * rng.standard_normal(m))
    for rows in ([0], [0, 1], [2, 0, 1]):
        mat = store[rows].T
        b, *_ = np.linalg.lstsq(mat, corr, rcond=None)
        want = float(np.sum(np.abs(corr - mat @ b) ** 2))
        got = _ls_residual_energy(store, np.array(rows, dtype=np.int64), corr)
        assert abs(got - want) <= 1e-9 * want
    # the same delay twice: singular Gram matrix, the caller must fall back to lstsq
    assert _ls_residual_energy(store, np.array([0, 3], dtype=np.int64), corr) == -1.0


def _dfe_reference(x, sps, n_sym, train, n_ff, ff_centre, n_fb, lam, delta, points):
    """The RLS DFE in plain Python complex arithmetic, as the kernel was written before (PLL off)."""
    n = n_ff + n_fb
    w = [0j] * n
    w[ff_centre] = 1 + 0j
    P = [[(1 + 0j) / delta if i == j else 0j for j in range(n)] for i in range(n)]
    past = [0j] * max(n_fb, 1)
    soft = []
    for k in range(n_sym):
        u = [complex(x[sps * k - ff_centre + i]) if 0 <= sps * k - ff_centre + i < len(x) else 0j
             for i in range(n_ff)] + past[:n_fb]
        z = 0j
        for i in range(n):
            z += w[i].conjugate() * u[i]
        if k < len(train):
            d = complex(train[k])
        else:
            d = complex(points[int(np.argmin([abs(z - p) for p in points]))])
        e = d - z
        denom = lam
        Pu = []
        for i in range(n):
            acc = 0j
            for j in range(n):
                acc += P[i][j] * u[j]
            Pu.append(acc)
            denom += (u[i].conjugate() * acc).real
        g = [Pu[i] / denom for i in range(n)]
        for i in range(n):
            w[i] += g[i] * e.conjugate()
        P = [[(P[i][j] - g[i] * Pu[j].conjugate()) / lam for j in range(n)] for i in range(n)]
        soft.append(z)
        past = [d] + past[:-1]
    return np.array(soft), np.array(w)


def test_rls_dfe_kernel_is_the_complex_arithmetic_form_bit_for_bit():
    rng = np.random.default_rng(4)
    n_sym, n_train = 60, 30
    symbols = np.sign(rng.standard_normal(n_sym)) + 0j
    x = np.repeat(symbols, 2) * (0.9 + 0.2j) + 0.1 * (rng.standard_normal(2 * n_sym) + 1j * rng.standard_normal(2 * n_sym))
    points = np.array([1 + 0j, -1 + 0j])
    n_ff, ff_centre, n_fb, lam, delta = 9, 3, 4, 0.999, 1e-2  # odd tap count: the kernel's leftover row
    soft, _, _, w = _dfe(x, 2, n_sym, symbols[:n_train], n_train, n_ff, ff_centre, n_fb, True, lam, 0.05,
                         0.0, 0.0, delta, points)
    soft_ref, w_ref = _dfe_reference(x, 2, n_sym, symbols[:n_train], n_ff, ff_centre, n_fb, lam, delta, points)
    assert np.array_equal(soft, soft_ref)
    assert np.array_equal(w, w_ref)


def test_whole_frame_interpolation_kernels_are_the_lagrange_forms():
    """The whole-frame fit's read (filter outputs and their derivative at the symbol instants) and spread
    (synthesis) kernels against the numpy forms they replaced: gather × Lagrange weights, and bincount."""
    from seamodem.receive.wholeframe import _BASIS, _TAPS, _lagrange, _read_kernel, _spread_kernel

    rng = np.random.default_rng(5)
    big = 4000
    c = rng.standard_normal(big) + 1j * rng.standard_normal(big)
    pos = np.concatenate([rng.uniform(0, big, 500), [0.0, 1.0, big - 3.5, 2.999999]])  # wrap at both ends
    x = rng.standard_normal(pos.size) + 1j * rng.standard_normal(pos.size)
    i0, w = _lagrange(pos)
    _, dw = _lagrange(pos, derivative=True)
    idx = (i0[:, None] + _TAPS[None, :]) % big
    y, dy = np.empty(pos.size, complex), np.empty(pos.size, complex)
    _read_kernel(c, pos, _BASIS, int(_TAPS[0]), y, dy)
    scale = np.max(np.abs(c))
    assert np.max(np.abs(y - np.einsum("kj,kj->k", c[idx], w))) < 1e-13 * scale
    assert np.max(np.abs(dy - np.einsum("kj,kj->k", c[idx], dw))) < 1e-13 * scale
    grid = np.zeros(big, complex)
    _spread_kernel(x, pos, _BASIS, int(_TAPS[0]), grid)
    spread = (w * x[:, None]).ravel()
    want = np.bincount(idx.ravel(), spread.real, big) + 1j * np.bincount(idx.ravel(), spread.imag, big)
    assert np.max(np.abs(grid - want)) < 1e-13 * np.max(np.abs(x))
    # the Lagrange weights interpolate: a cubic on the grid is read exactly, and its derivative too
    t = np.arange(big) / big
    _read_kernel((t**3 - 2 * t).astype(complex), pos[:500] * 0.5 + 10, _BASIS, int(_TAPS[0]), y[:500], dy[:500])
    u = (pos[:500] * 0.5 + 10) / big
    assert np.allclose(y[:500].real, u**3 - 2 * u, atol=1e-12)
    assert np.allclose(dy[:500].real * big, 3 * u**2 - 2, atol=1e-9)


def _bank_power_numpy(det, r):
    """The detector's Doppler bank as written before it was compiled (roll, product, |c|², mask updates)."""
    import scipy.fft

    n_out = len(r) - det.length + 1
    n = scipy.fft.next_fast_len(len(r))
    spectrum = scipy.fft.fft(r.astype(np.complex64), n)
    pilot = np.conj(scipy.fft.fft(det.template.astype(np.complex64), n))
    shifts = np.round(det.doppler_hz * n / det.fs).astype(np.int64)
    sample = np.empty((len(shifts), -(-n_out // 4)), dtype=np.float32)
    best = np.zeros(n_out, dtype=np.int64)
    peak = np.zeros(n_out, dtype=np.float32)
    for b, m in enumerate(shifts):
        c = scipy.fft.ifft(spectrum * np.roll(pilot, m))[:n_out]
        power = c.real**2 + c.imag**2
        sample[b] = power[::4]
        best[power > peak] = b
        np.maximum(peak, power, out=peak)
    return sample, best, peak.astype(np.float64)


def test_detector_bank_kernels_are_the_numpy_form_bit_for_bit():
    from seamodem.receive.detect import PilotDetector

    det = PilotDetector(CFG, 13736.142857, v_max_mps=5, sound_speed_mps=1500)
    rng = np.random.default_rng(7)
    for n in (3001, 9750, 16617):
        r = rng.standard_normal(n) + 1j * rng.standard_normal(n)
        r[n // 3 : n // 3 + det.length] += 3 * det.template  # a pilot in the noise
        for got, want in zip(det._bank_power(r), _bank_power_numpy(det, r)):
            assert np.array_equal(got, want)
