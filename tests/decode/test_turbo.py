import numpy as np
import pytest

from seamodem import build_frame, get_preset
from seamodem.decode.equalizer import DfeSettings
from seamodem.decode.turbo import estimate_channel, turbo_equalize
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
