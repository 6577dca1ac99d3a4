"""Reference waveforms: configuration, closed forms against scipy, the HFM coupling, the CRLB."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal

from seamodem.errors import ConfigError, InputFileError
from seamodem.transmit.reference import (
    ReferenceWaveform,
    hfm_coupling_s,
    load_references,
    parse_reference,
    reference_crlb,
    reference_replica,
    reference_waveform,
)

from independent import chirp_ping

FS = 96_000.0


@pytest.mark.parametrize(
    "fields, parameter",
    [
        ({"kind": "fm"}, "kind"),
        ({"kind": "lfm", "f_low_hz": 29e3, "f_high_hz": 19e3, "duration_s": 0.05}, "f_high_hz"),
        ({"kind": "lfm", "f_low_hz": 19e3, "f_high_hz": 29e3, "duration_s": 0.0}, "duration_s"),
        ({"kind": "hfm", "f_low_hz": 19e3, "f_high_hz": 29e3, "duration_s": 0.05, "window": "kaiser"}, "window"),
        ({"kind": "pn", "carrier_hz": 24e3, "chip_rate_hz": 5e3, "degree": 2}, "degree"),
        ({"kind": "pn", "carrier_hz": 2e3, "chip_rate_hz": 5e3}, "chip_rate_hz"),
        ({"kind": "template"}, "file"),
        ({"kind": "lfm", "f_low_hz": 19e3, "f_high_hz": 29e3, "duration_s": 0.05, "postamble_s": 0.01}, "postamble_s"),
        ({"kind": "lfm", "f_low_hz": 19e3, "f_high_hz": 29e3, "duration_s": 0.05, "bandwidth": 3}, "bandwidth"),
    ],
)
def test_invalid_configurations_name_the_parameter(fields, parameter):
    with pytest.raises(ConfigError, match=f"^{parameter}:"):
        ReferenceWaveform.from_dict(fields)


def test_round_trip_and_compact_forms(tmp_path):
    ref = parse_reference("hfm:29000-19000:0.05")
    assert (ref.kind, ref.f_low_hz, ref.f_high_hz, ref.down) == ("hfm", 19e3, 29e3, True)
    assert ReferenceWaveform.from_dict(ref.to_dict()) == ref
    pn = parse_reference("pn:24000:5000:7")
    assert pn.f_low_hz == pytest.approx(24e3 - 0.75 * 5e3) and pn.duration_s == pytest.approx((127 + 8) / 5e3)
    (tmp_path / "refs.toml").write_text(
        '[[reference]]\nkind = "lfm"\nf_low_hz = 19000.0\nf_high_hz = 29000.0\nduration_s = 0.05\nname = "a"\n'
        '[[reference]]\nkind = "pn"\ncarrier_hz = 12000.0\nchip_rate_hz = 4000.0\ndegree = 6\n'
    )
    a, b = load_references(str(tmp_path / "refs.toml"))
    assert a.name == "a" and b.degree == 6
    with pytest.raises(ConfigError, match="^reference:"):
        parse_reference("lfm:19000:0.05")
    with pytest.raises(InputFileError, match="not found"):
        load_references(str(tmp_path / "missing.toml"))


@pytest.mark.parametrize("kind, method", [("lfm", "linear"), ("hfm", "hyperbolic")])
def test_chirps_equal_scipy_chirp(kind, method):
    """Our closed forms against scipy.signal.chirp (same Tukey window): equal to float rounding."""
    ref = parse_reference(f"{kind}:19000-29000:0.05")
    x = reference_waveform(reference_replica(ref), FS)
    u = np.arange(len(x)) / FS
    y = chirp_ping(u, f0=19e3, f1=29e3, duration_s=0.05, method=method)
    # 1e-9: phases of ~3000 rad in float64
    np.testing.assert_allclose(x, y / np.max(np.abs(y)), atol=1e-9)


def test_hfm_coupling_is_a_shift_and_the_ridge_of_the_crlb():
    """s((1+ε)t) = s(t + δ)·e^{jψ} for an HFM, δ = (1 − 1/(1+ε))/k; the CRLB's ridge slope is −1/k."""
    ref = parse_reference("hfm:19000-29000:0.05")
    rep = reference_replica(ref)
    eps = 2e-3
    delta = float(hfm_coupling_s(ref, eps))
    k = (29e3 - 19e3) / (29e3 * 0.05)
    assert delta == pytest.approx((1 - 1 / (1 + eps)) / k, rel=1e-12)
    # inside the window's flat part the two analytic signals differ by one constant phase
    t = np.linspace(0.01, 0.035, 2000)
    a = rep.envelope((1 + eps) * t) * np.exp(2j * np.pi * rep.centre_hz * (1 + eps) * t)
    b = rep.envelope(t + delta) * np.exp(2j * np.pi * rep.centre_hz * (t + delta))
    ratio = a / b
    np.testing.assert_allclose(ratio, ratio[0], atol=1e-9)
    assert reference_crlb(rep).ridge_slope_s == pytest.approx(-1 / k, rel=1e-3)  # numerical Fisher matrix


def test_delay_crlb_matches_the_closed_form_for_a_flat_spectrum():
    """Rectangular LFM, large BT: spectrum ≈ flat over B, β = B/√12 → σ_τ = 1/(2π β √(2E/N0)) (SPEC §6)."""
    ref = ReferenceWaveform(kind="lfm", f_low_hz=19e3, f_high_hz=29e3, duration_s=0.2, window="rect")
    bound = reference_crlb(reference_replica(ref))
    beta = 10e3 / math.sqrt(12)
    e_n0 = 1000.0
    _, _, sigma_known = bound.at(e_n0)
    # 2 %: the Fresnel ripples of a finite-BT (2000) chirp's spectrum
    assert sigma_known == pytest.approx(1 / (2 * np.pi * beta * math.sqrt(2 * e_n0)), rel=0.02)


def test_pn_ping_is_the_m_sequence():
    """The PN envelope at the chip centres carries scipy's m-sequence: right signs, correlation near 1.

    An SRRC pulse alone is not a Nyquist pulse (only SRRC ⊗ SRRC is), so the
    samples are ±(peak ± ISI), not exactly ±1.
    """
    ref = parse_reference("pn:24000:5000:7")
    rep = reference_replica(ref)
    tc = (4 + np.arange(127)) / 5000.0
    chips = np.real(rep.envelope(tc))
    expected = 1.0 - 2.0 * scipy.signal.max_len_seq(7)[0]
    assert np.all(np.sign(chips) == expected)
    rho = chips @ expected / (np.linalg.norm(chips) * np.linalg.norm(expected))
    assert rho > 0.98  # measured 0.99: the ISI of one SRRC pulse at α = 0.5
    assert np.max(np.abs(np.imag(rep.envelope(tc)))) < 1e-12  # BPSK on the band's centre: a real envelope
