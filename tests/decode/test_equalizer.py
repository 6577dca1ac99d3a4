import numpy as np
import pytest

from seamodem.decode import decode_payload
from seamodem.decode.equalizer import DfeSettings, dfe_equalize, mmse_dfe_taps
from seamodem.errors import ConfigError
from seamodem import build_frame, get_preset

H = np.array([0.1, 0.3 + 0.1j, 1.0, 0.5 - 0.2j, 0.2, 0.1j, 0.25])  # a fixed channel at T/2 spacing


def _through_channel(s, h, noise_var, rng, phase=None):
    up = np.zeros(2 * s.size, complex)
    up[::2] = s
    x = np.convolve(up, h)[: up.size]
    if phase is not None:
        x = x * np.exp(1j * phase)
    return x + np.sqrt(noise_var / 2) * (rng.normal(size=x.size) + 1j * rng.normal(size=x.size))


def test_rls_taps_converge_to_the_mmse_solution():
    rng = np.random.default_rng(0)
    n = 20000
    s = rng.choice([-1.0, 1.0], n) + 0j
    x = _through_channel(s, H, 0.05, rng)
    st = DfeSettings(n_ff=16, ff_centre=6, n_fb=4, pll_kp=0, pll_ki=0, forgetting=0.9998)
    got = dfe_equalize(x, s, n, "bpsk", st).taps
    want = mmse_dfe_taps(H, st, 0.05)
    # RLS misadjustment with λ = 0.9998 and 20 taps leaves ~ √((1 − λ)·N/2) ≈ 4 % tap noise
    assert np.linalg.norm(got - want) / np.linalg.norm(want) < 0.06
    # and the FB taps cancel the post-cursor ISI that the MMSE solution predicts
    np.testing.assert_allclose(got[16:], want[16:], atol=0.03)


@pytest.mark.parametrize("algorithm", ["rls", "nlms"])
def test_decision_directed_after_pilots_with_phase_drift(algorithm):
    rng = np.random.default_rng(1)
    n = 4000
    s = (rng.choice([-1.0, 1.0], n) + 1j * rng.choice([-1.0, 1.0], n)) / np.sqrt(2)
    drift = 2 * np.pi * 0.5 / 6400 * np.arange(2 * n) / 2  # 0.5 Hz residual carrier offset at 6.4 kBd
    x = _through_channel(s, H, 0.01, rng, phase=0.7 + drift)
    n_train = 150 if algorithm == "rls" else 1000  # NLMS converges more slowly (module guidance)
    r = dfe_equalize(x, s[:n_train], n, "qpsk", DfeSettings(algorithm=algorithm, n_ff=16, ff_centre=6, n_fb=4))
    errors = np.count_nonzero(r.decisions[n_train:] != s[n_train:])
    assert errors == 0
    assert r.snr_db > 12  # 0.01 noise at |h| ≈ 1.3: an ideal MMSE-DFE gives about 20 dB
    # The PLL follows the drift. The adaptive taps rotate with it too and take a share: small with
    # RLS (5 %), larger with NLMS, whose slowly adapting taps lag and keep rotating (measured 12 %).
    slope = np.polyfit(np.arange(n // 2, n), np.unwrap(r.phase[n // 2 :]), 1)[0]
    share = {"rls": 0.05, "nlms": 0.15}[algorithm]
    assert slope == pytest.approx(2 * np.pi * 0.5 / 6400, rel=share)


def test_without_pll_a_frequency_offset_breaks_the_equaliser():
    # the PLL is what makes the residual-Doppler case work: without it, errors appear
    rng = np.random.default_rng(2)
    n = 4000
    s = (rng.choice([-1.0, 1.0], n) + 1j * rng.choice([-1.0, 1.0], n)) / np.sqrt(2)
    x = _through_channel(s, H, 0.01, rng, phase=2 * np.pi * 3.0 / 6400 * np.arange(2 * n) / 2)
    off = dfe_equalize(x, s[:150], n, "qpsk", DfeSettings(n_ff=16, ff_centre=6, n_fb=4, pll_kp=0, pll_ki=0,
                                                          forgetting=0.999))
    on = dfe_equalize(x, s[:150], n, "qpsk", DfeSettings(n_ff=16, ff_centre=6, n_fb=4))
    assert np.count_nonzero(on.decisions[150:] != s[150:]) == 0
    assert off.noise_var > 3 * on.noise_var


def test_equalised_frame_decodes():
    cfg = get_preset("jmse2024")
    rng = np.random.default_rng(3)
    fr = build_frame(cfg, b"through a multipath channel")
    x = _through_channel(fr.symbols, H, 0.05, rng, phase=0.3)
    r = dfe_equalize(x, fr.pilot_symbols, fr.symbols.size, cfg.modulation, DfeSettings(n_ff=16, ff_centre=6, n_fb=4))
    out = decode_payload(r.soft[cfg.n_pilot :], r.noise_var, cfg)
    assert out.crc_ok and out.payload == b"through a multipath channel"


def test_settings_validation():
    with pytest.raises(ConfigError, match="^algorithm"):
        DfeSettings(algorithm="lms")
    with pytest.raises(ConfigError, match="^ff_centre"):
        DfeSettings(n_ff=4, ff_centre=4)
    with pytest.raises(ConfigError, match="^forgetting"):
        DfeSettings(forgetting=1.5)
