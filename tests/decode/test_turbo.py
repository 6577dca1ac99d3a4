import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.decode.equalizer import DfeSettings
from seamodem.decode.turbo import estimate_channel, symbol_noise_var, turbo_equalize
from seamodem.errors import ConfigError

# a harsh fixed channel at T/2 spacing: 9 taps, a strong late echo
H = np.array([0.1, 0.3 + 0.1j, 1.0, 0.5 - 0.2j, 0.2, 0.1j, 0.6, 0.3j, 0.5])
SETTINGS = DfeSettings(n_ff=24, ff_centre=8, n_fb=8)


def _received(symbols, noise_var, rng):
    up = np.zeros(2 * symbols.size, complex)
    up[::2] = symbols
    x = np.convolve(up, H)[: up.size + 20]
    x = x * np.exp(1j * (0.4 + 2 * np.pi * 0.3 / 6400 * np.arange(x.size) / 2))  # residual phase + 0.3 Hz
    return x + np.sqrt(noise_var / 2) * (rng.normal(size=x.size) + 1j * rng.normal(size=x.size))


def test_least_squares_channel_estimate():
    rng = np.random.default_rng(0)
    s = rng.choice([-1.0, 1.0], 2000) + 0j
    up = np.zeros(4000, complex)
    up[::2] = s
    x = np.convolve(up, H)[:4000]  # centre 0: symbol k's first tap lands on sample 2k
    h, nv = estimate_channel(x, s, 2, 12, 0)
    np.testing.assert_allclose(h[: H.size], H, atol=1e-10)
    np.testing.assert_allclose(h[H.size :], 0, atol=1e-10)
    assert nv < 1e-20


@pytest.mark.parametrize("mod", ["bpsk", "qpsk"])
def test_turbo_recovers_frames_the_dfe_loses(mod):
    # measured on this channel, 10 frames: BPSK at noise variance 1.8, the DFE alone decodes 0 and four
    # turbo passes 10; QPSK at 0.8 (3 dB more SNR than BPSK needs), the DFE 1 of 5 and turbo 5 of 5.
    cfg = get_preset("jmse2024").replace(modulation=mod)
    noise_var = 1.8 if mod == "bpsk" else 0.8
    rng = np.random.default_rng(5)
    dfe_ok = turbo_ok = 0
    for _ in range(5):
        payload = bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8))
        fr = build_frame(cfg, payload)
        r = turbo_equalize(_received(fr.symbols, noise_var, rng), fr.pilot_symbols, cfg, settings=SETTINGS, passes=4)
        dfe_ok += r.crc_by_pass[0]
        turbo_ok += r.decoded.crc_ok and r.decoded.payload == payload
    assert dfe_ok <= 1
    assert turbo_ok >= 4


def test_turbo_stops_at_the_first_success_and_validates():
    cfg = get_preset("jmse2024")
    rng = np.random.default_rng(1)
    fr = build_frame(cfg, b"easy")
    r = turbo_equalize(_received(fr.symbols, 0.05, rng), fr.pilot_symbols, cfg, settings=SETTINGS)
    assert r.passes == 1 and r.decoded.crc_ok and r.decoded.payload == b"easy"
    with pytest.raises(ConfigError, match="^modulation"):
        turbo_equalize(np.zeros(10, complex), fr.pilot_symbols, cfg.replace(modulation="8psk"))
    with pytest.raises(ConfigError, match="^passes"):
        turbo_equalize(np.zeros(10, complex), fr.pilot_symbols, cfg, passes=0)


def test_symbols_hit_by_impulses_do_not_pull_the_decoder():
    # clicks the blanker leaves (below its threshold, 5 × a scale that the signal sets at high SNR) hit a few
    # symbols each: 40 bursts of 3 samples, |a| 2.5–7.5 against unit symbols, QPSK at noise variance 0.3.
    # Measured over 8 frames: each symbol's own noise variance decodes 8, the frame's one 0 (the turbo passes)
    cfg = get_preset("jmse2024").replace(modulation="qpsk")
    ok = {True: 0, False: 0}
    for trial in range(3):
        rng = np.random.default_rng(100 + trial)
        payload = bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8))
        fr = build_frame(cfg, payload)
        x = _received(fr.symbols, 0.3, rng)
        for a in rng.integers(0, x.size - 4, 40):
            x[a : a + 3] += 5.0 * np.exp(2j * np.pi * rng.random()) * rng.uniform(0.5, 1.5)
        for per_symbol in ok:
            r = turbo_equalize(x, fr.pilot_symbols, cfg, settings=SETTINGS, passes=4, per_symbol_noise=per_symbol)
            ok[per_symbol] += r.decoded.crc_ok and r.decoded.payload == payload
    assert ok[True] == 3
    assert ok[False] == 0


def test_symbol_noise_variance_is_the_frames_and_an_impulses_own():
    rng = np.random.default_rng(3)
    y = rng.choice([-1.0, 1.0], 4000) + np.sqrt(0.1 / 2) * (rng.normal(size=4000) + 1j * rng.normal(size=4000))
    var = symbol_noise_var(y, "bpsk")
    assert np.median(var) == pytest.approx(0.1, rel=0.08)  # the Gaussian's variance
    assert np.mean(var > var.min()) < 0.07  # e⁻³ ≈ 5 % of a Gaussian's symbols beyond 3σ²
    y[::100] += 6.0  # 1 % of the symbols hit: the frame's variance stays, theirs is their own
    var = symbol_noise_var(y, "bpsk")
    assert np.median(var) == pytest.approx(0.1, rel=0.1)
    err2 = np.min(np.abs(y[::100, None] - np.array([-1, 1])[None, :]) ** 2, axis=1)
    np.testing.assert_allclose(var[::100], np.maximum(err2 / 3, np.median(var)))
    assert symbol_noise_var(np.zeros(0, complex), "qpsk").size == 0
