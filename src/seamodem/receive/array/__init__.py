"""Multichannel reception: direction of arrival per frame and maximal-ratio combining (issue 17).

:func:`receive_array` takes every channel through the receiver's front end,
detects on all channels at once (:class:`ArrayDetector`) and, per frame,
correlates every channel with the frame's pilot as an *analytic passband*
waveform, Doppler-scaled by the detection's speed (on the decimated basebands,
:func:`baseband_correlation`; :func:`array_correlation` is the same on
passband samples):

    c_k(δ) = Σ_n x_k(t_n) r*(t_n − δ),   r(t) = b((t − t_a)(1 + v/c)) e^{j2π f0 (t − t_a)(1 + v/c)},

evaluated at any lag δ by its band-limited Fourier sum. A plane wave from the
unit direction u (body frame, towards the source) reaches element p_k at
δ_k = t0 − p_k·u / c, and near its peak c_k(δ) ≈ A_k e^{j2π f0 (δ − δ_k)}.

1. Wideband (ambiguity-free): each channel's envelope peak |c_k| gives a
   coarse δ_k; a least-squares plane wave through them gives t0 and u.
2. Carrier phase: at the plane-wave lags, arg c_k turns the coarse delays
   into fine ones, δ_k = δ̂_k − arg(c_k)/(2π f0) (the common phase goes into
   t0); the carrier period (36 µs at 28 kHz) is resolved because the
   wideband step is within a fraction of it. Weighted Gauss–Newton on
   (t0, azimuth, elevation), repeated until the lags stop moving.
3. σ: the Cramér–Rao bound of this model at the measured per-channel SNR,
   cov = (Jᵀ W J)⁻¹, W_k = 2 |c_k|² (2π)² (f0² + β²) / σ²_{c,k} with σ²_{c,k}
   the noise variance of c_k from the noise just before the frame (the
   envelope's share, β²/f0² ≈ 0.5 %, is counted in the bound), inflated by
   the fit's misfit when its χ² exceeds its degrees of freedom.

Combining: each channel's baseband is advanced by its direct-path lag and
weighted by conj(c_k)/σ²_{c,k} (maximal-ratio combining), scaled so that the
combined noise level equals the reference channel's; the single-hydrophone
receiver's measurement and decoding then run once on the combined frame.

Flat and linear arrays (:func:`array_geometry`): the mirror image through a
flat array's plane, or the cone about a line, fits as well as the truth; an
assumption (beacon below the plane; beacon to port at elevation 0) picks one,
and the estimate states it (``DoaEstimate.ambiguity``).

Array geometry and angles: :mod:`seamodem.channel.array` (body frame x
forward, y port, z up; azimuth atan2(u_y, u_x), elevation asin(u_z)). The
receiver uses the *nominal* element positions and removes the array's
``complex_gains`` (its calibration, :func:`calibrate_array`).

One module per job, every name importable from this package:

- :mod:`.correlation`: the pilot correlations c_k (:class:`ArrayCorrelation`,
  :func:`array_correlation`, :func:`baseband_correlation`);
- :mod:`.geometry`: unit vectors, volume / planar / linear arrays and their
  ambiguity (:func:`array_geometry`);
- :mod:`.doa`: the direction of arrival (:func:`estimate_doa`, steps 1–3);
- :mod:`.detector`: detection on every channel at once (:class:`ArrayDetector`);
- :mod:`.frontend`: every channel's basebands, impulses blanked as on the
  reference channel (:func:`front_end_array`);
- :mod:`.combine`: maximal-ratio combining (:func:`combine_channels`,
  :func:`~.combine.mrc_weights`);
- :mod:`.receiver`: the orchestration (:func:`receive_array`,
  :func:`receive_array_file`), which hands each frame to the
  single-hydrophone receiver's per-frame stage
  (:class:`~seamodem.receive.frame.FrameMeasurer`);
- :mod:`.calibration`: channel gains, phases and element positions from
  frames of known direction (:func:`calibrate_array`).
"""

from .calibration import POSITION_PRIOR_M, calibrate_array
from .combine import COMBINE_PAD_S, COMBINE_RAMP_S, combine_channels, mrc_weights, splice_beam
from .correlation import (
    NOISE_GAP_S,
    NOISE_SEGMENT_S,
    WINDOW_MARGIN_S,
    ArrayCorrelation,
    array_correlation,
    baseband_correlation,
    fs_of,
)
from .detector import DETECTION_CHUNK_S, ArrayDetector
from .doa import (
    ECHO_FRACTION,
    ECHO_SEARCH_S,
    LAG_TOLERANCE_S,
    MAX_ECHOES,
    MAX_ITERATIONS,
    MAX_SNR,
    DoaEstimate,
    coarse_lags,
    correlation_snr,
    estimate_doa,
    later_paths,
)
from .frontend import BLANKER_BLOCK, blank_like_reference, front_end_array
from .geometry import MIN_AXIS_COMPONENT, ArrayGeometry, array_geometry, unit_vector
from .receiver import receive_array, receive_array_file

__all__ = [
    "ArrayCorrelation",
    "ArrayDetector",
    "ArrayGeometry",
    "DoaEstimate",
    "array_geometry",
    "baseband_correlation",
    "blank_like_reference",
    "front_end_array",
    "array_correlation",
    "estimate_doa",
    "combine_channels",
    "receive_array",
    "calibrate_array",
    "receive_array_file",
    "unit_vector",
]
