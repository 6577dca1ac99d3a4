import itertools

import numpy as np
import pytest
from scipy.special import erfc

from seamodem import build_frame, get_preset
from seamodem.decode import decode_payload, soft_demap, viterbi_decode
from seamodem.transmit.coding import conv_encode
from seamodem.transmit.modulation import constellation, symbols_to_bits


def test_viterbi_equals_exhaustive_maximum_likelihood():
    # independent reference: try all 2^8 information words, keep the best correlation
    rng = np.random.default_rng(5)
    words = np.array(list(itertools.product([0, 1], repeat=8)))
    book = np.array([1.0 - 2.0 * conv_encode(w) for w in words])
    for _ in range(200):
        sent = words[rng.integers(256)]
        llr = (1.0 - 2.0 * conv_encode(sent)) * 2.0 + rng.normal(0, 2.2, book.shape[1])
        ml = words[np.argmax(book @ llr)]
        np.testing.assert_array_equal(viterbi_decode(llr, 8), ml)


def test_viterbi_noiseless_and_length_check():
    bits = np.random.default_rng(0).integers(0, 2, 1000).astype(np.uint8)
    np.testing.assert_array_equal(viterbi_decode(1.0 - 2.0 * conv_encode(bits), 1000), bits)
    with pytest.raises(ValueError, match="need 2012 LLRs"):
        viterbi_decode(np.zeros(100), 1000)


def test_coded_ber_near_the_union_bound():
    # K7 r1/2 at Eb/N0 = 4 dB: the union bound over d = 10, 12, 14 (c_d = 36, 211, 1404) gives ≈ 2e-5;
    # measured must be below 3× that (the bound is tight at this SNR) and far below uncoded Q(√(2Eb/N0)) = 1.3e-2
    rng = np.random.default_rng(1)
    ebn0 = 10 ** 0.4
    n_info, blocks = 2000, 60
    sigma = np.sqrt(1 / (2 * 0.5 * ebn0))
    errors = 0
    for _ in range(blocks):
        bits = rng.integers(0, 2, n_info).astype(np.uint8)
        y = 1.0 - 2.0 * conv_encode(bits) + rng.normal(0, sigma, 2 * (n_info + 6))
        errors += np.count_nonzero(viterbi_decode(2 * y / sigma**2, n_info) != bits)
    ber = errors / (n_info * blocks)
    q = lambda x: 0.5 * erfc(x / np.sqrt(2))  # noqa: E731
    bound = sum(c * q(np.sqrt(2 * d * 0.5 * ebn0)) for d, c in [(10, 36), (12, 211), (14, 1404)])
    assert ber < 3 * bound + 3 / (n_info * blocks)


@pytest.mark.parametrize("mod", ["bpsk", "qpsk", "8psk"])
def test_soft_demap_signs_and_exact_bpsk_llr(mod):
    pts = constellation(mod)
    bps = int(np.log2(pts.size))
    llr = soft_demap(pts, 0.1, mod).reshape(pts.size, bps)
    for label in range(pts.size):
        bits = (label >> np.arange(bps - 1, -1, -1)) & 1
        assert np.all(np.sign(llr[label]) == 1 - 2 * bits)
    y = np.array([0.3 + 0.2j, -1.1 - 0.4j])
    np.testing.assert_allclose(soft_demap(y, 0.5, "bpsk"), 4 * y.real / 0.5)  # exact: 4 Re(y)/σ²


@pytest.mark.parametrize("preset", ["jmse2024", "oceans2021"])
@pytest.mark.parametrize("mod", ["bpsk", "qpsk"])
def test_frame_payload_round_trip_through_noise(preset, mod):
    cfg = get_preset(preset).replace(modulation=mod)
    rng = np.random.default_rng(7)
    payload = bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8))
    fr = build_frame(cfg, payload)
    noise_var = 10 ** (-6 / 10)  # Es/N0 = 6 dB: raw symbol errors, all corrected by the code
    y = fr.data_symbols + np.sqrt(noise_var / 2) * (rng.normal(size=cfg.n_data) + 1j * rng.normal(size=cfg.n_data))
    raw_errors = np.count_nonzero(symbols_to_bits(y, mod) != symbols_to_bits(fr.data_symbols, mod))
    out = decode_payload(y, noise_var, cfg)
    assert raw_errors > 0
    assert out.crc_ok and out.payload == payload


def test_corrupted_frame_is_never_marked_valid():
    cfg = get_preset("jmse2024")
    rng = np.random.default_rng(11)
    fr = build_frame(cfg, b"secret")
    valid = 0
    for _ in range(40):
        y = fr.data_symbols + 1.5 * (rng.normal(size=cfg.n_data) + 1j * rng.normal(size=cfg.n_data))
        out = decode_payload(y, 4.5, cfg)
        valid += out.crc_ok
        if out.crc_ok:
            assert out.payload == b"secret"
    assert valid == 0  # at Es/N0 = −6.5 dB the code fails; CRC-16 must catch all 40 failures


def test_uncoded_frame_decodes():
    cfg = get_preset("oceans2021").replace(fec="none")
    fr = build_frame(cfg, b"raw bits")
    out = decode_payload(fr.data_symbols, 0.01, cfg)
    assert out.crc_ok and out.payload == b"raw bits"


def test_bcjr_hard_decisions_equal_viterbi_and_extrinsic_is_informative():
    from seamodem.decode.bcjr import bcjr_decode

    rng = np.random.default_rng(9)
    bits = rng.integers(0, 2, 400).astype(np.uint8)
    code = 1.0 - 2.0 * conv_encode(bits)
    sigma = 0.9
    llr = 2 * (code + rng.normal(0, sigma, code.size)) / sigma**2
    info_llr, extrinsic = bcjr_decode(llr, 400)
    np.testing.assert_array_equal((info_llr < 0).astype(np.uint8), viterbi_decode(llr, 400))
    # the a-posteriori coded LLRs make fewer hard errors than the channel LLRs alone
    raw = np.count_nonzero((llr < 0) != (code < 0))
    post = np.count_nonzero(((llr + extrinsic) < 0) != (code < 0))
    assert raw > 20 and post < raw / 4


def test_bcjr_matches_exhaustive_max_log_map():
    # independent reference: max-log-MAP of bit 3 by enumerating all 2^8 codewords
    from seamodem.decode.bcjr import bcjr_decode

    rng = np.random.default_rng(4)
    words = np.array(list(itertools.product([0, 1], repeat=8)))
    book = np.array([1.0 - 2.0 * conv_encode(w) for w in words])
    for _ in range(50):
        llr = book[rng.integers(256)] * 1.5 + rng.normal(0, 1.5, book.shape[1])
        metric = 0.5 * book @ llr
        info_llr, _ = bcjr_decode(llr, 8)
        for i in range(8):
            want = metric[words[:, i] == 0].max() - metric[words[:, i] == 1].max()
            assert info_llr[i] == pytest.approx(want, abs=1e-9)
