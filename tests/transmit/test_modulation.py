import numpy as np
import pytest

from seamodem.transmit.modulation import bits_to_symbols, constellation, symbols_to_bits


@pytest.mark.parametrize("mod,bps", [("bpsk", 1), ("qpsk", 2), ("8psk", 3)])
def test_constellation_unit_energy_and_gray(mod, bps):
    pts = constellation(mod)
    assert pts.size == 2**bps
    np.testing.assert_allclose(np.abs(pts), 1.0, atol=1e-15)
    # Gray: each point's nearest neighbours differ from it in exactly one bit
    d = np.abs(pts[:, None] - pts[None, :])
    np.fill_diagonal(d, np.inf)
    for label in range(pts.size):
        nearest = np.flatnonzero(np.isclose(d[label], d[label].min()))
        for other in nearest:
            assert bin(label ^ other).count("1") == 1


@pytest.mark.parametrize("mod,bps", [("bpsk", 1), ("qpsk", 2), ("8psk", 3)])
def test_bits_round_trip(mod, bps):
    bits = np.random.default_rng(2).integers(0, 2, 300 * bps).astype(np.uint8)
    np.testing.assert_array_equal(symbols_to_bits(bits_to_symbols(bits, mod), mod), bits)


def test_bpsk_and_qpsk_labels():
    np.testing.assert_allclose(bits_to_symbols(np.array([0, 1]), "bpsk"), [1, -1])
    q = bits_to_symbols(np.array([0, 0, 0, 1, 1, 1, 1, 0]), "qpsk") * np.sqrt(2)
    np.testing.assert_allclose(q, [1 + 1j, 1 - 1j, -1 - 1j, -1 + 1j])


def test_bit_count_must_match_modulation():
    with pytest.raises(ValueError, match="multiple of 3"):
        bits_to_symbols(np.zeros(4, dtype=np.uint8), "8psk")
