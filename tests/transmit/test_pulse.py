import numpy as np
import pytest
from scipy.integrate import simpson

from seamodem.transmit.pulse import srrc_matrix, srrc_pulse, srrc_taps, srrc_truncation_energy

T = 1 / 6400


def raised_cosine(t, T, a):
    """Closed-form raised-cosine pulse p(t) = (g*g)(t) of the untruncated SRRC (independent reference)."""
    u = t / T
    den = 1 - (2 * a * u) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.sinc(u) * np.cos(np.pi * a * u) / den
    sing = np.abs(den) < 1e-12
    p[sing] = np.pi / 4 * np.sinc(1 / (2 * a))
    return p


@pytest.mark.parametrize("a", [0.0, 0.25, 0.4, 1.0])
def test_untruncated_srrc_has_unit_energy(a):
    # energy beyond ±400 symbols is below 1e-6 for α > 0 (tails ∝ 1/t²); α = 0 (sinc) leaks 1/(π² 400) ≈ 2.5e-4
    u = np.linspace(-400, 400, 400 * 64 * 2 + 1)
    energy = simpson(srrc_pulse(u * T, T, a) ** 2, x=u * T)
    assert energy == pytest.approx(1.0, abs=3e-4 if a == 0 else 1e-5)


@pytest.mark.parametrize("a", [0.25, 0.4, 0.5])
def test_srrc_convolved_with_itself_is_the_raised_cosine(a):
    # independent closed form: SRRC * SRRC = raised cosine; numerical convolution over ±300 symbols
    u = np.linspace(-300, 300, 300 * 64 * 2 + 1)
    g = srrc_pulse(u * T, T, a)
    for shift in [0.0, 0.5, 1.0, 1.37, 3.0, 7.25]:
        g2 = srrc_pulse((u - shift) * T, T, a)
        conv = simpson(g * g2, x=u * T)
        # tail truncation of the numerical integral bounds the error at ~1e-5
        assert conv == pytest.approx(raised_cosine(np.array([shift * T]), T, a)[0], abs=2e-5)


@pytest.mark.parametrize("a", [0.0, 0.4, 1.0])
def test_srrc_is_symmetric_and_continuous_at_its_special_points(a):
    t = np.random.default_rng(0).uniform(-20 * T, 20 * T, 1000)
    np.testing.assert_allclose(srrc_pulse(t, T, a), srrc_pulse(-t, T, a), rtol=0, atol=1e-9 / np.sqrt(T))
    special = [0.0] + ([T / (4 * a)] if a > 0 else [])
    for ts in special:
        eps = 1e-7 * T
        near = srrc_pulse(np.array([ts - eps, ts + eps]), T, a)
        at = srrc_pulse(np.array([ts]), T, a)[0]
        # the limit value must agree with the pulse a hair away (slope × 1e-7 T is ~1e-6 relative)
        assert at == pytest.approx(near.mean(), rel=1e-5)


def test_alpha_zero_is_a_sinc():
    t = np.linspace(-10 * T, 10 * T, 1001)
    np.testing.assert_allclose(srrc_pulse(t, T, 0.0), np.sinc(t / T) / np.sqrt(T), atol=1e-9 / np.sqrt(T))


@pytest.mark.parametrize("a,span", [(0.4, 32), (0.4, 16), (0.25, 32), (1.0, 8)])
def test_truncated_pulse_unit_energy_and_zero_isi_within_stated_truncation_error(a, span):
    # The truncated pulse is g·1{|t| ≤ LT}/√E with E the energy kept. By Cauchy–Schwarz its
    # self-convolution differs from the raised cosine at t = kT by at most ε = 2√(1 − E)/E.
    energy_kept = srrc_truncation_energy(a, span // 2)
    bound = 2 * np.sqrt(1 - energy_kept) / energy_kept
    sps = 64
    dt = T / sps
    t = np.arange(-(span // 2) * sps, (span // 2) * sps + 1) * dt
    g = srrc_matrix(t, np.array([0.0]), symbol_period_s=T, rolloff=a, span_symbols=span).toarray()[:, 0] / np.sqrt(T)
    assert np.sum(g**2) * dt == pytest.approx(1.0, abs=1e-3)  # Riemann sum of a pulse with a jump at ±LT
    full = np.convolve(g, g) * dt
    centre = full.size // 2
    for k in range(1, span):
        assert abs(full[centre + k * sps]) <= bound + 1e-4, (k, full[centre + k * sps], bound)
    assert full[centre] == pytest.approx(1.0, abs=1e-3)
    print(f"alpha={a} span={span}: energy kept 1-{1 - energy_kept:.2e}, ISI bound {bound:.2e}")


def test_srrc_truncation_error_is_stated_for_the_presets():
    # jmse2024 and oceans2021 use span 32: the zero-ISI error bound must stay below −40 dB (1e-2)
    for a in (0.4, 0.5):
        e = srrc_truncation_energy(a, 16)
        assert 2 * np.sqrt(1 - e) / e < 1e-2


def test_sampled_taps_are_symmetric_with_unit_energy():
    h = srrc_taps(8, 16, 0.35)
    assert h.size == 16 * 8 + 1
    np.testing.assert_allclose(h, h[::-1], atol=1e-15)
    assert np.sum(h**2) == pytest.approx(1.0, abs=1e-12)


def test_srrc_matrix_matches_naive_sum_on_a_fractional_grid():
    fs = 96153.0
    rng = np.random.default_rng(1)
    tk = (10 + np.arange(40)) * T
    ts = 0.3e-5 + np.arange(int(60 * T * fs)) / fs
    x = rng.choice([-1.0, 1.0], 40) + 1j * rng.choice([-1.0, 1.0], 40)
    G = srrc_matrix(ts, tk, symbol_period_s=T, rolloff=0.4, span_symbols=16)
    scale = np.sqrt(srrc_truncation_energy(0.4, 8))
    naive = np.zeros(ts.size, complex)
    for k in range(40):
        d = ts - tk[k]
        naive += np.where(np.abs(d) <= 8 * T, x[k] * np.sqrt(T) * srrc_pulse(d, T, 0.4) / scale, 0)
    np.testing.assert_allclose(G @ x, naive, atol=1e-12)
