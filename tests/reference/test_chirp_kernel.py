"""The compiled chirp replica (transmit/_chirp_kernel.py) against the numpy forms of the envelope and its derivative."""

from __future__ import annotations

import numpy as np
import pytest

from seamodem.transmit.reference import ReferenceWaveform, reference_replica


@pytest.mark.parametrize("kind", ["lfm", "hfm"])
@pytest.mark.parametrize("down", [False, True])
@pytest.mark.parametrize("window, taper", [("tukey", 0.1), ("tukey", 0.0), ("hann", 0.1), ("rect", 0.1)])
def test_compiled_replica_matches_numpy_envelope(kind, down, window, taper):
    ref = ReferenceWaveform(kind=kind, name="r", f_low_hz=19000.0, f_high_hz=29000.0, duration_s=0.05, window=window,
                            taper=taper, down=down)
    rep = reference_replica(ref)
    t_a, eps, carrier = 123.4567, -1.7e-3, 23_950.0
    t = t_a - 0.002 + np.arange(1200) / 16_000.0  # before, across and after the ping (zero outside)
    q, dq = rep.scaled_with_derivative(t, t_arrival_s=t_a, eps=eps, carrier_hz=carrier)
    # the numpy forms: q = b(u) e^{j2π(f_c u − f_rx t)}, ∂q/∂u = (b'(u) + j2π f_c b(u)) e^{…}
    u = (1 + eps) * (t - t_a)
    rot = np.exp(2j * np.pi * (rep.centre_hz * u - carrier * t))
    b = rep.envelope(u)
    q_ref, dq_ref = b * rot, (rep.derivative(u) + 2j * np.pi * rep.centre_hz * b) * rot
    # phases of ~2e7 rad at t = 123 s: the two orders of operations agree to ~1e-8 of the amplitude
    assert np.max(np.abs(q - q_ref)) < 1e-7
    assert np.max(np.abs(dq - dq_ref)) < 1e-7 * np.max(np.abs(dq_ref))
    assert np.all(q[u < 0] == 0) and np.all(q[u > ref.duration_s] == 0)
    np.testing.assert_array_equal(rep.scaled(t, t_arrival_s=t_a, eps=eps, carrier_hz=carrier), q)
