"""Ranging on any known waveform: LFM/HFM chirps, m-sequence pings, templates (issue 16).

The same steps as the frame receiver, with the frame's pilot replaced by a
:class:`~seamodem.transmit.reference.ReferenceWaveform`:

1. **Front end** (:class:`BandDecimator`): the frame receiver's
   frequency-domain front end (:mod:`~seamodem.receive.frontend`: one real FFT per block, the
   band's bins filtered and inverse-transformed at the decimated size) on the
   union of the references' bands: decimation costs the same at 384 kHz as
   at 96 kHz per input sample, memory stays a few blocks. DC and anything
   outside the band are removed here.
2. **Detection** (:class:`ReferenceDetector`): a bank of time-scaled replicas
   s_a((1 + ε_b) t) over |ε| ≤ v_max/c (wideband Doppler is a scale, not a
   frequency shift), spaced so that the loss between bins is at most 1 dB,
   correlated by FFT. As :mod:`~seamodem.receive.detect`: z = |c|²/σ_c² (Exp(1) in noise,
   σ_c² from the median), threshold η = ln(n_tests/rate) for a stated
   false-alarm rate per hour (:func:`~seamodem.receive.detect.z_threshold`),
   and ρ ≥ ρ_min (normalised correlation) against impulses; the first arrival
   is the earliest distinct peak within ``multipath_window_s`` that reaches
   ``first_path_fraction`` of the strongest.
3. **Fine fit** (:func:`fit_reference`): maximum likelihood of (t_a, ε) for
   r(t) = A e^{jθ} s_a((1 + ε)(t − t_a)) + w, |C(t_a, ε)| = |Σ r q*| with
   the replica evaluated at arbitrary times: ε by dichotomy
   (:func:`~seamodem.receive.doppler.dichotomy_max`, paper 002's bank +
   dichotomy), t_a by Gauss–Newton along the delay–Doppler ridge for each ε.
   Echoes: the replica's distinct correlation peaks, fitted jointly, the first
   arrival the earliest of 0.3× the strongest (a merged earlier path by a GLRT).
   A chirp (a ridge longer than its main lobe) takes ε from the joint
   multi-path likelihood over all of ±v_max/c (:meth:`PathFitter.scan_paths`).
4. **σ's**: the joint CRLB of the reference (:func:`~seamodem.transmit.reference.reference_crlb`)
   at the measured E/N0, inflated by √χ² of the fit's residual when echoes or
   a varying Doppler leave more than noise.
5. **Pairs** (:func:`pair_up`, :func:`pair_doppler`): a preamble and a postamble
   of known spacing T_sp give ε = T_sp/Δ − 1 from their measured spacing Δ, using
   each ping's ridge coordinate so that the delay–Doppler coupling cancels, and
   allowing for a Doppler change over the packet.

Modules, one seam each (as the frame receiver's): :mod:`.band` (band plan and
front end), :mod:`.detect` (the replica bank), :mod:`.paths` (the path
fitter), :mod:`.fit` (one detection's fine fit and σ's), :mod:`.records`
(fitted detections and their records), :mod:`.receiver` (the streaming
receiver, channel and reference selection), :mod:`.pairing` (pre/postamble
pairs). Its settings are :class:`~seamodem.receive.settings.ReferenceSettings`.
Every name is importable from here.
"""

from ..settings import MAX_ACCEL_MPS2, MIN_RHO, ReferenceSettings
from .band import BandDecimator, BandPlan, plan_band
from .detect import ReferenceDetection, ReferenceDetector, replica_samples
from .fit import DOPPLER_THRESHOLD, MISFIT_LIMIT, NOISE_GAP_S, NOISE_WINDOW_S, ReferenceFit, fit_reference
from .pairing import pair_doppler, pair_up
from .paths import (
    EARLY_WINDOW_S,
    EARLY_Z,
    ECHO_WINDOW_S,
    ECHO_Z,
    FIRST_PATH_FRACTION,
    MAX_ECHOES,
    SCAN_POINTS,
    SCAN_STEPS,
    PathFitter,
)
from .receiver import ReferenceReceiver, best_per_detection, keep_matching_reference
from .records import REFERENCE_FIELDS, FittedPing, ReferenceRecord, to_record

__all__ = [
    "BandPlan",
    "plan_band",
    "BandDecimator",
    "ReferenceDetector",
    "ReferenceDetection",
    "ReferenceFit",
    "fit_reference",
    "ReferenceRecord",
    "REFERENCE_FIELDS",
    "pair_doppler",
    "ReferenceReceiver",
    "ReferenceSettings",
    "best_per_detection",
    "keep_matching_reference",
    "pair_up",
    "to_record",
    "FittedPing",
    "PathFitter",
    "replica_samples",
    "DOPPLER_THRESHOLD",
    "MISFIT_LIMIT",
    "MIN_RHO",
    "MAX_ACCEL_MPS2",
    "NOISE_GAP_S",
    "NOISE_WINDOW_S",
    "ECHO_WINDOW_S",
    "EARLY_WINDOW_S",
    "FIRST_PATH_FRACTION",
    "MAX_ECHOES",
    "ECHO_Z",
    "SCAN_POINTS",
    "SCAN_STEPS",
    "EARLY_Z",
]
