"""Reference waveforms other than seamodem's frame: LFM and HFM chirps, m-sequence pings, templates.

A :class:`ReferenceWaveform` is a frozen, validated configuration (JSON/TOML
round trip). Every reference is handled through its analytic signal
s_a(t) = b(t) e^{j2π f_c t}, f_c the centre of its band [f_low, f_high] and b
the complex envelope, defined for 0 ≤ t ≤ duration (zero outside):

* ``lfm``: b(t) = w(t) e^{j2π(f_low − f_c) t + jπ (B/T) t²} (down-sweep mirrored);
* ``hfm``: instantaneous frequency f(t) = f_0 / (1 − k t), f_0 = f_low,
  k = (f_high − f_low)/(f_high T) (down-sweep: f_0 = f_high, k < 0),
  phase φ(t) = −(2π f_0 / k) ln(1 − k t);
* ``pn``: a maximal-length sequence of 2^m − 1 chips (``scipy.signal.max_len_seq``),
  ±1 BPSK, SRRC-shaped at the chip rate, on a carrier;
* ``template``: an excerpt of a recording (WAV or ``.mat``), any waveform.

Doppler is a time scale (SPEC §1): the received reference is
s((1 + ε)(t − t_a)), ε = v_r/c.

HFM delay–Doppler coupling
--------------------------
An HFM is Doppler invariant: s((1 + ε) t) = s(t + δ(ε)) e^{jψ}, up to its
envelope, with δ(ε) = (1 − 1/(1 + ε))/k ≈ ε/k (:func:`hfm_coupling_s`). A
replica matched at the wrong scale still correlates fully, but its peak sits
δ early: the arrival time and the Doppler scale lie on one ridge, and an error
Δε in the Doppler becomes an error Δε/k in the arrival time. The receiver
measures the pair jointly on the ridge (time-scaled replicas, so the
correction t_a = t_peak + δ(ε) is built in), and the bounds are the joint ones
(:func:`reference_crlb`); a pre/postamble pair of known spacing gives ε
independently of the ridge (their common offset cancels in the spacing).

The module gathers three (every name importable from here): :mod:`.reference_waveform`
(the description, its files and compact form, packets), :mod:`.replica` (replicas,
envelope tables, CRLB) and :mod:`.reference_beacon` (the beacon writer).
"""

from __future__ import annotations

from .reference_beacon import emission_times, write_reference_beacon
from .reference_waveform import (  # noqa: F401  (PN_SPAN: importable, not in __all__)
    PN_SPAN,
    REFERENCE_KINDS,
    REFERENCE_SIDECAR_FORMAT,
    WINDOWS,
    ReferenceWaveform,
    load_references,
    parse_reference,
)
from .replica import ReferenceBound, Replica, hfm_coupling_s, reference_crlb, reference_replica, reference_waveform

__all__ = [
    "REFERENCE_KINDS",
    "WINDOWS",
    "ReferenceWaveform",
    "Replica",
    "parse_reference",
    "load_references",
    "reference_waveform",
    "reference_replica",
    "hfm_coupling_s",
    "reference_crlb",
    "ReferenceBound",
    "REFERENCE_SIDECAR_FORMAT",
    "emission_times",
    "write_reference_beacon",
]
