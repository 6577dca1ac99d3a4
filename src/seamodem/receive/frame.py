"""Per-frame measurement: one detected frame in its baseband window → one measurement record.

The stage every receiver of seamodem frames shares: the streaming
:class:`~seamodem.receive.stream.Receiver` hands it each detection whose span
has arrived, with the basebands around it (:class:`BasebandBuffers`); the
array receiver (:mod:`seamodem.receive.array`) hands it the combined
basebands of each frame. :class:`FrameMeasurer` measures the frame
(:func:`~seamodem.receive.measure.measure_frame`: arrival, Doppler, SNR),
decodes it when asked (:mod:`.demodulate`), picks the direct path's Doppler
and arrival (tone, pilot bank or the whole-frame fit, :mod:`.wholeframe`),
ties it to its emission and writes the :class:`~seamodem.receive.records.MeasurementRecord`.

:func:`receiver_front_end` and :func:`detector_options` turn the
:class:`~seamodem.receive.settings.ReceiverSettings` into the front end,
impulse blanker and detector options, once for every receiver.
"""

from __future__ import annotations

import cmath
import collections
import dataclasses
import math
import warnings
from typing import NamedTuple
from collections.abc import Callable

import numpy as np

from ..config import FrameConfig
from ..transmit.frame import build_frame
from ..transmit.modulation import constellation, nearest_labels
from ..transmit.pilot import pilot_symbols
from .bounds import delay_crlb_s, pilot_velocity_crlb_mps, tone_velocity_crlb_mps
from .demodulate import FrameDecode, demodulate, payload_fields
from .detect import Detection
from .echo_geometry import GEOMETRY_MIN_GAIN, ImageDepths, grazing, pooled_depths
from .frontend import FrontEndPlan, plan_front_end
from .impulse import ImpulseBlanker
from .measure import FrameMeasurement, frame_span_s, impulse_excess, measure_frame
from .multipath import direct_path_index, find_echoes, sidelobe_pull_s
from .records import MeasurementRecord
from .settings import Emissions, ReceiverSettings
from .two_way import two_way_range_m
from .wholeframe import (EARLIER_NEAREST_B, WholeFrameFit, channel_bend_s2, fit_whole_frame, joint_delay_inflation,
                         joint_delay_sigma_s, srrc_spectrum)

__all__ = [
    "BasebandBuffers",
    "FrameMeasurer",
    "ReceiverWarning",
    "RecordLookahead",
    "detector_options",
    "direct_path_share",
    "one_blas_thread",
    "receiver_front_end",
    "tone_fallback_sigma_mps",
    "bank_echo_sigma_mps",
    "earlier_path_gap_s",
    "missed_direct_lag_s",
    "earlier_fitted_direct",
    "earlier_standing_out",
    "merged_image_delay_s",
    "merged_image_bias_s",
    "two_carrier_sigma_mps",
    "time_scale_delay_s",
    "unmodelled_sigmas",
    "channel_shape_delay_s",
    "kinematic_gaps",
    "gap_excess",
    "range_gaps",
]

_BLAS = None


def one_blas_thread():
    """Context: one BLAS thread while a frame is measured and decoded.

    The receiver's linear algebra is many small products; OpenBLAS's second thread busy-waits after each
    of them. Measured on 10 deep-echo frames (12 dB, decoding on): 172–188 → 95 ms CPU per frame with the
    records bit-identical; on the demo's 60 s recording the wall time did not change (4.7 s). The limit is
    set per frame, never across a ``yield``, so the caller's own BLAS is untouched.

    Returns
    -------
    contextlib.AbstractContextManager
        threadpoolctl's limit: BLAS runs on one thread inside the ``with`` block.
    """
    global _BLAS
    if _BLAS is None:
        from threadpoolctl import ThreadpoolController

        _BLAS = ThreadpoolController()
    return _BLAS.limit(limits=1, user_api="blas")


class ReceiverWarning(UserWarning):
    """A degraded but usable result (clipped input, no frame found, truncated frame...)."""


def receiver_front_end(config: FrameConfig, fs: float, settings: ReceiverSettings
                       ) -> tuple[FrontEndPlan, ImpulseBlanker | None]:
    """The front end's plan and the impulse blanker the settings ask for.

    Parameters
    ----------
    config : FrameConfig
        The transmitted frame (its bands).
    fs : float
        The recording's sample rate [Hz].
    settings : ReceiverSettings
        ``v_max_mps`` and ``sound_speed_mps`` (the bands' Doppler margin),
        ``blank_impulses`` and ``impulse_threshold``.

    Returns
    -------
    plan : FrontEndPlan
        Bands, decimations and basebands' rates [Hz].
    blanker : ImpulseBlanker or None
        A new blanker, or None when impulses are kept.
    """
    s = settings
    plan = plan_front_end(config, fs, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps,
                          block_target=s.front_end_block)
    blanker = ImpulseBlanker(threshold=s.impulse_threshold) if s.blank_impulses else None
    return plan, blanker


def detector_options(settings: ReceiverSettings, pilot: np.ndarray) -> dict:
    """Keyword arguments of a pilot detector (:class:`~seamodem.receive.detect.PilotDetector`) from the settings.

    Parameters
    ----------
    settings : ReceiverSettings
        ``v_max_mps`` [m/s], ``sound_speed_mps`` [m/s] and ``false_alarms_per_hour`` [1/h].
    pilot : numpy.ndarray
        Pilot symbols.

    Returns
    -------
    dict
        ``v_max_mps``, ``sound_speed_mps``, ``false_alarms_per_hour`` and ``pilot``.
    """
    s = settings
    return dict(v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps,
                false_alarms_per_hour=s.false_alarms_per_hour, pilot=pilot)


#: a fit on decisions is not used when its direct-path Es/N0 is below this share of the measured SNR's
_DECISIONS_MIN_ES_N0_SHARE = 0.1
#: a fit on decisions whose speed moves by more than this share of a tilt given to its reference
#: (:func:`decisions_follow`), or against it, stands on which decisions the tilt flips, not on the frame:
#: it is taken as decisions that do not explain the frame. Measured (session 21; corpus, fading and impulsive
#: families, 40 recordings, 76 rows on decisions): λ 0.5–1.3 on most fits, whose σ was right (RMS err/σ
#: 0.8); the 29 fits beyond [0, 1.5] had RMS err/σ 1.7 with their own σ, one at 7.2σ (a DFE that had
#: locked onto noise: raw BER 0.43, its output SNR 6.6 dB above the input's)
_DECISIONS_MAX_FOLLOW = 1.5
#: decoded frames whose echoes pull a later undecoded frame's pilot arrival (``pooled_pilot_pull_s``)
_ECHO_POOL_FRAMES = 5


def _root_mean_excess(gaps) -> float:
    """√ of the mean of squared gaps less their σ's (unbiased, unclipped), clipped at 0; 0 with none."""
    return math.sqrt(max(0.0, float(np.mean(gaps)))) if len(gaps) else 0.0


#: the pilot bank's σ column takes the error its gaps to the last decoded frames' fits show once this many are in
#: (``FrameMeasurer.bank_excess_mps``; before, the bound of the echoes a frame's fit shows over the pilot)
BANK_GAP_MIN_FRAMES = 3


def direct_path_share(m: FrameMeasurement) -> float:
    """The first path's share of the power of the paths resolved in the pilot (1 for a lone path).

    The in-band SNR (SPEC §1) counts every path as signal; an estimate of the
    first path alone (the pilot's arrival, the pilot bank with the echoes
    removed) has only this share of it.

    Parameters
    ----------
    m : FrameMeasurement
        The frame's measurement: its echoes (else its resolved paths).

    Returns
    -------
    float
        |a_first|² / Σ |a_p|², at least 1e-3 (1 for a lone path).
    """
    paths = m.echoes if m.echoes is not None else m.paths
    power = np.abs(np.asarray(paths.amplitudes)) ** 2
    if power.size < 2 or not np.all(np.isfinite(power)) or power.sum() <= 0:
        return 1.0
    return float(max(power[direct_path_index(paths)] / power.sum(), 1e-3))


#: a component of a decoded frame's residual before the direct path (``WholeFrameFit.earlier_path``) is a direct
#: path the pilot's fit missed when its |amplitude|² stands this many times its noise expectation out ...
MISSED_DIRECT_Z2 = 30.0
#: ... and its amplitude is at least this share of the path taken as the direct one
MISSED_DIRECT_GAIN = 0.2


def missed_direct_lag_s(wf: WholeFrameFit, first: int) -> float | None:
    """How far before the path taken as the direct one [s] (< 0) a decoded frame's residual holds another
    path, None when it holds none (``WholeFrameFit.earlier_path``, sought from 3/B to a pilot's length before).

    Nothing arrives before the direct path, so a component there that stands :data:`MISSED_DIRECT_Z2`
    times its noise expectation out (per lag e^{−30}: the window's ~320 lags at jmse2024 leave it about
    3e−11 of frames in Gaussian noise) and is at least :data:`MISSED_DIRECT_GAIN` of the path taken is the
    direct path itself, which the pilot's 23 ms did not show above its threshold. The corpus's far family
    at 4 dB (a surface image −0.92 at 33 µs, near its null): the pilot's fit took the bottom echo, 0.62 m
    late with σ 69 mm (9σ); the whole frame's residual held the direct pair 740–894 times its noise,
    0.85 of the path taken. The 235 decoded frames of 24 other fresh corpus recordings (every family) held
    at most 22 times it there, median 8, and 0.06 of the direct path
    (:func:`~seamodem.receive.wholeframe.earlier_path`, 3/B and more before the direct path).
    """
    found = wf.earlier_path
    if found is None:
        return None
    lag, amp, z2 = found
    a0 = abs(complex(wf.amplitudes[first]))
    if not (math.isfinite(lag) and lag < 0 and z2 >= MISSED_DIRECT_Z2 and abs(amp) >= MISSED_DIRECT_GAIN * a0):
        return None
    return float(lag)


def earlier_fitted_direct(wf: WholeFrameFit, first: int, config: FrameConfig) -> int | None:
    """The earliest path of a decoded frame's whole-frame fit at least 3/B (``EARLIER_NEAREST_B``) before the
    path taken as the direct one (``first``) that stands out over the whole frame (n·Es/N0, its |amplitude|²
    over its noise expectation, at least :data:`MISSED_DIRECT_Z2`, and :data:`MISSED_DIRECT_GAIN` of the path
    taken); None when there is none.

    The pilot's fit takes the earliest path at least 0.3 of the strongest; a weaker one before it is a faded
    direct path or noise, which the pilot alone cannot tell (:func:`earlier_path_gap_s`: the arrival's σ
    covers the gap). The whole frame can: the corpus's far recording 6920412038, 14 dB, frame 9: the pilot's
    fit had a path 8.3 ms early at 0.18 of the strongest, whose σ made the range's 12.4 m (error 7.9 mm);
    fitted over the decoded frame it stood 2 times its noise expectation, 0.007 of the direct path.
    """
    a0 = abs(complex(wf.amplitudes[first]))
    if not a0 > 0:
        return None
    taken = np.flatnonzero(earlier_standing_out(wf, first, config)
                           & (np.abs(np.asarray(wf.amplitudes)) >= MISSED_DIRECT_GAIN * a0))
    return int(taken[np.argmin(wf.delays_s[taken])]) if taken.size else None


def earlier_standing_out(wf: WholeFrameFit, first: int, config: FrameConfig) -> np.ndarray:
    """Which paths of a whole-frame fit lie at least 3/B (``EARLIER_NEAREST_B``) before ``first`` and stand out
    over the whole frame (n·Es/N0 at least :data:`MISSED_DIRECT_Z2`); nearer, a merged echo's misfit stands
    out too (:func:`~seamodem.receive.wholeframe.earlier_path`)."""
    return (((wf.delays_s[first] - wf.delays_s) * config.bandwidth_hz >= EARLIER_NEAREST_B)
            & (wf.n_reference * np.asarray(wf.es_n0, float) >= MISSED_DIRECT_Z2))


def earlier_path_gap_s(m: FrameMeasurement) -> float:
    """How far before the path taken as the direct one the earliest path the pilot fit found lies [s]
    (0 when it is the earliest).

    The direct path is the earliest path at least 0.3 of the strongest
    (:func:`~seamodem.receive.multipath.fit_paths`): an earlier, weaker one is
    an echo's precursor only in noise, and otherwise the direct path faded
    (Rician fading, a notch) below the echoes. The frame cannot say which, so
    the arrival's σ covers the gap (a faded direct path at −2 dB taken 1.3–
    4.5 ms late: 2–7 m off with σ 6–16 cm before).
    """
    paths = m.echoes if m.echoes is not None else m.paths
    delays = np.asarray(paths.delays_s, dtype=float)
    if delays.size == 0:
        return 0.0
    return max(0.0, float(own_arrival_s(paths) - np.min(delays)))


def own_arrival_s(paths) -> float:
    """The direct path's arrival [s] in a pilot fit's own paths (:func:`direct_path_index`).

    The echoes' search (:func:`~seamodem.receive.multipath.find_echoes`) fits the direct path again with them
    and keeps the arrival fit's ``first_s`` (the origin of the pilot's outputs): the direct path's own delay
    there moves by up to a few µs (the corpus's steep family: −1.6 to +0.6 µs). Read against ``first_s``, a
    direct path refitted earlier was its own precursor, and its gap the largest term of the range's σ on 25
    of the steep family's 80 whole-frame rows logged on one seed (0.05–3.1 mm, errors within 1.5 mm)."""
    return float(np.asarray(paths.delays_s, dtype=float)[direct_path_index(paths)])


def merged_image_delay_s(range_m: float, beacon_depth_m: float, vehicle_depth_m: float, *,
                         config: FrameConfig, sound_speed_mps: float) -> float:
    """The surface image's extra delay when it is below the signal's resolution, else 0 [s].

    With the ends at depths z_b, z_v and the slant range R, the horizontal
    range is h = √(R² − (z_b − z_v)²) and the surface-reflected path is
    √(h² + (z_b + z_v)²): its extra delay δ ≈ 2·z_b·z_v/(R·c). Below 1/B
    (B = R_s·(1 + rolloff), 112 µs for jmse2024) the image merges with the
    direct path, H(f) = 1 + b·e^{−j2πfδ}: the arrival's group delay moves by
    δ·Re(w), w = b·e^{−j2πf₀δ}/(1 + b·e^{−j2πf₀δ}), while the channel's shape
    across the band shows δ·Im(w) only, below the noise in one frame. With
    |b| ≈ 0.8–0.98 and the phase f₀δ unknown (waves move it), δ itself is the
    honest scale (measured in the corpus's far family: errors 0.3–1.5 δ·c).
    An image resolved (δ ≥ 1/B) is the path fit's to separate: 0.

    Parameters
    ----------
    range_m : float
        Slant range (c·tof) [m]; not finite or not beyond the depths' difference: 0.
    beacon_depth_m, vehicle_depth_m : float
        Depths of the two ends [m].
    config : FrameConfig
        Symbol rate and roll-off (the resolution 1/B).
    sound_speed_mps : float
        c [m/s].
    """
    dz = beacon_depth_m - vehicle_depth_m
    if not (math.isfinite(range_m) and range_m > abs(dz)):
        return 0.0
    h = math.sqrt(range_m**2 - dz**2)
    delay = (math.hypot(h, beacon_depth_m + vehicle_depth_m) - range_m) / sound_speed_mps
    resolution = 1.0 / config.bandwidth_hz
    return delay if delay < resolution else 0.0


#: magnitude of the sea surface's coherent reflection at grazing incidence (sign −1): the Rayleigh roughness
#: loss exp(−2(k·h·sin θ)²) of 0.1–0.5 m waves at the angles where the image merges (sin θ < 0.02) is
#: below 20 %
SURFACE_REFLECTION = (0.8, 0.98)
#: surface elevation [m] the image's phase rides by default (waves of this amplitude; sea state 3:
#: ``ReceiverSettings.wave_amplitude_m``), and the ends' depths' σ [m] (a pressure sensor, a surveyed
#: mooring): both spread the image's carrier phase
WAVE_AMPLITUDE_M, DEPTH_SIGMA_M = 0.5, 0.1
#: the shortest period of waves that high [s] by default (steepness 0.07, a wind sea:
#: ``ReceiverSettings.wave_period_s``): the surface's vertical speed, 2π·a/T, moves the image's Doppler
WAVE_PERIOD_S = 3.0


def wave_doppler_mps(sin_grazing: float, wave_amplitude_m: float, wave_period_s: float) -> float:
    """RMS Doppler [m/s] the waves give a surface image relative to the direct path: 2·sin θ times the
    surface's RMS vertical speed, 2π·a/T/√2 (``MergedImage.wave_doppler_mps``)."""
    return 2 * sin_grazing * (2 * math.pi * wave_amplitude_m / wave_period_s / math.sqrt(2))


class MergedImage(NamedTuple):
    """What a surface image merged with the direct path does to it (:func:`merged_image_bias_s`)."""

    #: the arrival's bias [s] and its σ
    bias_s: float
    sigma_s: float
    #: the channel's curvature it makes, in ``WholeFrameFit.curvature_s2``'s units (d²ln H/df²/(2π)² [s²]),
    #: and that curvature's variance over what is not known [s⁴]
    curvature_s2: complex
    curvature_var_s4: float
    #: |Re w| and |Im w| (w = z/(1 + z)) at the geometry's δ and the middle of ρ: the image's Doppler relative
    #: to the direct path's, Δv, moves the sum's phase rate by Re(w)·Δv and its log-amplitude rate by Im(w)·Δv
    #: (in the same units)
    re_w: float = 0.0
    im_w: float = 0.0
    #: the image's Doppler relative to the direct path's that the waves can give it, RMS [m/s]: 2·sin θ times
    #: the surface's vertical speed (:data:`WAVE_AMPLITUDE_M` at :data:`WAVE_PERIOD_S`, 0.74 m/s RMS)
    wave_doppler_mps: float = 0.0
    #: the image's extra delay δ at the geometry [s] (:func:`merged_image_delay_s`; 0: no merged image)
    delay_s: float = 0.0
    #: True for an image the channel's pooled bend shows without the depths (:func:`bend_image`): only its
    #: Doppler term is known, nothing of it is taken out
    from_bend: bool = False

    def residual_bend(self, bend: complex, noise: float) -> tuple[complex, float]:
        """A measured bend (``WholeFrameFit.curvature_s2``, its noise expectation) less the image's mean bend,
        the image's variance added to the noise: what the bend bound counts (``_CurvaturePool``,
        :func:`channel_shape_delay_s`)."""
        return bend - self.curvature_s2, noise + self.curvature_var_s4


def merged_image_bias_s(range_m: float, beacon_depth_m: float, vehicle_depth_m: float, *, config: FrameConfig,
                        sound_speed_mps: float, wave_amplitude_m: float = WAVE_AMPLITUDE_M,
                        wave_period_s: float = WAVE_PERIOD_S, depth_sigma_m: float = DEPTH_SIGMA_M,
                        delay_sigma_s: float = 0.0) -> MergedImage:
    """The bias of the direct path's arrival that a merged surface image puts on it, its σ, and the bend
    it gives the channel [s, s, s², s⁴].

    The ends' depths give the image's extra delay δ (:func:`merged_image_delay_s`) and with it the image's
    carrier phase: the channel is H(f) = 1 + z·e^{−j2πfδ}, z = −ρ·e^{−j2πf₀δ}. An arrival fitted as one
    pulse is the peak of the matched filter's output, |∫ RC(f)·H(f)·e^{j2πfτ} df| over τ (RC: the
    raised-cosine spectrum of pulse and matched filter): about Re(w)·δ, w = z/(1 + z), which for
    ρ ≈ 0.9 is +0.4–0.47·δ over most of the phase, and large and early near the null (f₀δ near a whole
    number of cycles, where the two paths cancel). The bias is that peak's mean over what is not known:
    ρ over :data:`SURFACE_REFLECTION`, and the image's delay (and with it its phase) over the waves'
    ±2·a·sin θ of path (a = ``wave_amplitude_m``, θ the grazing angle) and over two σ of the depths'
    error (``depth_sigma_m``, default :data:`DEPTH_SIGMA_M`) and of δ's own (``delay_sigma_s``, depths
    inferred from the echoes: :mod:`.echo_geometry`); its σ is the peaks' spread over them. The channel's curvature it makes,
    d²ln H/df² = −(2πδ)²·w(1 − w), is the mean over the same (with its variance): the share of a measured
    bend (``WholeFrameFit.curvature_s2``) the image explains. All 0 when the image is resolved or the
    geometry is not given. The waves' amplitude and shortest period (``wave_period_s``) are
    :class:`~seamodem.receive.settings.ReceiverSettings`'s (default :data:`WAVE_AMPLITUDE_M`, 0.5 m, at
    :data:`WAVE_PERIOD_S`, 3 s).

    Examples
    --------
    Ends 3 m deep, 800 m apart: the image 15 µs behind, f₀δ = 0.42 cycles, away from the null (the
    waves move it by ±1.6 µs):

    >>> from seamodem import get_preset
    >>> image = merged_image_bias_s(800.0, 3.0, 3.0, config=get_preset("jmse2024"), sound_speed_mps=1500.0)
    >>> round(image.bias_s * 1e6, 1), round(image.sigma_s * 1e6, 1)  # [µs]
    (7.0, 2.0)
    """
    delta = merged_image_delay_s(range_m, beacon_depth_m, vehicle_depth_m, config=config,
                                 sound_speed_mps=sound_speed_mps)
    if not delta > 0:
        return MergedImage(0.0, 0.0, 0j, 0.0)
    c, f0 = sound_speed_mps, config.carrier_hz
    # the image's path moves with the surface where it reflects, by ±2·a·sin θ (the waves: uniform over it),
    # and δ ∝ z_b·z_v with the depths' error, by δ·σ_z·√(1/z_b² + 1/z_v²) (two σ each way); its carrier
    # phase 2π·f₀·δ moves with it
    sin_grazing = (beacon_depth_m + vehicle_depth_m) / max(range_m, 1e-9)
    waves = 2 * wave_amplitude_m * sin_grazing / c
    depths = 2 * delta * depth_sigma_m * math.hypot(1 / max(beacon_depth_m, depth_sigma_m),
                                                    1 / max(vehicle_depth_m, depth_sigma_m))
    deltas = np.maximum(delta + (waves + depths + 2 * delay_sigma_s) * np.linspace(-1.0, 1.0, 13), 0.0)
    rho = np.linspace(*SURFACE_REFLECTION, 3)
    z = -(rho[:, None] * np.exp(-2j * np.pi * f0 * deltas[None, :])).ravel()
    lags = np.broadcast_to(deltas[None, :], (len(rho), len(deltas))).ravel()
    rs, period = config.symbol_rate_hz, config.symbol_period_s
    f = np.linspace(-(1 + config.rolloff) * rs / 2, (1 + config.rolloff) * rs / 2, 161)
    rc = srrc_spectrum(f, period, float(config.rolloff)) ** 2 / period  # pulse × matched filter, peak 1
    # the matched filter's output around the paths, for every (ρ, phase): its peak on a grid, then a parabola
    reach = 2 * float(np.max(deltas)) + 10e-6
    taus = np.linspace(-reach, reach, 241)
    spectra = rc[None, :] * (1 + z[:, None] * np.exp(-2j * np.pi * f[None, :] * lags[:, None]))
    out = np.abs(spectra @ np.exp(2j * np.pi * f[:, None] * taus[None, :]))
    i = np.clip(np.argmax(out, axis=1), 1, len(taus) - 2)
    rows = np.arange(len(z))
    ym, y0, yp = out[rows, i - 1], out[rows, i], out[rows, i + 1]
    den = ym - 2 * y0 + yp
    step = np.where(den < 0, 0.5 * (ym - yp) / np.where(den < 0, den, -1.0), 0.0)
    peaks = taus[i] + np.clip(step, -0.5, 0.5) * (taus[1] - taus[0])
    # the bend the whole-frame fit reads from each (its sub-band parabolas: near the null ln H is no parabola
    # over the band, and the fit's c exceeds −δ²·w(1 − w), the curvature at f₀, by 5–50 %; an analytic frame
    # near the null reads channel_bend_s2's value: tests/receive/test_channel_bend.py)
    f_fine = np.linspace(f[0], f[-1], 641)
    curvature = channel_bend_s2(f_fine, srrc_spectrum(f_fine, period, float(config.rolloff)) ** 2,
                                1 + z[:, None] * np.exp(-2j * np.pi * f_fine[None, :] * lags[:, None]))
    mean = complex(np.mean(curvature))
    z0 = -float(np.mean(SURFACE_REFLECTION)) * cmath.exp(-2j * math.pi * f0 * delta)
    w0 = z0 / (1 + z0)
    re_w, im_w = abs(w0.real), abs(w0.imag)
    if delay_sigma_s > 0 and f0 * float(np.ptp(deltas)) > 0.25:
        # the image's phase not known within a quarter of a carrier cycle (depths from the echoes): |Re w| and
        # |Im w| as for a phase unknown (bend_image's), not at δ's middle (a far recording at 14.5 dB, δ from
        # the echoes: v_r 6.6σ off at the middle's |Re w / Im w|, 4.3σ with the bend's)
        re_w, im_w = _BEND_RE_W, _BEND_RE_W / _BEND_RE_IM
    return MergedImage(float(np.mean(peaks)), float(np.std(peaks)), mean,
                       float(np.mean(np.abs(curvature - mean) ** 2)),
                       re_w=re_w, im_w=im_w,
                       wave_doppler_mps=wave_doppler_mps(sin_grazing, wave_amplitude_m, wave_period_s),
                       delay_s=delta)


#: a merged surface image's |w(1 − w)| and |Re w| (w = z/(1 + z), z = −ρ·e^{−j2πf₀δ}) over its unknown phase:
#: their medians over the phase at ρ 0.8, 0.89 and 0.98 (:data:`SURFACE_REFLECTION`) are 0.49–0.50 and
#: 0.42–0.49 (:func:`bend_image`)
_BEND_W_1MW, _BEND_RE_W = 0.5, 0.46
#: |Re w / Im w| a bend's image is taken to have (:func:`bend_image`): its Doppler term reads the direct
#: path's log-amplitude rate as up to twice that in phase rate, within the waves' bound. Its phase unknown,
#: the ratio is spread from 0.16 to 6.3 (10–90 %, ρ 0.89), below 2 at 70 % of phases. Measured on the
#: corpus's far family without the depths (two seeds, 15 recordings each; 1 is no term): within 3σ
#: 0.942 / 0.986 / 1.000 / 1.000 at 1 / 2 / 3 / ∞ and 0.971 / 0.979 / 0.993 / 1.000, median σ/RMS error
#: 0.77 / 0.87 / 1.16 / 2.90 and 0.78 / 1.38 / 2.05 / 3.37: beyond 2, σ grew to several times the errors
_BEND_RE_IM = 2.0


def bend_image(merge_delay_s: float, range_m: float, *, config: FrameConfig, sound_speed_mps: float,
               wave_amplitude_m: float = WAVE_AMPLITUDE_M, wave_period_s: float = WAVE_PERIOD_S
               ) -> MergedImage | None:
    """Without the ends' depths: the surface image a channel bend pooled over recent frames shows, as far as
    its Doppler term goes (:func:`image_doppler_sigma_mps`); None when the pool shows no bend.

    The pool's bias bound (``_CurvaturePool.delay_s``, the σ of a uniform spread over |c̄|^½) gives the
    echo's delay: |c| = δ²·|w(1 − w)|, and |w(1 − w)| is about ½ over most of the image's phase, so
    δ ≈ √3·σ/√½ (at most the resolution 1/B). A surface image that far behind at the slant range R has its
    ends' depths' product δ·R·c/2, and its grazing angle is least when the depths are equal:
    sin θ ≥ √(2·c·δ/R). The waves move such an image by 2·sin θ times the surface's vertical speed
    (``wave_amplitude_m`` at ``wave_period_s``, as :func:`merged_image_bias_s`), the sum's phase rate by
    |Re w| of that (its median, 0.46) and its log-amplitude rate by |Im w|. With the phase unknown, the
    amplitude's rate counts up to :data:`_BEND_RE_IM` (2) times as a phase rate, within that bound: the
    image's Doppler term (:func:`image_doppler_sigma_mps`). With the depths it is
    :func:`merged_image_bias_s`'s instead. Nothing else of it is used: its bias stays in the bend bound.

    Measured on the corpus's far family without the depths: v_r 3–6 mm/s off with σ 0.8–1.4 mm/s at
    15–18 dB, where the bend was pooled and the waves turned the image's phase; within 3σ 0.942 → 0.986
    and 0.971 → 0.979 on two seeds (docs/performance.md).

    >>> from seamodem import get_preset
    >>> image = bend_image(8.5e-6, 877.0, config=get_preset("jmse2024"), sound_speed_mps=1500.0)
    >>> round(image.delay_s * 1e6, 1), round(image.re_w * image.wave_doppler_mps * 1e3, 1)  # [µs], [mm/s]
    (20.8, 5.7)
    >>> bend_image(0.0, 877.0, config=get_preset("jmse2024"), sound_speed_mps=1500.0) is None
    True
    """
    if not (merge_delay_s > 0 and math.isfinite(range_m) and range_m > 0):
        return None
    delta = min(math.sqrt(3.0 / _BEND_W_1MW) * merge_delay_s, 1.0 / config.bandwidth_hz)
    sin_grazing = min(1.0, math.sqrt(2 * sound_speed_mps * delta / range_m))
    return MergedImage(0.0, 0.0, 0j, 0.0, re_w=_BEND_RE_W, im_w=_BEND_RE_W / _BEND_RE_IM,
                       wave_doppler_mps=wave_doppler_mps(sin_grazing, wave_amplitude_m, wave_period_s),
                       delay_s=delta, from_bend=True)


#: the direct path's κ (``joint_delay_inflation``) beyond which other fitted paths couple to its arrival, and
#: the surface image alone does not predict its bias: its delay δ is then the σ, not its bias taken out. Measured
#: on the corpus's far family with the depths (two seeds, 300 rows each): at κ 1.05–1.5 (111 and 51 rows, paths
#: about 1.6–2.2/B from the direct one) the image's bias taken out left every range within 3σ (worst 1.3σ),
#: the range σ's median 23–25 → 11–15 mm; at κ 1.5–2, one row in 34 and one in 20 at 3.2σ. (1.05 before: the
#: whole-frame fit's joint-step trigger, borrowed without a measurement.)
_IMAGE_ALONE_KAPPA = 1.5


def direct_path_kappa(delays_s, amplitudes, first: int, config: FrameConfig, *, v_mps=None,
                      sound_speed_mps: float = 1500.0) -> float:
    """κ ≥ 1 of the direct path ``first`` among fitted paths (``joint_delay_inflation``; a whole-frame fit's,
    with its Doppler, or the pilot's): 1 when no other path couples to it."""
    if len(delays_s) < 2:
        return 1.0
    return float(joint_delay_inflation(delays_s, amplitudes, config=config, v_mps=v_mps,
                                       sound_speed_mps=sound_speed_mps)[first])


def amp_rate_mps(rate_hz: float, config: FrameConfig, *, sound_speed_mps: float) -> float:
    """A log-amplitude rate [Hz] as the phase-rate error of the same scale, a speed at the data carrier
    [m/s]: c/(2π·f₀)·rate (a fading or beating phasor's log-amplitude and phase are the real and imaginary
    parts of one analytic function). The fading term (:func:`unmodelled_sigmas`) and a merged image's
    Doppler term (:func:`image_doppler_sigma_mps`) read it.

    >>> from seamodem import get_preset
    >>> round(amp_rate_mps(1.0, get_preset("jmse2024"), sound_speed_mps=1500.0) * 1e3, 2)  # [mm/s] per Hz
    8.53
    """
    return sound_speed_mps / (2 * math.pi * config.carrier_hz) * rate_hz


def image_doppler_sigma_mps(image: MergedImage, amp_rate_hz: float, config: FrameConfig, *,
                            sound_speed_mps: float) -> float:
    """σ [m/s] the Doppler of a merged surface image puts on the direct path's whole-frame v_r, beyond what
    the fading term (``unmodelled_sigmas``: the log-amplitude rate as a phase-rate error, one to one) has.

    The waves move the image's path, and so its Doppler Δv relative to the direct path's: the sum's phase
    rate moves by Re(w)·Δv, its log-amplitude rate by Im(w)·Δv. Near f₀δ = ½ cycle (the image adding to
    the path, w nearly real) the amplitude stays flat while the phase wanders, and the fading term misses
    it by |Im w / Re w| (the corpus's far family with the depths: 3–7σ at 15–20 dB, |Im/Re| 0.03–0.3, the
    errors' RMS as Re(w)·2 sin θ·(the surface's vertical speed) predicts within 15 %). The measured rate,
    scaled by |Re w / Im w|, estimates Re(w)·Δv, up to what the waves can give it
    (``MergedImage.wave_doppler_mps``); what the fading term has already is not added again.
    """
    fade = amp_rate_mps(amp_rate_hz, config, sound_speed_mps=sound_speed_mps)
    bound = image.re_w * image.wave_doppler_mps
    shown = fade * image.re_w / image.im_w if image.im_w > 0 else math.inf
    sigma = min(bound, shown)
    return math.sqrt(max(0.0, sigma**2 - fade**2)) if math.isfinite(sigma) else 0.0


def fade_image_term_mps(rate_hz: float, image: MergedImage | None, measurer: FrameMeasurer) -> float:
    """The whole-frame v_r's σ terms [m/s] that read the direct path's log-amplitude rate ``rate_hz``: the
    fading term (``unmodelled_sigmas``) and a merged image's Doppler term beyond it
    (:func:`image_doppler_sigma_mps`), in quadrature: what ``RecordLookahead`` replaces when it settles
    the rate."""
    c = measurer.settings.sound_speed_mps
    fade = _K_FADE * amp_rate_mps(rate_hz, measurer.config, sound_speed_mps=c)
    if image is None:
        return fade
    return math.hypot(fade, image_doppler_sigma_mps(image, rate_hz, measurer.config, sound_speed_mps=c))


def bend_image_term_mps(fade: tuple[float, float, MergedImage | None] | None, measurer: FrameMeasurer) -> float:
    """The Doppler term [m/s] a record's v_r σ took from the image a bend showed without the depths
    (:func:`bend_image`), read from its fading rates ``fade`` (``FrameMeasurer.last_shape``'s: the rate
    used and the image); 0 without one."""
    if fade is None or fade[2] is None or not fade[2].from_bend:
        return 0.0
    return image_doppler_sigma_mps(fade[2], fade[1], measurer.config,
                                   sound_speed_mps=measurer.settings.sound_speed_mps)


def unbent_sigma_v_mps(record: MeasurementRecord, fade: tuple[float, float, MergedImage | None] | None,
                       measurer: FrameMeasurer) -> float:
    """The record's v_r σ without the Doppler term of an image a bend showed (:func:`bend_image_term_mps`):
    what ``RecordLookahead``'s speed check reads [m/s]."""
    return math.sqrt(max(record.sigma_v_r_mps**2 - bend_image_term_mps(fade, measurer) ** 2, 0.0))


def confident_decisions(soft: np.ndarray, modulation: str) -> tuple[np.ndarray, np.ndarray]:
    """The equaliser's outputs ``soft`` decided (the nearest constellation point) and which of them are
    confident: within half of half the gap between points (a fit on decisions uses only those).

    >>> d, ok = confident_decisions(np.array([0.9, -1.2, 0.3, -0.1j]), "bpsk")
    >>> d.real.tolist(), ok.tolist()
    ([1.0, -1.0, 1.0, 1.0], [True, True, False, False])
    """
    points = constellation(modulation)
    data = points[nearest_labels(soft, modulation)]
    half_gap = 0.5 * np.min(np.abs(points[1:] - points[0]))
    return data, np.abs(soft - data) < 0.5 * half_gap


def decisions_follow(soft: np.ndarray, config: FrameConfig, speed: Callable[[np.ndarray, np.ndarray], float], *,
                     sound_speed_mps: float) -> float:
    """How far a fit on decisions follows a tilt of its reference: λ = (v₊ − v₋)/(2Δ).

    The equaliser's outputs ``soft`` are turned by a phase ramp about the data's middle, the Doppler of a
    speed ±Δ, that reaches a quarter of the way to a decision boundary at the data's ends (π/(2M) for M
    points: π/4 for BPSK). The ramp moves no decision of a clean frame, so a fit on good decisions does not
    follow it (λ ≈ 0). Where the decisions are as much the noise's as the signal's, they follow the ramp
    and the fit with them (λ ≈ 1: it knows the slope of its reference, not of the frame); beyond 1, or
    against the ramp, the fit moves with which decisions flip. ``speed(data, trusted)`` refits the frame on
    new decisions and returns the direct path's speed [m/s] (NaN when it cannot).

    >>> from seamodem import get_preset
    >>> cfg = get_preset("jmse2024")
    >>> clean = np.sign(np.random.default_rng(1).standard_normal(cfg.n_data)) + 0j
    >>> decisions_follow(clean, cfg, lambda d, t: float(np.mean(d.real == clean.real)), sound_speed_mps=1500.0)
    0.0
    """
    m = len(constellation(config.modulation))
    t = (np.arange(len(soft)) - (len(soft) - 1) / 2) / config.symbol_rate_hz
    end_phase = math.pi / (2 * m)
    delta = end_phase * sound_speed_mps / (2 * math.pi * config.carrier_hz * float(np.max(np.abs(t))))
    v = []
    for sign in (1.0, -1.0):
        turned = soft * np.exp(-2j * math.pi * config.carrier_hz * sign * delta / sound_speed_mps * t)
        v.append(speed(*confident_decisions(turned, config.modulation)))
    return (v[0] - v[1]) / (2 * delta)


def tone_fallback_sigma_mps(sigma_tone: float, sigma_bank: float, gap: float, *, echoes: bool) -> float:
    """σ of the tone ML as the direct path's v_r [m/s], without a whole-frame fit.

    Parameters
    ----------
    sigma_tone : float
        The tone's CRLB at its C/N0 [m/s].
    sigma_bank : float
        The pilot bank's σ (the direct path's own, pilot-only estimate) [m/s].
    gap : float
        |tone − bank| [m/s].
    echoes : bool
        Whether the pilot resolved paths after the first.

    Returns
    -------
    float
        The tone's σ as the direct path's v_r [m/s].

    Notes
    -----
    Model: tone = v + b + n_t, bank = v + n_b, b the tone's multipath bias.
    With echoes resolved the tone sums paths whose Doppler differs by less
    than its resolution (1/T ≈ 3 Hz, 25 cm/s at 20 kHz): b is not observable
    in the tone (two paths of amplitude ratio ρ, a relative phase uniform and
    slow over the frame: b has an RMS of Δv·ρ/√(2(1 − ρ²)), 1.5 Δv at ρ = 0.9;
    0.8 Δv for Δv = 5 cm/s over 0.3 s in tests/receive/test_sigma_rules.py), and the tone's error is
    (tone − bank) + (bank − v): its second moment given the gap is
    gap² + σ_bank², with σ_tone² for the tone's own noise. Without resolved
    echoes b is small unless the gap shows it, and only a gap beyond 3 of the
    bank's σ is counted. In the benchmark's deep echoes (tone RMSE 34 mm/s,
    CRLB 1–20 mm/s) this puts 0.92–0.98 of the tone estimates within 3σ
    against 0.29–0.47 with the second form alone.
    """
    if echoes:
        return math.sqrt(sigma_tone**2 + gap**2 + sigma_bank**2)
    return math.sqrt(sigma_tone**2 + max(0.0, gap**2 - 9 * sigma_bank**2))


def bank_gap_sigmas_mps(v_fit: float, sigma_fit: float, v_bank: float, sigma_bank: float, v_tone: float,
                        sigma_tone: float) -> tuple[float, float]:
    """The σ's [m/s] of the direct path's whole-frame Doppler and of the pilot bank's, their gap counted.

    Two estimates of the same path's speed further apart than 3 combined σ: one is wrong. The tone, a third
    estimate over the whole frame, is the referee: when it agrees with the fit within 3 combined σ and not
    with the bank, the bank is the one wrong (the pilot's 23 ms saw a merged image's or an impulse's pull
    that the frame averages out), and its σ alone covers the gap. Otherwise the frame does not say which,
    and both σ's cover it (the gap beyond 3 combined σ, in quadrature). Within 3 combined σ, neither moves.

    The tone's σ here is its honest one (noise, spread of its lines, fading): a tone among echoes with
    their own Doppler has lines of its own that widen it, and then agrees with both, deciding nothing.
    Measured on the corpus's eight fresh seeds (4,534 whole-frame rows with echoes): of the 45 rows whose
    fit had taken such a gap, the fit was the closer to the truth on all 45 and the tone sided with it on
    44; those fits were 1.3 mm/s off (median) with σ's of 52 mm/s, the banks 88 mm/s off with 16 mm/s.

    >>> [round(s, 3) for s in bank_gap_sigmas_mps(0.5, 0.002, 0.6, 0.01, 0.501, 0.005)]  # the tone: the fit's
    [0.002, 0.096]
    >>> [round(s, 3) for s in bank_gap_sigmas_mps(0.5, 0.002, 0.6, 0.01, 0.55, 0.005)]  # neither: both cover it
    [0.095, 0.096]
    >>> bank_gap_sigmas_mps(0.5, 0.002, 0.51, 0.01, math.nan, 0.005)  # within 3 combined σ
    (0.002, 0.01)
    """
    gap2 = (v_fit - v_bank) ** 2 - 9 * (sigma_fit**2 + sigma_bank**2)
    if not gap2 > 0:
        return sigma_fit, sigma_bank
    grown_bank = math.sqrt(sigma_bank**2 + gap2)
    if abs(v_fit - v_tone) <= 3 * math.hypot(sigma_fit, sigma_tone) \
            and abs(v_bank - v_tone) > 3 * math.hypot(sigma_bank, sigma_tone):
        return sigma_fit, grown_bank
    return math.sqrt(sigma_fit**2 + gap2), grown_bank


#: frames (decoded, with a whole-frame fit) whose direct-path log-amplitude rates are pooled
#: (``FrameMeasurer``): a fading channel's statistics hold over seconds to tens of seconds
FADE_POOL_FRAMES = 5


class _FramePool:
    """Unbiased per-frame estimates (with their noise σ) over the last ``FADE_POOL_FRAMES`` frames."""

    def __init__(self):
        self._items: collections.deque[tuple[float, float]] = collections.deque(maxlen=FADE_POOL_FRAMES)

    def add(self, value: float, noise_sd: float = 0.0) -> None:
        if math.isfinite(value) and math.isfinite(noise_sd):
            self._items.append((float(value), float(noise_sd)))

    def standing_mean(self, k: float) -> float:
        """The frames' mean when it stands ``k`` of its σ out of 0, else 0 (0 with none)."""
        if not self._items:
            return 0.0
        values, noise = np.array(self._items).T
        mean = float(np.mean(values))
        return mean if mean > k * float(np.sqrt(np.sum(noise**2))) / len(values) else 0.0


#: a pooled rate's term counts when its mean stands this many of its noise σ out of 0 (``_RatePool``)
_RATE_POOL_K = 3.0


class _RatePool:
    """A log-amplitude rate's terms (``log_amplitude_rate``'s: the line's and the parabola's mean squares,
    each less its noise expectation, with that noise's σ) over the last ``FADE_POOL_FRAMES`` frames.

    :attr:`rate_hz` is √ of the sum of the terms' means that stand :data:`_RATE_POOL_K` of their σ out
    of 0 (0 with none). Apart, because the parabola's noise is five times the line's over a frame: summed,
    a slope wander 3 times the line's noise σ on every frame was not counted, and clipped at 0 alone,
    noise counted in half the pools (the corpus's steep family, no fading: whole-frame v_r σ 1.6 times
    its errors).
    """

    def __init__(self):
        self._terms: list[_FramePool] = []

    def add(self, terms: np.ndarray) -> None:
        """One frame's terms: rows of (mean square [1/s²], its noise σ)."""
        terms = np.asarray(terms, float)
        if not np.all(np.isfinite(terms)):
            return
        while len(self._terms) < len(terms):
            self._terms.append(_FramePool())
        for pool, (value, noise_sd) in zip(self._terms, terms):
            pool.add(value, noise_sd)

    @property
    def rate_hz(self) -> float:
        return math.sqrt(sum(pool.standing_mean(_RATE_POOL_K) for pool in self._terms))


#: frames whose complex channel curvatures are averaged (``_CurvaturePool``): a merged surface image's
#: geometry changes over minutes at a kilometre, so ten frames see the same bend
CURVATURE_POOL_FRAMES = 10
#: the coherent mean also over older frames (up to this many) while the range stays within
#: :func:`steady_bend_range_share` of the newest frame's: a bend of one frame's noise σ/4 (|c|² at 1/16 of
#: its noise expectation, the corpus's far family at 5 dB: a surface image 14 µs behind, 9 mm of bias)
#: needs about 100 frames to stand out, ten cannot show it
CURVATURE_POOL_MAX_FRAMES = 120


def steady_bend_range_share(config: FrameConfig) -> float:
    """The share of the range over which a merged echo's bend keeps its phase: B/(8·f₀).

    An echo merged with the direct path lies within the resolution, δ < 1/B, so its carrier phase is f₀·δ <
    f₀/B cycles; δ goes as 1/R for a surface image (2·z_b·z_v/(R·c)), and a range change ΔR turns that phase
    by at most (f₀/B)·ΔR/R cycles: within B/(8·f₀) of the range, an eighth of a cycle at most, and the bends
    add coherently (to within cos(π/4) at the edge).

    >>> from seamodem import get_preset
    >>> round(steady_bend_range_share(get_preset("jmse2024")), 4)
    0.04
    """
    return config.bandwidth_hz / (8 * config.carrier_hz)

#: the coherent mean's |c̄|² over its noise expectation beyond which it counts: noise alone leaves an
#: exponential ratio of mean 1, beyond ln(100) once in 100 pools (at ln(1000), a far recording at −1 dB
#: whose ten bends all pointed one way ended at 6.86 and its frames 4–8σ off; counted, the false alarm's
#: bound is that of a bend at the noise's scale)
_COHERENT_THRESHOLD = math.log(100.0)


def _coherent_excess(bends: np.ndarray, noise: np.ndarray) -> float:
    """|c̄|² of the inverse-noise weighted mean less its noise expectation when beyond
    :data:`_COHERENT_THRESHOLD` times that expectation, else 0 [s⁴]."""
    weight = 1.0 / noise
    mean = complex(np.sum(weight * bends) / np.sum(weight))
    floor = 1.0 / float(np.sum(weight))  # E|c̄|² of noise alone
    power = abs(mean) ** 2
    return power - floor if power > _COHERENT_THRESHOLD * floor else 0.0


#: a first echo within this many 1/B of the direct path, travelling with it (:func:`thin_waveguide`), is an
#: image of a waveguide thin against the range: the pulse's reach, within which a fitted path trades delay with
#: the direct one (as ``EARLIER_NEAREST_B``). The corpus's geometry (400 draws per family): the first resolved
#: image within it on 0.72 of far recordings (all of which have a merged image), 0.18–0.19 of fading and
#: impulsive ones (3 % of which have one). At 8/B the fading and impulsive families' whole-frame range went
#: from RMS err/σ 0.70–0.76 to 0.52–0.70 (two seeds): resolved surface echoes 0.3–0.8 ms behind took it
_THIN_WAVEGUIDE_B = 3.0


def thin_waveguide(wf: WholeFrameFit, first: int, config: FrameConfig) -> bool:
    """Whether the fit holds an echo of a waveguide thin against the range: a path at least
    ``GEOMETRY_MIN_GAIN`` of the direct one's, within :data:`_THIN_WAVEGUIDE_B`/B after it, whose Doppler is
    the direct path's within ``GRAZING_DOPPLER_MPS`` and three of its σ (it travels parallel to it:
    :func:`~seamodem.receive.echo_geometry.grazing`).

    The images of such a waveguide all lie within a few 1/B (method of images: paraxial lags of 2·z·z'/(c·R)),
    the nearest before the first one resolved; unresolved (within 1/B), it merges with the direct path, and
    its bias on the arrival is first order in its delay where the channel's bend it shows is second order:
    at low SNR a bend the pooled noise hides still biases the range several times the arrival's σ (the
    corpus's far family at 2 dB: a surface image 11 µs behind, no bend counted, ranges 5–12 mm long for σ
    1.9–3.6 mm). A steep channel's first echo is milliseconds behind, and its paths' Doppler differ."""
    echoes = fit_echoes(wf, first)
    if echoes is None:
        return False
    lags, gains = echoes
    dv, sigma_v, _ = fit_echo_dopplers(wf, first)
    near = ((lags > 0) & (lags <= _THIN_WAVEGUIDE_B / config.bandwidth_hz) & (gains >= GEOMETRY_MIN_GAIN)
            & grazing(dv, sigma_v))
    return bool(np.any(near))


class _CurvaturePool(_FramePool):
    """The direct path's channel curvature over the last decoded frames.

    Two means, the larger counted (:attr:`shown_delay_s`, the arrival's bias bound):

    - the fourth powers (|``WholeFrameFit.curvature_s2``|² less their noise expectation
      ``curvature_noise_s4``: unbiased, with that noise as their σ) over the last
      ``FADE_POOL_FRAMES``, when their mean stands 3 of its σ out of the noise: a bend whose phase moves
      from frame to frame (a fading echo) still adds there. At 1 km, a surface image 17 µs behind, the
      ends near the surface, bends one frame's channel by 2–3 of its σ at 20 dB (12 mm of bias, σ 0.3
      mm), five frames' by 5–7;
    - the complex curvature itself (``WholeFrameFit.curvature_s2``, inverse-noise weighted) over the
      last :data:`CURVATURE_POOL_FRAMES`: an echo that stays put adds coherently, its |c̄|² growing
      as the frames' count against the noise's, where the fourth powers' mean grows as its root.
      Counted beyond :data:`_COHERENT_THRESHOLD` times its noise expectation, less that expectation
      (unbiased). A steady bend whose |c|² is 0.8 of one frame's noise expectation: counted in 88 % of
      10-frame pools by the coherent mean, 22 % by the fourth powers' (``tests/receive/test_merged_image.py``).
      The same mean also over up to :data:`CURVATURE_POOL_MAX_FRAMES` older frames while the range stays
      within :func:`steady_bend_range_share` of the newest frame's (the bend keeps its phase there): on a
      long recording, a bend at 1/16 of one frame's noise expectation is counted once about 100 frames are in.

    And where the pooled fits show a waveguide thin against the range (:func:`thin_waveguide`), the bound of
    the largest steady bend the coherent mean would not count (:meth:`hidden_s4`) is the floor of
    :attr:`delay_s`, the range's; :attr:`shown_delay_s`, the bends counted alone, is the Doppler's.

    Fits on decisions do not feed it: at −3.5 dB their |c|² is 3.3 times the noise expectation the
    residual gives (80 fits on a single path), which would read as a bend.

    With ``hold`` (frames), the bound counted after each of the last ``hold`` fits whose range is within
    the steady bend's share of the newest one's still counts (the largest): a merged image's bend near
    the tests' thresholds would otherwise count on some frames and not on their neighbours, whose
    channel is the same (the corpus's far family without the depths, fresh seed 6283185: a recording at
    9.5 dB covered on 8 frames with σ 13–19 mm, 5 and 12 mm off with σ 0.9–1.0 mm on the two others).
    """

    def __init__(self, range_share: float = 0.0, hold: int = 0):
        super().__init__()
        self._bends: collections.deque[tuple[complex, float, float, bool]] = collections.deque(
            maxlen=CURVATURE_POOL_MAX_FRAMES)
        self._range_share = float(range_share)
        # (the bound counted after each of the last ``hold`` fits [s], that fit's range [m]; none kept at 0)
        self._counted: collections.deque[tuple[float, float]] = collections.deque(maxlen=int(hold))

    def add_fit(self, wf: WholeFrameFit, first: int, image: MergedImage | None = None,
                range_m: float = math.nan, thin: bool = False) -> None:
        """Pool the fit's direct-path curvature (``wf.curvature_*``; nothing when it has none), less the bend
        of a surface image whose bias is taken out (``image``), whose variance adds to the noise's; with the
        frame's range (``range_m``), for the coherent mean over older frames; ``thin``: the fit shows a
        waveguide thin against the range (:func:`thin_waveguide`), where a bend the noise hides counts."""
        if wf.curvature_s2 is None:
            return
        bend, noise = complex(wf.curvature_s2[first]), float(wf.curvature_noise_s4[first])
        if image is not None:
            bend, noise = image.residual_bend(bend, noise)
        self.add(abs(bend) ** 2 - noise, noise)
        if cmath.isfinite(bend) and math.isfinite(noise) and noise > 0:
            self._bends.append((bend, noise, float(range_m), bool(thin)))
        if self._counted.maxlen:
            self._counted.append((self._bound_s(), float(range_m)))

    def coherent_s4(self) -> float:
        """|c̄|² less its noise expectation [s⁴] when beyond the threshold, else 0 (0 with none): over the
        last :data:`CURVATURE_POOL_FRAMES`, and over every pooled frame whose range is within the steady
        bend's share (:func:`steady_bend_range_share`) of the newest one's when they are more (the larger
        counts; each test's false alarm is 1 in 100 pools, so at most 2 in 100 with both)."""
        if not self._bends:
            return 0.0
        bends, noise, ranges, _ = (np.array(v) for v in zip(*self._bends))
        found = _coherent_excess(bends[-CURVATURE_POOL_FRAMES:], noise[-CURVATURE_POOL_FRAMES:])
        steady = self._steady(ranges)
        if steady is not None:
            found = max(found, _coherent_excess(bends[steady], noise[steady]))
        return found

    def _steady(self, ranges: np.ndarray) -> np.ndarray | None:
        """The pooled frames whose range is within the steady bend's share of the newest one's, when they are
        more than :data:`CURVATURE_POOL_FRAMES`, else None."""
        newest = ranges[-1]
        if self._range_share > 0 and math.isfinite(newest):
            steady = np.abs(ranges - newest) <= self._range_share * newest  # (NaN ranges are not)
            if np.count_nonzero(steady) > CURVATURE_POOL_FRAMES:
                return steady
        return None

    def hidden_s4(self) -> float:
        """The largest steady bend the coherent mean would not count, |c|² at :data:`_COHERENT_THRESHOLD`
        times its noise expectation [s⁴], when most of the frames it pools show a thin waveguide
        (``add_fit(thin=…)``), else 0: over the frames the coherent mean pools, the more of them when the
        range has stayed steady (its floor the smaller).

        In such a waveguide an image merged with the direct path is the rule, not the exception (the corpus's
        far family: every recording, 3–52 µs behind), and its bias is first order in its delay where its bend
        is second order: a bend below the noise is no sign that the bias is below the arrival's σ."""
        if not self._bends:
            return 0.0
        _, noise, ranges, thin = (np.array(v) for v in zip(*self._bends))
        steady = self._steady(ranges)
        pick = steady if steady is not None else slice(-CURVATURE_POOL_FRAMES, None)
        noise, thin = noise[pick], thin[pick]
        if not 2 * np.count_nonzero(thin) > len(thin):
            return 0.0
        return _COHERENT_THRESHOLD / float(np.sum(1.0 / noise))

    def _bound_s(self) -> float:
        bound4 = max(self.standing_mean(3.0), self.coherent_s4())
        return bound4**0.25 / math.sqrt(3)  # σ of a uniform spread over the bound

    @property
    def shown_delay_s(self) -> float:
        """The bias σ [s] of the bends counted (held with ``hold``), a bend the noise hides left out."""
        now = self._bound_s()
        newest = self._counted[-1][1] if self._counted else math.nan
        if not math.isfinite(newest):
            return now
        return max([now, *(d for d, r in self._counted if abs(r - newest) <= self._range_share * newest)])

    @property
    def delay_s(self) -> float:
        """The arrival's bias σ [s]: :attr:`shown_delay_s`, or that of the bend the noise hides now
        (:meth:`hidden_s4`: not held, its floor only falls as the frames add up) when larger."""
        return max(self.shown_delay_s, self.hidden_s4() ** 0.25 / math.sqrt(3))


#: frames further apart than this [s] are not compared for the slow fading (``FrameMeasurer._frame_to_frame``)
_SLOW_FADE_MAX_GAP_S = 5.0

#: radial acceleration a vehicle can have over a frame [m/s²]: an AUV's is below ~0.5 (circling at
#: 15 m radius ~0.15); a fitted drift beyond it is phase wander (fading, a merged echo), not Doppler
PLAUSIBLE_ACCEL_MPS2 = 0.5
#: scale of the unmodelled terms against the raw observables (1: the analytic-signal argument alone)
_K_FADE, _K_ACCEL, _K_MERGE = 1.0, 1.0, 1.0


def unmodelled_sigmas(wf: WholeFrameFit, first: int, config: FrameConfig, *, sound_speed_mps: float,
                      pooled_amp_rate_hz: float = 0.0, pooled_merge_delay_s: float = 0.0,
                      image: MergedImage | None = None) -> tuple[float, float]:
    """σ terms [m/s], [s] of what the whole-frame fit of a path shows but does not model.

    Parameters
    ----------
    wf : WholeFrameFit
        The fit.
    first : int
        The direct path's index in it.
    config : FrameConfig
        The frame (carrier, duration).
    sound_speed_mps : float
        c [m/s].
    pooled_amp_rate_hz : float
        The direct path's log-amplitude rate pooled over recent frames
        (``FrameMeasurer``): the larger of it and this frame's is the scale.
    pooled_merge_delay_s : float
        The bias bound of a merged echo from the channel's curvature pooled
        over recent frames (``FrameMeasurer``): the larger of it and this
        frame's ``tilt_delay_s`` is counted.

    Returns
    -------
    sigma_v : float
        The Doppler's: the path's log-amplitude rate as a phase-rate error
        (a fading or beating phasor: same scale, ``WholeFrameFit.amp_rate_hz``),
        and the fitted drift beyond what a vehicle does
        (:data:`PLAUSIBLE_ACCEL_MPS2`) over the frame [m/s].
    sigma_tau : float
        The arrival's: the direct path's channel shape across its band as a
        delay (an unresolved echo, ``WholeFrameFit.tilt_delay_s``), and
        ``sigma_v``'s share through the time scale it gives the symbol
        instants (``sigma_v / c`` over half the frame) [s].
    """
    c, dur = sound_speed_mps, config.frame_duration_s
    amp = 0.0 if wf.amp_rate_hz is None else float(wf.amp_rate_hz[first])
    amp = max(amp, pooled_amp_rate_hz)
    fade = _K_FADE * amp_rate_mps(amp, config, sound_speed_mps=c)
    drift = _K_ACCEL * max(0.0, abs(float(wf.accel_mps2[first])) - PLAUSIBLE_ACCEL_MPS2) * dur / math.sqrt(12)
    # (the segments' timing scatter is already the fit's own σ of the arrival: not counted twice)
    sigma_v = math.hypot(fade, drift)
    return sigma_v, math.hypot(channel_shape_delay_s(wf, first, pooled_merge_delay_s, image),
                               time_scale_delay_s(sigma_v, config, sound_speed_mps=c))


def channel_shape_delay_s(wf: WholeFrameFit, first: int, pooled_merge_delay_s: float = 0.0,
                          image: MergedImage | None = None) -> float:
    """σ [s] of the direct path's arrival from its channel's shape (a merged echo): the larger of the fit's
    ``tilt_delay_s`` and ``pooled_merge_delay_s``. The pilot's arrival sees the same channel, so this
    bias is common to both arrivals (not in their gap). With a surface image whose bias is taken out
    (``image``), the fit's tilt is that of its curvature less the image's, beyond 3 of its noise σ (the
    image's variance added) as the fit's own."""
    tilt = 0.0 if wf.tilt_delay_s is None else float(wf.tilt_delay_s[first])
    if image is not None and wf.curvature_s2 is not None:
        bend, noise = image.residual_bend(complex(wf.curvature_s2[first]), float(wf.curvature_noise_s4[first]))
        rest = abs(bend) ** 2 - 9 * noise
        tilt = max(rest, 0.0) ** 0.25 / math.sqrt(3) if math.isfinite(rest) else tilt
    return _K_MERGE * max(tilt, pooled_merge_delay_s)


def bank_echo_sigma_mps(wf: WholeFrameFit, first: int, config: FrameConfig) -> float:
    """σ [m/s] the pilot bank's Doppler takes from the echoes that overlap the pilot, as the whole-frame fit
    sees them.

    The bank's Doppler comes from the pilot alone (23 ms at jmse2024: a Doppler resolution of 2.3 m/s),
    and an echo that arrives while the pilot is still being received, with its own Doppler, pulls it
    towards its own: up to b·|v_echo − v_direct| for an echo of relative amplitude b (the corpus's steep
    family, an echo 0.6 of the direct path 3.5 ms behind, 0.2–0.46 m/s away: the bank 0.05–1.0 of that
    off, 4–6 of its CRLB). Each such path of the fit adds (b·Δv)²; the σ is that of a uniform spread
    over the sum's root, /√3. 0 with no such path.

    A bound, not a measure: the bank is fitted with its echoes, and the corpus's steep family had it 17–64
    mm/s RMS off where this gave 80–99 mm/s. It is the bank's σ in the gap test of the whole-frame fit, and
    in its own σ column only until :data:`BANK_GAP_MIN_FRAMES` decoded frames' gaps to their fits measure
    that error (``FrameMeasurer.bank_excess_mps``).
    """
    span = config.n_pilot * config.symbol_period_s
    a0 = abs(complex(wf.amplitudes[first]))
    if not a0 > 0:
        return 0.0
    total = 0.0
    for p in range(len(wf.delays_s)):
        lag = float(wf.delays_s[p] - wf.delays_s[first])
        if p != first and 0 < lag < span:
            total += (abs(complex(wf.amplitudes[p])) / a0 * abs(float(wf.v_mps[p] - wf.v_mps[first]))) ** 2
    return math.sqrt(total / 3) if math.isfinite(total) else 0.0


#: an echo of the last decoded frame's fit at least this share of its first path is fitted in the next frame
#: where that frame's pilot fit has no path within 1/B of it (``with_recalled_echoes``)
RECALL_MIN_GAIN = 0.3


def with_recalled_echoes(delays_s, first_s: float, echoes: tuple[np.ndarray, np.ndarray] | None,
                         config: FrameConfig) -> np.ndarray:
    """The pilot fit's path arrivals ``delays_s`` [s], with the echoes of an earlier frame's fit (``echoes``:
    :func:`fit_echoes`, lags after its first path [s] and gains relative to it) at least
    :data:`RECALL_MIN_GAIN` of its first path and 1.5/B or more after it, placed after ``first_s``, where no
    path lies within 1/B of them.

    The pilot is 23 ms of the frame (jmse2024): an echo that fades over it is not found there, though it
    carries its share over the rest of the frame. Left out of the whole-frame fit, it stays in the residual,
    and a sub-band (B/4 wide) does not resolve it from the direct path: the corpus's fading family, a surface
    echo 0.96 at 495 µs the pilot fit missed on one frame in ten bent that frame's direct path 36 times its
    noise, and the pooled bend took the recording's range σ to 22 mm for errors within 3 mm."""
    delays = np.asarray(delays_s, float)
    if echoes is None:
        return delays
    lags, gains = echoes
    one_b = 1.0 / config.bandwidth_hz
    keep = [first_s + lag for lag, g in zip(lags, gains)
            if g >= RECALL_MIN_GAIN and lag >= 1.5 * one_b and np.all(np.abs(delays - (first_s + lag)) > one_b)]
    return np.sort(np.concatenate([delays, keep])) if keep else delays


def fit_echoes(wf: WholeFrameFit, first: int) -> tuple[np.ndarray, np.ndarray] | None:
    """A whole-frame fit's paths other than ``first``: their lags after it [s] and their gains relative to
    it; None when its gain is not positive."""
    a0 = abs(complex(wf.amplitudes[first]))
    if not a0 > 0:
        return None
    others = np.arange(len(wf.delays_s)) != first
    return (np.asarray(wf.delays_s, float)[others] - float(wf.delays_s[first]),
            np.abs(np.asarray(wf.amplitudes)[others]) / a0)


def fit_echo_dopplers(wf: WholeFrameFit, first: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A whole-frame fit's paths other than ``first``, in :func:`fit_echoes`' order: their Doppler less its
    [m/s], that Doppler's σ [m/s] and their arrivals' σ [s]."""
    others = np.arange(len(wf.delays_s)) != first
    return (np.asarray(wf.v_mps, float)[others] - float(wf.v_mps[first]),
            np.asarray(wf.sigma_v_mps, float)[others], np.asarray(wf.sigma_delay_s, float)[others])


def unmodelled_pull_s(lags_s: np.ndarray, gains: np.ndarray, modelled_s: np.ndarray, config: FrameConfig,
                      pilot: np.ndarray, *, eps: float = 0.0) -> float:
    """σ [s] of the pilot's arrival from echoes (lags after the first path, gains relative to it) that its
    fit did not model (none of its paths, ``modelled_s`` after the same first path, within half a
    symbol): :func:`~seamodem.receive.multipath.sidelobe_pull_s`."""
    modelled = np.asarray(modelled_s, float)
    half = config.symbol_period_s / 2
    keep = np.array([not np.any(np.abs(modelled - lag) < half) for lag in lags_s], dtype=bool)
    return sidelobe_pull_s(config, pilot, lags_s[keep], gains[keep], eps=eps)


def pilot_sidelobe_sigma_s(wf: WholeFrameFit, first: int, modelled_s: np.ndarray, config: FrameConfig,
                           pilot: np.ndarray, *, eps: float = 0.0) -> float:
    """σ [s] of the pilot's arrival from the echoes the whole-frame fit holds and the pilot's arrival fit
    (its paths' delays ``modelled_s``) did not model: :func:`unmodelled_pull_s`."""
    echoes = fit_echoes(wf, first)
    if echoes is None:
        return 0.0
    return unmodelled_pull_s(*echoes, np.asarray(modelled_s, float) - float(wf.delays_s[first]), config, pilot,
                             eps=eps)


def pooled_pilot_pull_s(pool, paths, config: FrameConfig, pilot: np.ndarray, *, eps: float = 0.0) -> float:
    """Median over recent frames' echoes of their pull on this frame's pilot arrival [s]
    (:func:`unmodelled_pull_s`: echoes this frame's pilot fit modelled left out).

    Parameters
    ----------
    pool : iterable of (numpy.ndarray, numpy.ndarray)
        Per frame, its echoes (:func:`fit_echoes`).
    paths : PathFit
        This frame's pilot fit (its paths and first arrival).
    config, pilot, eps
        As :func:`~seamodem.receive.multipath.sidelobe_pull_s`.
    """
    modelled = np.asarray(paths.delays_s, float) - float(paths.first_s)
    pulls = [unmodelled_pull_s(lags, gains, modelled, config, pilot, eps=eps) for lags, gains in pool]
    return float(np.median(pulls)) if pulls else 0.0


def time_scale_delay_s(sigma_v_mps: float, config: FrameConfig, *, sound_speed_mps: float) -> float:
    """The frame-start arrival's σ [s] from a σ of the Doppler that sets the symbol instants' time scale.

    The instants' time scale is the carrier's (1 + v/c): a phase-rate error (a fading phasor's, one the
    two carriers show) scales them too, and the frame-start arrival, fitted to the timing over the whole
    frame (centroid D/2 in), moves by that error's v/c times D/2 (a Rician direct path at 12–17 dB was
    2–6 mm off with σ 0.5 mm without this term).

    Parameters
    ----------
    sigma_v_mps : float
        σ of the Doppler as a speed [m/s].
    config : FrameConfig
        The frame (its duration D).
    sound_speed_mps : float
        c [m/s].
    """
    return sigma_v_mps / sound_speed_mps * config.frame_duration_s / 2


#: the largest pull of a tone's peak by a line Δf away beyond its resolution, over a·Δf·(Δf·T)⁻²
TONE_PULL_ENVELOPE = 0.3


def two_carrier_sigma_mps(wf: WholeFrameFit, first: int, v_tone: float, sigma_tone: float, sigma_v: float,
                          config: FrameConfig, *, sound_speed_mps: float = 1500.0) -> float:
    """σ term [m/s] of the direct path's whole-frame Doppler from its gap to the tone's, as two carriers see it.

    A Doppler shift is the same speed at every carrier; a phase that wanders
    with time (a fading or beating phasor, frequency-flat across the band)
    is the same phase rate at every carrier, i.e. a speed error inversely
    proportional to the carrier. With the data band at f0 and the tone at
    f_t, the data's error is f_t / (f_t − f0) times the gap v − v_tone (−2.5
    for jmse2024): the dual-frequency argument of GNSS's ionosphere-free
    combination. The tone also sums the echoes, which pull it: by up to
    ρ/|1 − ρ|·Δv for a path of relative amplitude ρ, Δv away, within the
    tone's resolution 1/T (the phase rate of 1 + ρe^{jψ} near cancellation),
    by ``TONE_PULL_ENVELOPE``/(Δf·T)² of that beyond. The sum over the fitted
    paths is a gap the echoes alone can make: it counts as noise. The gap's
    square less its noise expectation (both estimates' variances and that
    pull), times the ratio, is this term's square (0 without a tone).

    The tone's σ here is its noise only (CRLB, impulses): the spectral
    spread around a fading line is the same wander the data band sees, so it
    is what the gap measures, not noise to it (counted as noise, it hid
    wanders of 20–30 mm/s on fading single paths).

    Parameters
    ----------
    wf : WholeFrameFit
        The fit (every resolved path's amplitude and Doppler).
    first : int
        The direct path's index in it.
    v_tone, sigma_tone : float
        The tone's speed and the σ of its noise [m/s].
    sigma_v : float
        The direct path's σ so far [m/s].
    config : FrameConfig
        Carrier and tone frequencies, frame duration (the tone's).
    sound_speed_mps : float
        Sound speed [m/s].
    """
    if not (math.isfinite(v_tone) and math.isfinite(sigma_tone)):
        return 0.0
    amps = np.abs(np.asarray(wf.amplitudes))
    rho = amps / max(float(amps[first]), np.finfo(float).tiny)
    dv = np.asarray(wf.v_mps, dtype=float) - float(wf.v_mps[first])
    # an echo of relative amplitude ρ, Δv away, unresolved by the tone (Δf·T ≪ 1), moves the sum's phase rate
    # by Δv·Re(w), w = ρe^{jψ}/(1 + ρe^{jψ}) at their relative phase ψ: up to ρ/|1 − ρ|·Δv near cancellation
    # (capped at 10: equal paths), of either sign; beyond the resolution its line stands apart, the pull
    # falling as the envelope 0.3/(Δf·T)² of the exact pull (tests/receive/test_two_carrier.py). Their sum is
    # the gap the echoes alone can make. (As RMS rather than bound, a 0.89 echo 9 mm/s away in the demo's
    # channel left gaps of 40–120 mm/s read as wander, σ 0.07 → 0.09 cm/s where the errors are 0.05.)
    x = np.abs(dv) * config.tone_hz / sound_speed_mps * config.frame_duration_s
    reach = np.minimum(rho / np.maximum(np.abs(1.0 - rho), 0.1), 10.0)
    reach[first] = 0.0
    pull = float(np.sum(reach * np.abs(dv) * np.minimum(1.0, TONE_PULL_ENVELOPE / np.maximum(x, 1e-12) ** 2)))
    gap = float(wf.v_mps[first]) - v_tone
    # less its noise expectation (as the log-amplitude rate): beyond 3 σ only, a gap just inside it would
    # leave the data's error at up to 2.5 × 3 of the tone's σ unseen (8σ on an analytic fading path)
    excess = gap**2 - (sigma_tone**2 + sigma_v**2 + pull**2)
    ratio = config.tone_hz / (config.tone_hz - config.carrier_hz)
    return abs(ratio) * math.sqrt(max(excess, 0.0))


class BasebandBuffers:
    """Data and tone baseband samples of a stretch of the recording, with their global start indices.

    The streaming receiver appends the front end's output and trims what no
    frame needs any more; the array receiver gives each frame its combined
    basebands around it. Sample i of ``bb`` is at (bb_start + i) / fs_data [s],
    of ``tone`` at (tone_start + i) / fs_tone [s].

    Parameters
    ----------
    bb, tone : numpy.ndarray, optional
        Data-band and tone basebands, complex (default: empty).
    bb_start, tone_start : int
        Global index of their first samples [samples at their rates].
    """

    def __init__(self, bb: np.ndarray | None = None, tone: np.ndarray | None = None, *, bb_start: int = 0,
                 tone_start: int = 0):
        self.bb = np.zeros(0, complex) if bb is None else bb
        self.tone = np.zeros(0, complex) if tone is None else tone
        self.bb_start = bb_start
        self.tone_start = tone_start

    @property
    def bb_end(self) -> int:
        """Global index one past the last data baseband sample."""
        return self.bb_start + len(self.bb)

    @property
    def tone_end(self) -> int:
        """Global index one past the last tone baseband sample."""
        return self.tone_start + len(self.tone)

    def append(self, bb: np.ndarray, tone: np.ndarray) -> None:
        """Append the front end's next data and tone baseband samples.

        Parameters
        ----------
        bb, tone : numpy.ndarray
            Data-band and tone baseband samples that follow the buffers' own.
        """
        self.bb = np.concatenate([self.bb, bb])
        self.tone = np.concatenate([self.tone, tone])

    def trim(self, oldest_bb: int, plan: FrontEndPlan) -> None:
        """Drop the samples before data baseband index ``oldest_bb`` (and the tone's before the same time).

        Parameters
        ----------
        oldest_bb : int
            Global index of the oldest data baseband sample still needed.
        plan : FrontEndPlan
            The front end's decimations (the tone's cut at the same time).
        """
        cut = max(0, oldest_bb - self.bb_start)
        self.bb = self.bb[cut:]
        self.bb_start += cut
        oldest_tone = int(math.floor(self.bb_start * plan.data.decimation / plan.tone.decimation))
        cut = max(0, oldest_tone - self.tone_start)
        self.tone = self.tone[cut:]
        self.tone_start += cut


class _WholeFrame(NamedTuple):
    """A decoded frame's whole-frame fit as :meth:`FrameMeasurer._whole_frame` gives it."""

    #: the fit
    fit: WholeFrameFit
    #: the direct path's index in it
    first: int
    #: "whole_frame" (decoded) or "whole_frame_decisions"
    source: str
    #: how far a fit on decisions follows a tilt of its reference (:func:`decisions_follow`; NaN when decoded),
    #: computed when called
    follow: Callable[[], float]
    #: the index of the path the pilot's arrival took
    pilot_path: int
    #: the gap [s] to the pilot's fit's earliest path within 3/B before the one taken, when the frame decoded
    #: and the fit judged the earlier ones (:func:`earlier_fitted_direct`), else None
    near_gap_s: float | None


class _FitTiming(NamedTuple):
    """The whole-frame fit's arrival of the direct path, as :meth:`FrameMeasurer._doppler` gives it."""

    #: its arrival [s]
    t_s: float
    #: its σ [s] (the fit's noise, and the time scale the Doppler's unmodelled σ gives the instants)
    sigma_s: float
    #: the channel shape's σ [s] (``channel_shape_delay_s``), which the pilot's arrival shares
    sigma_shape_s: float
    #: the direct path's κ among the fit's paths with the ends' depths, else 1
    kappa: float
    #: how far after the direct path the path the pilot's arrival took lies [s] (0 unless the whole frame
    #: found a direct path the pilot's fit missed or took as an echo's precursor)
    lead_s: float
    #: ``_WholeFrame.near_gap_s``
    near_gap_s: float | None


class FrameMeasurer:
    """One detected frame in its basebands → its measurement record (and decoded payload when asked).

    Parameters
    ----------
    config : FrameConfig
        The transmitted frame (pilot, tone, symbol rate).
    plan : FrontEndPlan
        The front end that made the basebands (rates [Hz], bands).
    emissions : Emissions
        When frames (or, two-way, polls) were emitted.
    settings : ReceiverSettings, optional
        Sound speed, clock offset, turnaround, v_max, decoding and equaliser
        (default: ``ReceiverSettings()``).
    pilot : numpy.ndarray, optional
        Pilot symbols (default: from the config's seed).
    payloads : sequence of bytes, optional
        The payload sent in each frame, by frame_index, to count bit errors when decoding.
    blanker : ImpulseBlanker, optional
        The blanker the recording went through (the records' ``blanked_fraction``; NaN without).
    on_frame : callable, optional
        Called with (FrameMeasurement, bb, bb_t0_s, fs_bb) for every frame
        (as :class:`~seamodem.receive.stream.Receiver`'s ``on_frame``).

    Attributes
    ----------
    span_s : float
        A frame's longest span from its detected start [s]: a detection is
        ready to measure once the basebands reach this far past it.
    """

    def __init__(
        self,
        config: FrameConfig,
        plan: FrontEndPlan,
        *,
        emissions: Emissions,
        settings: ReceiverSettings | None = None,
        pilot: np.ndarray | None = None,
        payloads=None,
        blanker: ImpulseBlanker | None = None,
        on_frame: Callable | None = None,
    ):
        self.config = config
        self.plan = plan
        self.emissions = emissions
        self.settings = ReceiverSettings() if settings is None else settings
        self.pilot = pilot_symbols(config.n_pilot, config.pilot_seed) if pilot is None else np.asarray(pilot, complex)
        self.payloads = None if payloads is None else list(payloads)
        self.blanker = blanker
        self.on_frame = on_frame
        s = self.settings
        self.span_s = frame_span_s(config, v_max_mps=s.v_max_mps, sound_speed_mps=s.sound_speed_mps)
        # the fading's scale over the last frames (one frame's rate is one draw of it, its Doppler error
        # another): the direct path's from decoded frames' whole-frame fits, and the tone's from every frame
        self._fade_pool, self._tone_fade_pool = _RatePool(), _RatePool()
        # (without the depths, a bound once counted holds over the standing pool's frames at a steady range)
        self._curvature_pool = _CurvaturePool(steady_bend_range_share(config),
                                              hold=0 if self.images_modelled else FADE_POOL_FRAMES)
        # the direct path's amplitude from frame to frame (decoded frames): a fading or beating slower than a
        # frame, whose rate within one frame is within its noise
        self._slow_fade_pool = _RatePool()
        # the echoes the last decoded frames' fits held (lags after their first path [s], gains relative to
        # it): a frame not decoded has its pilot's arrival as its range, and its fit on decisions may miss or
        # misplace an echo those frames found
        self._decoded_echoes: collections.deque[tuple[np.ndarray, np.ndarray]] = collections.deque(
            maxlen=_ECHO_POOL_FRAMES)
        # the same with each echo's Doppler less the first path's, its σ and the lag's σ: the ends' depths
        # without them (echo_image)
        self._geometry_echoes: collections.deque[tuple[np.ndarray, ...]] = collections.deque(
            maxlen=_ECHO_POOL_FRAMES)
        self._geometry_count = 0  # echoes appended so far (the key of echo_image's last answer)
        self._echo_image_cache: tuple | None = None
        # the pilot's arrival against the whole frame's in the last decoded frames: its squared gap less the
        # two σ's (unbiased, not clipped) [s²]: how far this channel moves the pilot's arrival beyond what
        # its σ holds, for a frame whose range is the pilot's arrival (_record)
        self._pilot_gaps: collections.deque[float] = collections.deque(maxlen=_ECHO_POOL_FRAMES)
        # the pilot's path's Es/N0 that the measured SNR gives it, over the one the last frames' whole-frame
        # fits measured over their pilots: a frame without a fit of its own
        self._pilot_noise_ratios: collections.deque[float] = collections.deque(maxlen=_ECHO_POOL_FRAMES)
        # the pilot bank's Doppler against the whole frame's in the last decoded frames: its squared gap less the
        # two estimates' noise variances (unbiased, not clipped) [m²/s²]: what this channel adds to the bank's
        # error (echoes over the pilot with their own Doppler, impulses), for the bank's σ column
        self._bank_gaps: collections.deque[float] = collections.deque(maxlen=_ECHO_POOL_FRAMES)
        self._last_amplitude: tuple[float, float, float] | None = None
        #: of the last record: the channel shape's σ its arrival took [s], metres per second of arrival σ in
        #: its range σ (c, or c/2 two-way), and its whole-frame fit's own fading rate, the rate its v_r took [Hz]
        #: and the merged image its Doppler term read it with (None: v_r not from a fit); :class:`RecordLookahead`
        #: settles them with later frames
        self.last_shape: tuple[float, float, tuple[float, float, MergedImage | None] | None, float] = (
            0.0, 0.0, None, 0.0)

    @property
    def pooled_merge_delay_s(self) -> float:
        """The merged-echo bias bound's σ from the channel curvature pooled over recent decoded frames [s]."""
        return self._curvature_pool.delay_s

    @property
    def pooled_fade_rate_hz(self) -> float:
        """The direct path's log-amplitude rate pooled over recent decoded frames, within them and from frame
        to frame (the larger) [Hz]."""
        return max(self._fade_pool.rate_hz, self._slow_fade_pool.rate_hz)

    def bank_excess_mps(self, bound_mps: float) -> float:
        """The pilot bank's Doppler error beyond its noise [m/s], as the last decoded frames' gaps to their
        whole-frame fits showed it (the root of their mean, clipped at 0); ``bound_mps`` (a bound the frame's
        own fit gives) while fewer than :data:`BANK_GAP_MIN_FRAMES` frames are in, the larger then."""
        shown = _root_mean_excess(self._bank_gaps)
        return shown if len(self._bank_gaps) >= BANK_GAP_MIN_FRAMES else max(shown, bound_mps)

    def _frame_to_frame(self, wf: WholeFrameFit, first: int, range_m: float) -> None:
        """Pool the direct path's log-amplitude rate from the last decoded frame to this one.

        The whole frame's amplitude is known to 1/√(2 n Es/N0); its change over the frames' spacing, less
        the spreading's (ln A = −ln R + const: ln(1 + v_r·dt/R) over dt) and less its noise expectation, is a slow
        fading's or a beating merged echo's log-amplitude rate, whose phase rate (a Doppler error) has the
        same scale (``log_amplitude_rate``). A surface image riding 8-s waves at 800 m moved the amplitude
        13 % from frame to frame while within a frame it stayed flat, the Doppler 2–3 mm/s off (σ 0.4).
        Frames more than ``_SLOW_FADE_MAX_GAP_S`` apart are not compared (the rate would alias).
        """
        t = float(wf.delays_s[first])
        amp = abs(complex(wf.amplitudes[first]))
        es_n0 = float(wf.es_n0[first])
        if not (amp > 0 and es_n0 > 0 and math.isfinite(range_m) and range_m > 0):
            return
        ln_a, var = math.log(amp), 1.0 / (2 * wf.n_reference * es_n0)
        last, self._last_amplitude = self._last_amplitude, (t, ln_a, var)
        if last is None or not 0 < t - last[0] <= _SLOW_FADE_MAX_GAP_S:
            return
        dt = t - last[0]
        # (the range dt earlier, closing at v: R + v·dt)
        rate = (ln_a - last[1] - math.log1p(max(float(wf.v_mps[first]) * dt / range_m, -0.5))) / dt
        noise = (var + last[2]) / dt**2
        self._slow_fade_pool.add(np.array([[rate**2 - noise, math.sqrt(2) * noise]]))

    def measure(self, detection: Detection, window: BasebandBuffers) -> MeasurementRecord:
        """Measure (and decode) one detection whose span the window holds.

        A frame the window cuts (the recording's end) is measured on the part
        received, with a :class:`ReceiverWarning`. BLAS runs on one thread
        meanwhile (:func:`one_blas_thread`).

        Parameters
        ----------
        detection : Detection
            The frame's detection (start time [s], Doppler bin, z, ρ).
        window : BasebandBuffers
            Data and tone basebands around the frame, from the noise window
            before it to its span's end (:attr:`span_s`).

        Returns
        -------
        MeasurementRecord
            The frame's record, tied to its emission.
        """
        plan = self.plan
        bb_t0 = window.bb_start / plan.fs_data
        with one_blas_thread():
            m = measure_frame(
                window.bb,
                window.tone,
                detection,
                plan=plan,
                config=self.config,
                pilot=self.pilot,
                sound_speed_mps=self.settings.sound_speed_mps,
                v_max_mps=self.settings.v_max_mps,
                bb_t0_s=bb_t0,
                tone_t0_s=window.tone_start / plan.fs_tone,
            )
            if not m.complete:
                warnings.warn(
                    f"frame at {m.pilot.t_start_s:.3f} s is cut by the end of the recording: "
                    "its Doppler uses the part received",
                    ReceiverWarning,
                    stacklevel=4,  # the caller iterating Receiver.run
                )
            if self.on_frame is not None:
                self.on_frame(m, window.bb, bb_t0, plan.fs_data)
            return self._record(m, window.bb, bb_t0, plan.fs_data)

    def _record(self, m: FrameMeasurement, bb: np.ndarray, t0_s: float, fs: float) -> MeasurementRecord:
        s = self.settings
        c = s.sound_speed_mps
        t_arr = m.pilot.t_start_s
        if s.turnaround_s is None:
            k, t_emit = self.emissions.frame_for(t_arr - s.clock_offset_s)
        else:
            k, t_emit = self.emissions.frame_for(t_arr - s.turnaround_s)
        # impulses that blanking left are noise the median-based SNR does not see; the pilot's estimates
        # (arrival, bank) have only the direct path's share of the in-band SNR, which counts echoes as signal
        excess = impulse_excess(bb, self.plan, t0_s, t_start_s=t_arr, duration_s=self.config.frame_duration_s)
        snr_direct_db = m.pilot.snr_db + 10 * math.log10(direct_path_share(m))
        sigma_tau = float(delay_crlb_s(self.config, snr_direct_db)) * math.sqrt(excess)
        # the pilot fitted its paths together: an echo within the pulse's width trades its gain against the
        # arrival (an echo 0.3 at 100 µs: σ × 1.7–4)
        pilot_first = direct_path_index(m.paths) if len(m.paths.delays_s) > 1 else 0
        if len(m.paths.delays_s) > 1:
            sigma_tau = float(joint_delay_sigma_s(np.full(len(m.paths.delays_s), sigma_tau), m.paths.delays_s,
                                                  m.paths.amplitudes, config=self.config)[pilot_first])
        sent = None
        if self.payloads is not None and 0 <= k < len(self.payloads):
            sent = self.payloads[k]
        dec = demodulate(m, bb, t0_s, fs, config=self.config, pilot=self.pilot, settings=s, sent_payload=sent)
        # the range, roughly, for the spreading's share of the frames' amplitude change (nan when unknown)
        range_hint = c * (t_arr - t_emit - (s.clock_offset_s if s.turnaround_s is None else s.turnaround_s))
        if s.turnaround_s is not None:
            range_hint /= 2
        doppler, timing = self._doppler(m, dec, bb, t0_s, fs, excess, snr_direct_db, range_hint)
        sigma_bank = doppler.pop("sigma_bank")
        # impulses left where the pilot lies, as a fit's residual there shows them (the noise windows
        # around the frame may miss them: a pilot 16 mm off with σ 3.1 mm, its outputs' excess 1.5, the
        # windows' 1.0)
        pilot_excess = doppler.pop("pilot_excess", 1.0)
        # and the pilot's Es/N0 over its own outputs less than the measured SNR gives it (a whole-frame fit's, its
        # other paths taken out): noise that blanking left larger within the frame than around it (α-stable
        # noise at 3 dB: 0.49 of it, the pilot's arrivals 1.5 times their σ), echoes the pilot's fit did not
        # resolve (four echoes 2–10 ms behind, none in the pilot's fit: 2.3 times)
        pilot_excess = max(pilot_excess, doppler.pop("pilot_noise_ratio", 1.0))
        if pilot_excess > excess:
            sigma_tau *= math.sqrt(pilot_excess / excess)
        # the pilot's arrival: its CRLB and the pull of the echoes it did not model (the fit's, where one was made)
        sigma_tau = math.hypot(sigma_tau, doppler.pop("sigma_tau_pilot_pull"))
        if doppler["v_r_source"] == "whole_frame":
            if timing is not None:
                self._pilot_gaps.append((timing.t_s + timing.lead_s - t_arr) ** 2 - timing.sigma_s**2 - sigma_tau**2)
        elif self._pilot_gaps:
            # the pilot's arrival is the range: the last decoded frames' gaps between their pilot's arrival and
            # their whole frame's, beyond both σ's, are this channel's (an impulsive recording's surface echo
            # −0.93 at 107 µs ≈ 1/B: the decoded frames' fits resolved it, the pilot's arrivals of the frames
            # not decoded were 16–47 mm short with σ 7–8 mm)
            sigma_tau = math.hypot(sigma_tau, _root_mean_excess(self._pilot_gaps))
        noise_tau = sigma_tau  # the arrival's σ of noise, frame to frame (RecordLookahead's kinematic check)
        # (the fit's own, the one its v_r took, the merged image its Doppler term used): RecordLookahead
        fade_rates = doppler.pop("fade_rates_hz", None)
        # a fit not used still showed the direct path's channel (tilt, timing scatter): the pilot's arrival
        # sees the same channel
        unmodelled = doppler.pop("sigma_tau_unmodelled", 0.0)
        sigma_tau = math.hypot(sigma_tau, unmodelled)
        shape_used = unmodelled  # without a fit: the pooled bend, or a set-aside fit's terms (the larger)
        kappa = 1.0  # the whole-frame fit's direct path's κ (joint_delay_inflation), when it has one
        # (a direct path the pilot's fit missed, which the whole frame found: ``lead`` before the pilot's)
        # (of the pilot's earlier paths, those the decoded frame's whole-frame fit judged are not in the gap)
        lead = 0.0 if timing is None else timing.lead_s
        gap_first = timing.near_gap_s if timing is not None and timing.near_gap_s is not None \
            else earlier_path_gap_s(m)
        sigma_first = max(0.0, gap_first - lead)
        # the direct path's data-aided arrival over the frame, when decoded. Not on decisions: they were taken
        # at the pilot's timing, and pull the fit's arrival towards it (22 single-path frames at −3…−1 dB,
        # the corpus: the two arrivals' errors correlated 0.60, the fit's 0.64 of the pilot's plus its own,
        # its RMS err/σ 2.0), so the fit's σ does not hold and its gap to the pilot hides the pull; the
        # pilot's arrival, with its own σ, was the closer one too (decisions rows' range RMSE 9.1 → 7.1 mm
        # steep, 13.0 → 10.4 far, 10.4 → 9.4 fading). Its gap to the fit still counts beyond their σ's.
        if timing is not None:
            # two arrivals of the same path (the pilot's, the whole frame's): a gap beyond 3 combined σ is
            # a wrong path or peak taken by one of them, and neither says which: the σ of the one used
            # covers it (as the tone's covers its gap to the bank)
            # on decisions (CRC failed: raw BER 0.3–0.5 in multipath at 0 dB, the pilot's arrival 1.6–2× its
            # bound off) the gap less its expectation: beyond 3σ only left those frames 3–5σ off
            # the channel's shape (a merged echo) biases both arrivals alike: it is not in their gap, and goes
            # to the σ of the one used (in the gap's expectation on decisions, a fit 39 mm off kept σ 2.8 mm)
            # (the pilot's arrival is compared with the whole frame's of the same path: ``lead`` after the direct)
            t_fit, sigma_fit, sigma_shape, kappa = timing.t_s, timing.sigma_s, timing.sigma_shape_s, timing.kappa
            gap_k = 9 if doppler["v_r_source"] == "whole_frame" else 1
            excess = (t_fit + lead - t_arr) ** 2 - gap_k * (sigma_fit**2 + sigma_tau**2)
            if doppler["v_r_source"] == "whole_frame":
                t_arr, sigma_tau = t_fit, sigma_fit
                noise_tau = sigma_fit
            sigma_tau = math.sqrt(sigma_tau**2 + sigma_shape**2 + max(0.0, excess))
            shape_used = sigma_shape
        sigma_tau = math.hypot(sigma_tau, sigma_first)
        if s.turnaround_s is None:
            tof = t_arr - t_emit - s.clock_offset_s
            image = self.merged_image(c * tof, t_arr)
            if image is not None:
                # the ends' depths give the surface image and its phase: a merged one's bias on the arrival is
                # taken out, with its σ (the phase and reflection not known); the channel bend it makes was
                # not counted in the channel shape's σ (merged_image). The corpus's far family: ranges 5–19 mm
                # long, 0.4–0.47 of the image's delay, as predicted. How much the paths fitted around the
                # direct one move its arrival: the pilot's fit's, and the whole frame's (a fit on decisions
                # too: its paths are there for the pilot's arrival)
                kappa = max(kappa, direct_path_kappa(m.paths.delays_s, m.paths.amplitudes, pilot_first, self.config))
                if kappa > _IMAGE_ALONE_KAPPA:
                    # another path fitted within the pulse's width (a merged bottom image) moves the arrival
                    # too, which the image alone does not predict: the image's delay is the honest scale
                    sigma_tau = math.hypot(sigma_tau, image.delay_s)
                else:
                    t_arr, tof = t_arr - image.bias_s, tof - image.bias_s
                    sigma_tau = math.hypot(sigma_tau, image.sigma_s)
        else:
            tof = float(two_way_range_m(t_emit, t_arr, turnaround_s=s.turnaround_s, sound_speed_mps=1.0))
            sigma_tau /= 2  # the reply's arrival is the only measured time; the poll's emission is known
        self.last_shape = (shape_used, c / 2 if s.turnaround_s is not None else c, fade_rates, noise_tau)
        return MeasurementRecord(
            frame_index=int(k),
            t_emit_s=float(t_emit),
            t_arrival_s=float(t_arr),
            tof_s=float(tof),
            range_m=float(c * tof),
            snr_db=float(m.pilot.snr_db),
            v_r_tone_eq9_mps=m.v_tone_eq9_mps,
            v_r_bank_mps=float(m.pilot.v_mps),
            detection_z=m.detection.z,
            detection_rho=m.detection.rho,
            sigma_range_m=c * sigma_tau,
            sigma_v_r_bank_mps=sigma_bank,
            tone_c_n0_dbhz=10 * math.log10(max(m.tone.c_n0_hz, 1e-30)),
            two_way=s.turnaround_s is not None,
            blanked_fraction=self._blanked_fraction(m),
            **doppler,
            **payload_fields(dec),
        )

    def _blanked_fraction(self, m: FrameMeasurement) -> float:
        if self.blanker is None:
            return math.nan
        fs = self.plan.fs
        start = m.pilot.t_start_s
        return self.blanker.blanked_fraction(int(start * fs), int((start + self.config.frame_duration_s) * fs))

    @property
    def images_modelled(self) -> bool:
        """Whether a merged surface image is modelled (one-way, the ends' depths given: :meth:`merged_image`).

        Only then are echoes that are clusters split and the paths a whole-frame fit left in its residual
        taken out of the direct path's bend (``fit_whole_frame(split=2, clean=True)``). Without the depths,
        a cluster's misfit and the unmodelled paths' ripple stay in the bend and the bend bound counts
        them: on the corpus's far family it is that bound which covers a merged surface image's bias the
        frames cannot show (a bend second order in the image's delay, the bias first order). Done there
        too, the far range within 3σ went from 1.000 to 0.879 on the report seed, worst 19.9σ (a recording
        at 12 dB: σ 18.6 → 0.65 mm for errors of 8 mm), and the split alone took a fresh seed's from 0.925
        to 0.896; with the depths the image is taken out instead, and so are the misfit and the ripple
        (the depth report's fading range RMS err/σ 0.63 → 0.79, far 0.31 → 0.43)."""
        s = self.settings
        return s.turnaround_s is None and s.beacon_depth_m is not None and (
            s.vehicle_depth_m is not None or s.vehicle_depth_log is not None)

    def merged_image(self, range_m: float, t_s: float = math.nan) -> MergedImage | None:
        """The surface image merged with the direct path at ``range_m`` (one-way, the ends' depths given: the
        vehicle's at ``t_s``, the frame's arrival, with a depth log), whose bias is taken out of the arrival
        (:func:`merged_image_bias_s`); None without one."""
        s = self.settings
        if not self.images_modelled:
            return self.echo_image(range_m)
        image = merged_image_bias_s(range_m, s.beacon_depth_m, s.vehicle_depth_at(t_s), config=self.config,
                                    sound_speed_mps=s.sound_speed_mps, wave_amplitude_m=s.wave_amplitude_m,
                                    wave_period_s=s.wave_period_s)
        return image if image.delay_s > 0 else None

    def echo_image(self, range_m: float) -> MergedImage | None:
        """Without the ends' depths (one-way, ``ReceiverSettings.echo_geometry``): the merged surface image
        whose geometry the last decoded frames' echoes give (:func:`~.echo_geometry.pooled_depths`), as
        :func:`merged_image_bias_s` with those depths and their σ; None when they do not give one."""
        s = self.settings
        if s.turnaround_s is not None or not s.echo_geometry or not self._geometry_echoes:
            return None
        if not (math.isfinite(range_m) and range_m > 0):
            return None
        c = s.sound_speed_mps

        def image_at(g: ImageDepths) -> MergedImage:
            return merged_image_bias_s(range_m, g.z1_m, g.z2_m, config=self.config, sound_speed_mps=c,
                                       wave_amplitude_m=s.wave_amplitude_m, wave_period_s=s.wave_period_s,
                                       depth_sigma_m=max(g.sigma_m, DEPTH_SIGMA_M), delay_sigma_s=g.delay_sigma_s)

        key = (self._geometry_count, round(range_m, 2))
        if self._echo_image_cache is not None and self._echo_image_cache[0] == key:
            return self._echo_image_cache[1]
        # the fit's first path is the merged pair, about Re(w)·δ late (the median of |Re w| over the image's
        # phase): added back to the lags before the depths are solved for
        found = pooled_depths(self._geometry_echoes, range_m, config=self.config, sound_speed_mps=c,
                              lead_s=lambda g: _BEND_RE_W * merged_image_delay_s(
                                  range_m, g.z1_m, g.z2_m, config=self.config, sound_speed_mps=c))
        image = image_at(found) if found is not None else None
        image = image if image is not None and image.delay_s > 0 else None
        self._echo_image_cache = (key, image)
        return image

    def doppler_image(self, range_m: float, t_s: float = math.nan) -> MergedImage | None:
        """The merged surface image whose Doppler term the whole-frame v_r's σ takes at ``range_m``: with the
        ends' depths, :meth:`merged_image` (at ``t_s``, the frame's arrival, with a depth log); one-way without
        them, the one the channel's pooled bend shows (:func:`bend_image`); None without one."""
        s = self.settings
        if self.images_modelled:
            return self.merged_image(range_m, t_s)
        if s.turnaround_s is not None:
            return None
        image = self.echo_image(range_m)
        if image is not None:
            return image
        # (of a bend counted: one the noise may hide is the range's cover, not an image's Doppler)
        return bend_image(self._curvature_pool.shown_delay_s, range_m, config=self.config,
                          sound_speed_mps=s.sound_speed_mps,
                          wave_amplitude_m=s.wave_amplitude_m, wave_period_s=s.wave_period_s)

    def _doppler(self, m: FrameMeasurement, dec: FrameDecode | None, bb, t0_s: float, fs: float,
                 excess: float, snr_direct_db: float, range_m: float = math.nan
                 ) -> tuple[dict, _FitTiming | None]:
        """v_r_mps, its σ and source (and the bank's σ, ``sigma_bank``): the direct path's whole-frame Doppler
        when decoded, else the tone ML; and the direct path's arrival from the whole-frame fit
        (:class:`_FitTiming`: its arrival, σ, the channel shape's σ, which the pilot's arrival shares, κ, how
        far after it the path the pilot's arrival took lies: :func:`missed_direct_lag_s`,
        :func:`earlier_fitted_direct`, and the gap to the pilot's earlier paths within 3/B), or None.
        ``range_m`` (nan when unknown) takes the spreading out of the frames' amplitude change, and gives a
        merged surface image with the depths (:meth:`merged_image`): the channel bend it explains is not
        counted.

        The tone sums every path; it is flagged as multipath-biased when it and
        the direct path's own estimate (whole-frame fit, else the pilot bank)
        differ by more than 3 combined σ. Without the whole-frame fit, the
        tone's σ covers its bias as far as the frame shows it
        (:func:`tone_fallback_sigma_mps`). A fit on
        decisions (CRC failed) has its σ grown by its gap to the pilot bank
        beyond 3 of the bank's σ (runs of wrong decisions bias it unseen by
        its own scatter); it is not used when it then disagrees with the tone
        by more than 3 combined σ (the tone's with that gap), or when its σ is
        not below the tone's: the tone is then the estimate, and the pilot's
        arrival the range. A fit on decisions that do not explain the frame
        (its Es/N0 far below the measured SNR's, or a fit that moves further
        than a tilt of its reference, :func:`decisions_follow`) has its whole
        gap to the bank and the bank's σ added.
        """
        c = self.settings.sound_speed_mps
        v_tone = m.v_tone_ml_mps
        image = self.merged_image(range_m, m.pilot.t_start_s)
        # impulses left by blanking reach the tone's band as the data band's (the same √excess as the bank's)
        sigma_tone = float(tone_velocity_crlb_mps(self.config, m.tone.c_n0_hz, sound_speed_mps=c)) * math.sqrt(excess)
        sigma_tone_noise = sigma_tone  # the two-carrier check's: lines and wander are what it measures
        # the tone sums every path: echoes with their own Doppler are lines of their own in its band, which
        # pull the fitted one or are the one taken (the stronger); their spread is the tone's honest scale
        sigma_tone = math.hypot(sigma_tone, m.tone.spread_hz * c / self.config.tone_hz)
        # and a fading tone (or one beating with a merged echo): its log-amplitude rate, the same scale as
        # its phase's wander (as the whole-frame fit's term)
        # (its scale pooled over recent frames, as the whole-frame fit's: one frame's rate is one draw). The
        # tone's pool sets the tone's σ only: the tone sums every path, so among echoes its amplitude beats
        # where the direct path's does not (given to the data band too, it took the corpus's steep and
        # impulsive families' RMS err/σ from 0.7–0.8 to 0.03–0.3; a fading single path at −2.8 dB: tone rows
        # 4.3σ and 3.8σ → 2.0σ with it)
        self._tone_fade_pool.add(m.tone.amp_rate_terms)
        sigma_tone = math.hypot(sigma_tone, max(m.tone.amp_rate_hz, self._tone_fade_pool.rate_hz)
                                * c / (2 * math.pi * self.config.tone_hz))
        sigma_bank = float(pilot_velocity_crlb_mps(self.config, snr_direct_db, sound_speed_mps=c)) * math.sqrt(excess)
        gap = abs(v_tone - m.pilot.v_mps)
        sigma_tone_gap = tone_fallback_sigma_mps(sigma_tone, sigma_bank, gap, echoes=len(m.paths.delays_s) > 1)
        # the bend the image explains is not counted again with the depths given; an image the echoes place
        # (echo_image) is an inference: the bend keeps counting in full, its bound a cover beside the image's
        # σ (corpus far 2911526075: the echoes' clusters placed the image 21 µs behind for 7 µs, and the bend
        # less that image's left frames 3.4–5.6σ off that the bend had covered)
        explained = image if self.images_modelled else None
        fit = (self._whole_frame(m, dec, bb, t0_s, fs, image)
               if dec is not None and self.settings.whole_frame_doppler else None)
        if fit is not None and fit.source == "whole_frame":
            # the channel's bend, from decoded frames only: a fit on decisions at low SNR bends more than the
            # noise its residual gives (a single path at −3.5 dB: |c|² 3.3 times it over 80 fits; the corpus's
            # single paths at −2 dB took 18–34 mm of range σ from it)
            self._curvature_pool.add_fit(fit.fit, fit.first, explained, range_m,
                                         thin=not self.images_modelled
                                         and thin_waveguide(fit.fit, fit.first, self.config))
            echoes = fit_echoes(fit.fit, fit.first)
            if echoes is not None:
                self._decoded_echoes.append(echoes)
                self._geometry_count += 1
                self._geometry_echoes.append(echoes + fit_echo_dopplers(fit.fit, fit.first))
        pooled_merge = self.pooled_merge_delay_s
        inflation = 1.0
        # the direct path's Es/N0 that the measured SNR gives it
        expected_es_n0 = 10 ** (snr_direct_db / 10) * (1 + self.config.rolloff)
        rejected = None  # (v, σ, the fit) of a fit on decisions not used: the tone's σ must still cover its gap to it
        if fit is not None and fit.source == "whole_frame_decisions":
            # decided symbols can be wrong in runs and pull the fit away: they bias every segment alike,
            # which the segments' scatter does not see (1 frame in 100 at 6–12 dB in the benchmark's deep
            # echoes, raw BER 0.16–0.5: −435 mm/s with σ 21 mm/s). The pilot bank does not use them: its
            # gap to the fit beyond 3 of its σ is added to the fit's σ (as to the tone's), and to the
            # timing's in proportion; the fit is then kept only when the tone agrees and its σ is the smaller
            v, sigma = float(fit.fit.v_mps[fit.first]), float(fit.fit.sigma_v_mps[fit.first])
            grown = math.sqrt(sigma**2 + max(0.0, (v - m.pilot.v_mps) ** 2 - 9 * sigma_bank**2))
            inflation = grown / sigma if sigma > 0 else 1.0
            # decisions that do not explain the frame: the fit's direct-path Es/N0 (from its residual) far
            # below what the measured SNR gives that path (amplitude ∝ 1 − 2q for a share q of wrong BPSK
            # decisions: below 0.1 is q ≳ 1/3). Benchmark: such fits 0.001–0.06 of it and 9–863 mm/s off;
            # fits on good decisions 0.38–0.89, decoded frames ≥ 0.26 in α-stable noise (its mean power is
            # its tail's). Its bias is then as unobservable as the tone's among echoes, and its σ is found
            # the same way (tone_fallback_sigma_mps): the one with the smaller σ is used
            # A fit that moves further than a tilt given to its decisions' reference, or against it
            # (decisions_follow; NaN, a refit that failed, counts so), is no better known: it stands on
            # which decisions the tilt flips
            if (float(fit.fit.es_n0[fit.first]) < _DECISIONS_MIN_ES_N0_SHARE * expected_es_n0
                    or not 0.0 <= fit.follow() <= _DECISIONS_MAX_FOLLOW):
                grown = math.sqrt(sigma**2 + (v - m.pilot.v_mps) ** 2 + sigma_bank**2)
                inflation = grown / sigma if sigma > 0 else 1.0
                if math.isfinite(v_tone) and not grown < sigma_tone_gap:
                    fit, rejected = None, (v, grown, fit)
            elif math.isfinite(v_tone) and not (abs(v - v_tone) <= 3 * math.hypot(grown, sigma_tone_gap)
                                                and grown < sigma_tone_gap):
                fit, rejected = None, (v, grown, fit)
        # the echoes a fit (used or set aside) holds that the pilot's arrival fit did not model pull that
        # arrival through the pilot's sidelobes (pilot_sidelobe_sigma_s)
        shown = fit if fit is not None else (rejected[2] if rejected is not None else None)
        pilot_pull = 0.0 if shown is None else pilot_sidelobe_sigma_s(
            shown.fit, shown.pilot_path, m.paths.delays_s, self.config, self.pilot, eps=m.pilot.v_mps / c)
        pilot_excess = 1.0 if shown is None else float(shown.fit.pilot_noise_excess)
        # the pilot's path's Es/N0 over the pilot, the fit's other paths taken out, against what the measured
        # SNR gives it: noise the windows around the frame did not show (impulses the signal hid from the
        # blanker), or echoes the pilot's own fit did not resolve, which took signal from its path
        measured = math.nan if shown is None or shown.fit.pilot_es_n0 is None \
            else float(shown.fit.pilot_es_n0[shown.pilot_path])
        if measured > 0:
            noise_ratio = expected_es_n0 / measured
            self._pilot_noise_ratios.append(noise_ratio)
        else:  # no fit of its own: the last frames'
            noise_ratio = float(np.median(self._pilot_noise_ratios)) if self._pilot_noise_ratios else 1.0
        if (fit is None or fit.source != "whole_frame") and self._decoded_echoes:
            # the pilot's arrival is the range: the echoes of the last decoded frames pull it too (the median
            # of their pulls), where this frame's own fit on decisions did not see them (an impulsive
            # recording's bottom echo at 82 µs, which decoded fits found at 83–120 µs and one on decisions at
            # 22 µs: its pilot's arrival 13.7 mm off with σ 2.0 mm, pull 0.5 mm against their 19–21 mm)
            pilot_pull = max(pilot_pull, pooled_pilot_pull_s(self._decoded_echoes, m.paths, self.config, self.pilot,
                                                            eps=m.pilot.v_mps / c))
        sigma_tau_rejected = 0.0
        if rejected is not None:
            sigma_tau_rejected = unmodelled_sigmas(rejected[2].fit, rejected[2].first, self.config, sound_speed_mps=c,
                                                   pooled_merge_delay_s=pooled_merge, image=explained)[1]
            # two independent estimates of the same speed further apart than 3 combined σ: one of them is
            # wrong and the frame does not say which, so the one used (the tone) has a σ that covers the gap
            gap_fit2 = (rejected[0] - v_tone) ** 2 - 9 * (rejected[1] ** 2 + sigma_tone_gap**2)
            sigma_tone_gap = math.sqrt(sigma_tone_gap**2 + max(0.0, gap_fit2))
        if fit is not None and math.isfinite(fit.fit.v_mps[fit.first]):
            wf, first, source, _, pilot_path, near_gap = fit
            v, sigma = float(wf.v_mps[first]), float(wf.sigma_v_mps[first]) * inflation
            # decoded frames feed the pool (wrong decisions move a fit's amplitudes), fits on decisions use it:
            # a frame whose amplitude stayed flat had the fit's noise alone as σ while its phase wandered (the
            # corpus's fading family, whole-frame v_r 0.91 within 3σ, worst 9σ; pooled over 5 frames 0.98)
            if source == "whole_frame":
                if wf.amp_rate_terms is not None:
                    self._fade_pool.add(wf.amp_rate_terms[first])
                self._frame_to_frame(wf, first, range_m)
            pooled_rate = self.pooled_fade_rate_hz
            sigma_v_un, _ = unmodelled_sigmas(wf, first, self.config, sound_speed_mps=c,
                                              pooled_amp_rate_hz=pooled_rate, pooled_merge_delay_s=pooled_merge,
                                              image=explained)
            own_rate = 0.0 if wf.amp_rate_hz is None else float(wf.amp_rate_hz[first])
            sigma = math.hypot(sigma, sigma_v_un)
            # a merged surface image's Doppler: with the depths, the image's; without them, the one a bend
            # pooled over recent frames shows (this frame's in the pool)
            doppler_image = image if image is not None or self.images_modelled else self.doppler_image(range_m)
            sigma_image = 0.0 if doppler_image is None else image_doppler_sigma_mps(
                doppler_image, max(own_rate, pooled_rate), self.config, sound_speed_mps=c)
            sigma = math.hypot(sigma, sigma_image)
            # the pilot bank is the same path's own estimate: a gap beyond 3 combined σ is unmodelled too
            # (the bank's σ with the pull of the echoes the fit sees over the pilot: without it, the steep
            # family's decoded rows took 40–110 mm/s of σ from a bank 0.1 m/s off, their error 0.1–0.9 mm/s)
            # (the tone referees the gap: bank_gap_sigmas_mps; the bank's own σ column covers it too)
            v_bank, echo_bound = float(m.pilot.v_mps), bank_echo_sigma_mps(wf, first, self.config)
            sigma_fit = sigma
            sigma, _ = bank_gap_sigmas_mps(v, sigma_fit, v_bank, math.hypot(sigma_bank, echo_bound), v_tone,
                                           sigma_tone)
            # the bank's own column. Its error beyond its noise, measured: the last decoded frames' gaps to their
            # fits (this one's in), where the echoes' bound above is a bound (the corpus's steep family: banks
            # 17–64 mm/s RMS off against a bound of 80–99 mm/s); the bound while fewer frames are in. This
            # frame's own gap beyond 3 combined σ, when the tone sides with the fit, as above
            if source == "whole_frame":
                sigma_fit_noise = float(wf.sigma_v_mps[first]) * inflation
                self._bank_gaps.append((v - v_bank) ** 2 - sigma_fit_noise**2 - sigma_bank**2)
            column = math.hypot(sigma_bank, self.bank_excess_mps(echo_bound))
            _, column = bank_gap_sigmas_mps(v, sigma_fit, v_bank, column, v_tone, sigma_tone)
            # and the channel's wander the fit shows (fading, a merged image's Doppler), which is no Doppler and
            # moves the pilot's 23 ms as it moves the frame (the corpus's far family: banks 20–35 mm/s off with
            # σ 6–8 mm/s, the fit's σ 8.5 mm/s of these terms). Not in the gaps: the two estimates share it
            sigma_bank_column = math.sqrt(column**2 + sigma_v_un**2 + sigma_image**2)
            # (a fit on decisions has the tone as its referee already, above)
            sigma_2c = two_carrier_sigma_mps(wf, first, v_tone, sigma_tone_noise, sigma, self.config,
                                             sound_speed_mps=c) \
                if source == "whole_frame" else 0.0
            sigma = math.hypot(sigma, sigma_2c)
            # the fit's own arrival σ (its noise, and the time scale the Doppler's unmodelled σ gives the symbol
            # instants), and apart from it the channel shape's, which the pilot's arrival shares
            sigma_tau_fit = math.hypot(float(wf.sigma_delay_s[first]) * inflation, time_scale_delay_s(
                math.hypot(sigma_v_un, sigma_2c), self.config, sound_speed_mps=c))
            shape = channel_shape_delay_s(wf, first, pooled_merge, explained)
            biased = abs(v_tone - v) > 3 * math.hypot(sigma_tone, sigma)
            return dict(v_r_mps=v, sigma_v_r_mps=sigma, sigma_bank=sigma_bank_column, sigma_tau_pilot_pull=pilot_pull,
                        pilot_excess=pilot_excess, pilot_noise_ratio=noise_ratio,
                        v_r_source=source, v_r_tone_mps=v_tone,
                        tone_multipath_biased=bool(biased) if math.isfinite(v_tone) else None,
                        v_r_paths_spread_mps=float(np.ptp(wf.v_mps)), n_paths=len(wf.v_mps),
                        v_r_drift_mps2=float(wf.accel_mps2[first]),
                        fade_rates_hz=(own_rate, max(own_rate, pooled_rate), doppler_image)), \
                _FitTiming(float(wf.delays_s[first]), sigma_tau_fit, shape,
                           direct_path_kappa(wf.delays_s, wf.amplitudes, first, self.config, v_mps=wf.v_mps,
                                             sound_speed_mps=c) if image is not None else 1.0,
                           float(wf.delays_s[pilot_path] - wf.delays_s[first]), near_gap)
        # without a fit, the pilot's arrival: the channel's bend pooled over recent frames is this frame's too
        sigma_tau_unmodelled = max(sigma_tau_rejected, _K_MERGE * pooled_merge)
        # the bank's own column without a fit: its noise and the error the last decoded frames' gaps showed
        column = math.hypot(sigma_bank, self.bank_excess_mps(0.0))
        if not math.isfinite(v_tone):  # no tone (frame cut just after its pilot): the bank
            return dict(v_r_mps=float(m.pilot.v_mps), sigma_v_r_mps=column, sigma_bank=column,
                        sigma_tau_pilot_pull=pilot_pull, pilot_excess=pilot_excess, pilot_noise_ratio=noise_ratio,
                        v_r_source="bank",
                        v_r_tone_mps=v_tone, n_paths=len(m.paths.delays_s),
                        sigma_tau_unmodelled=sigma_tau_unmodelled), None
        return dict(v_r_mps=v_tone, sigma_v_r_mps=sigma_tone_gap, sigma_bank=column,
                    sigma_tau_pilot_pull=pilot_pull, pilot_excess=pilot_excess, pilot_noise_ratio=noise_ratio,
                    v_r_source="tone",
                    v_r_tone_mps=v_tone, tone_multipath_biased=bool(gap > 3 * math.hypot(sigma_tone, sigma_bank)),
                    n_paths=len(m.paths.delays_s), sigma_tau_unmodelled=sigma_tau_unmodelled), None

    def _whole_frame(self, m: FrameMeasurement, dec: FrameDecode, bb, t0_s: float, fs: float,
                     image: MergedImage | None = None) -> _WholeFrame | None:
        """The whole-frame fit of a decoded frame (:class:`_WholeFrame`: the fit, the direct path's index,
        the source, how far a fit on decisions follows a tilt of its reference, the path the pilot's arrival
        took, the gap to the pilot's earlier paths within 3/B), or None. On a decoded frame, a path of the
        fit before the pilot's that stands out over the whole frame (:func:`earlier_fitted_direct`) is the
        direct path; else, when the fit's residual holds one there (:func:`missed_direct_lag_s`), the frame is
        fitted again with it, and it is the direct path when that fit explains the frame better. A merged
        surface image (:meth:`merged_image`) is projected out of the residual's correlation before the paths left
        in it are sought (``fit_whole_frame(clean_lags_s=…)``)."""
        cfg, c = self.config, self.settings.sound_speed_mps
        soft = None
        if dec.crc_ok:
            data = build_frame(cfg, dec.payload).data_symbols
            trusted = np.ones(cfg.n_data, bool)
            source = "whole_frame"
        else:
            # pilots and the data decisions that lie close to their constellation point
            soft = np.asarray(dec.equalized)[: cfg.n_data]
            data, trusted = confident_decisions(soft, cfg.modulation)
            source = "whole_frame_decisions"
        eps = m.pilot.v_mps / c
        paths = m.echoes if m.echoes is not None else find_echoes(bb, fs, t0_s, config=cfg, pilot=self.pilot,
                                                                  paths=m.paths, eps=eps)

        # an echo the last decoded frame's fit held that this frame's pilot fit missed (it faded over the pilot)
        # is fitted too: left out, it stays in the residual and ripples the direct path's sub-bands
        delays0 = with_recalled_echoes(paths.delays_s, paths.first_s,
                                       self._decoded_echoes[-1] if self._decoded_echoes else None, cfg)

        def fit(data, trusted, delays=None, direct=paths.first_s,
                reach=0.0) -> tuple[WholeFrameFit, int]:
            delays = delays0 if delays is None else delays
            wf = fit_whole_frame(bb, fs, t0_s, config=cfg, symbols=np.concatenate([self.pilot, data]),
                                 reference=np.concatenate([np.ones(cfg.n_pilot, bool), trusted]),
                                 delays_s=delays, v_mps=m.compensation_speed_mps,
                                 sound_speed_mps=c, direct_s=direct,
                                 split=2 if self.images_modelled else 0,
                                 clean=self.images_modelled,
                                 clean_lags_s=() if image is None else (-image.bias_s, image.delay_s - image.bias_s),
                                 earlier_reach_s=reach)
            return wf, int(np.argmin(np.abs(wf.delays_s - direct)))

        # a decoded frame's residual is searched for a direct path the pilot's fit missed
        reach = cfg.n_pilot * cfg.symbol_period_s if dec.crc_ok else 0.0
        try:
            wf, first = fit(data, trusted, reach=reach)
            if len(delays0) > len(paths.delays_s) and np.min(np.diff(wf.delays_s)) * cfg.bandwidth_hz < 0.5:
                # a recalled echo that converged onto a path the pilot's fit had (the echo moved since the
                # earlier frame): two paths for one, which bend the direct path's sub-bands as one missed would
                delays0 = np.asarray(paths.delays_s, float)
                wf, first = fit(data, trusted, reach=reach)
        except ValueError:  # too few trusted symbols
            return None
        pilot_path = first

        def retake(wf2: WholeFrameFit, first2: int) -> None:
            # the earlier path as the direct one, where the fit kept it at least 1/B before the pilot's
            nonlocal wf, first, pilot_path
            taken = int(np.argmin(np.abs(wf2.delays_s - paths.first_s)))
            if first2 != taken and float(wf2.delays_s[taken] - wf2.delays_s[first2]) * cfg.bandwidth_hz >= 1.0:
                wf, first, pilot_path = wf2, first2, taken

        if dec.crc_ok:
            q = earlier_fitted_direct(wf, first, cfg)
            lag = missed_direct_lag_s(wf, first) if q is None else None
            try:
                if q is not None:
                    # a path the pilot's fit found before the one it took, which the whole frame shows: the direct
                    # path (fitted again with its channel's shape read)
                    retake(*fit(data, trusted, direct=float(wf.delays_s[q]), reach=reach))
                elif lag is not None:
                    t_direct = float(wf.delays_s[first]) + lag
                    wf2, first2 = fit(data, trusted, np.concatenate([[t_direct], delays0]), t_direct)
                    if wf2.noise_var < wf.noise_var:
                        retake(wf2, first2)
            except ValueError:
                pass
        # the pilot's fit's paths 3/B or more before the one it took were all fitted over the decoded frame: one
        # that stands out was taken above, the others are noise; of its gap (earlier_path_gap_s) only that to the
        # paths within 3/B is left, where a merged echo's misfit and the direct path's delay trade (the corpus's
        # far recording 6920412519: paths 1–2/B before its merged pair pulled the fitted arrival 23–50 µs
        # early). A path there that stands out but is too weak to be taken leaves the whole gap (None)
        pilot_paths = m.echoes if m.echoes is not None else m.paths
        near_gap = None
        if (dec.crc_ok and len(pilot_paths.delays_s)
                and np.min(paths.delays_s) <= np.min(pilot_paths.delays_s) + 1e-9
                and not np.any(earlier_standing_out(wf, first, cfg))):
            ahead = own_arrival_s(pilot_paths) - np.asarray(pilot_paths.delays_s, float)
            near = ahead[(ahead > 0) & (ahead * cfg.bandwidth_hz < EARLIER_NEAREST_B)]
            near_gap = float(np.max(near)) if near.size else 0.0

        def follow() -> float:
            # asked only of a fit on decisions that the cheaper test (its Es/N0) kept: two more fits
            if soft is None:
                return math.nan

            def speed(data, trusted) -> float:
                try:
                    wf, first = fit(data, trusted)
                except ValueError:
                    return math.nan
                return float(wf.v_mps[first])
            return decisions_follow(soft, cfg, speed, sound_speed_mps=c)
        return _WholeFrame(wf, first, source, follow, pilot_path, near_gap)


#: the radial jerk the track check allows [m/s³] (``RecordLookahead``): circling at 8 m radius and
#: 1.6 m/s, the closing speed's second derivative is about v·ω² ≈ 0.06; a straight leg's far less
TRACK_JERK_MPS3 = 0.2
#: neighbours further apart than this [s] are not compared by the track check
_TRACK_MAX_GAP_S = 10.0
#: the closing speed's third derivative the kinematic check allows [m/s⁴] (``kinematic_gaps``): circling at
#: 8 m radius and 1.6 m/s, v·ω³ ≈ 0.013
TRACK_SNAP_MPS4 = 0.05
#: frames further apart than this [s] are not used by the kinematic check (a quadratic speed over the span)
_KIN_MAX_GAP_S = 4.0
#: frames on each side of a record whose kinematic gaps are pooled with its own (``RecordLookahead``)
_KIN_HALF_WINDOW = 3
#: the gaps a turn makes: one step of the closing acceleration anywhere between the records moves the speed's
#: gap (``kinematic_gaps``) by at most 0.115 of the largest second difference of the speeds it makes at the
#: record and its neighbours, the range's (``range_gaps``) by 0.127 of it times the spacing (equal spacing
#: 1–3 s, 0.3 s frames; tests/receive/test_kinematic_check.py); a turn's onset and end are such steps, of
#: either sign: the gaps within this share of the second difference are not counted
_TURN_SHARE = 0.15
#: the same for the speed's gap against the second difference the ranges show (their third differences,
#: ``_turn_bounds_from_ranges``): at most 0.143 (1 s spacing) to 0.209 (3 s) of it
_TURN_SHARE_RANGES = 0.25


class _Neighbours(NamedTuple):
    """A record and its neighbours as measured (``RecordLookahead._window``), in arrival order."""

    times_s: list
    ranges_m: list
    speeds_mps: list
    #: the ranges' σ of noise (the arrival's own: the fit's or the pilot's; a bias common to neighbouring
    #: frames, as a merged echo's, cancels in their gaps)
    noise_m: list
    sigma_speeds_mps: list
    records: list
    #: the record's place among them
    index: int
    #: the speeds' σ's without the Doppler term of an image a bend showed (``bend_image_term_mps``): the
    #: speed's check reads these
    speed_sigmas_unbent_mps: list


class RecordLookahead:
    """Records held back until later frames have been measured (``ReceiverSettings.lookahead_frames``).

    What a frame cannot show about itself, its neighbours can:

    - **the channel's bend.** The channel shape's σ of an arrival (a merged echo's bias bound,
      ``channel_shape_delay_s``) comes from the curvature pooled over *recent* decoded frames, so the first
      frames of a recording, and frames while the pool's mean hovers at its threshold, miss it: the corpus's
      far family, 1 km with the surface image merged, had its first two or five frames 8–26σ off where the
      next ones were covered. A held record takes the larger of its own shape term and the pool's when it
      is released (the pool then spans it: 5 decoded frames after it, 10 around it for the coherent mean).
      The records of a stream's first :data:`CURVATURE_POOL_FRAMES` frames wait, settled, until that many
      have been measured (or the stream ends) and then take the pool's bound if it is the larger: a far
      recording's second frame, 18 mm off, had been given out with σ 1.2 mm five frames after it, while
      the pool counted its surface image's bend from the eighth frame on;
    - **the track.** A range that the neighbouring frames' ranges and closing speeds do not reach
      (r_k = r_j − (v_j + v_k)/2 · (t_k − t_j) + (v_k − v_j)·D/2, exact for a constant acceleration, within
      :data:`TRACK_JERK_MPS3`·|dt|³/12 otherwise; D/2 brings the frames' mean speeds to their arrivals) is an echo taken for a faded direct path, or an arrival
      given to the wrong emission: when *every* neighbour (at least two, up to two on each side within
      10 s) puts it beyond 3 combined σ on the same side, its σ covers the smallest gap beyond those 3σ
      (as two estimates of one quantity elsewhere in the receiver). A neighbour that is itself an outlier
      has a σ that makes it agree, so one bad frame does not condemn the next;
    - **the range between its neighbours** (``range_gaps``): the range the two adjacent records' ranges
      and speeds put at its arrival (exact for a constant jerk; a bias common to them cancels). A gap
      beyond 3 combined σ that is the largest among its neighbours' is its own error, which its σ covers
      (a fading tone row 0.44 m off, an echo taken, where each neighbour alone had too wide a σ through its
      speed's: 15σ → 1.0σ); below that, the gaps of the record and its neighbours less their noise, pooled,
      count when they stand 3σ out (a range error that changes from frame to frame);
    - **the speed against the ranges** (``kinematic_gaps``): the range lost between the two adjacent
      arrivals is the speed's integral, which the three speeds give (Simpson's rule). A phase that wanders
      from frame to frame (a merged surface image whose own Doppler follows the waves) moves the speeds
      and not the ranges: the gaps around it pooled, when they stand out, and then its own, raise its v_r σ
      (an analytic image swinging ±12 mm/s: speeds 4–21σ off → within 2.2σ).
      Both use each range's σ of noise (the arrival's own), not its bias terms.

    A whole-frame v_r's fading-rate term (``unmodelled_sigmas``, pooled over recent decoded frames) is
    settled the same way, but replaced rather than raised: the pool when the record is released spans it,
    before and after, where the one it took had only earlier frames (and the larger of two noisy pools
    would inflate it); the frame's own rate stays its floor. Only ``sigma_range_m`` (up) and
    ``sigma_v_r_mps`` change; the range-between and speed checks read the records as measured, not
    settled. ``frames=0`` releases each record at once (a live receiver), with none of these checks.

    Parameters
    ----------
    measurer : FrameMeasurer
        The stream's measurer (its curvature pool and each record's :attr:`FrameMeasurer.last_shape`).
    frames : int
        Frames measured after a record before it is released.
    """

    def __init__(self, measurer: FrameMeasurer, frames: int):
        self.measurer = measurer
        self.frames = int(frames)
        self._held: collections.deque = collections.deque()
        self._released: collections.deque = collections.deque(maxlen=2)
        # the released records as measured (before their σ's were settled), with their ranges' σ of noise
        self._measured: collections.deque = collections.deque(maxlen=_KIN_HALF_WINDOW + 1)
        # settled records of the stream's start, given out once the curvature pool has had its frames
        # (record, the channel-shape σ its range σ holds [s], metres per second of it)
        self._waiting: collections.deque = collections.deque()
        self._pushed = 0

    def push(self, record: MeasurementRecord) -> list[MeasurementRecord]:
        """Hold ``record`` (just measured) and return those now released, in order."""
        if self.frames <= 0:
            return [record]
        self._held.append((record, self.measurer.last_shape))
        self._pushed += 1
        out = []
        while len(self._held) > self.frames:
            out.extend(self._give(*self._held.popleft()))
        if self._pushed >= CURVATURE_POOL_FRAMES:
            out[:0] = self._give_waiting()
        return out

    def flush(self) -> list[MeasurementRecord]:
        """Every record still held (the stream has ended), in order."""
        out = []
        while self._held:
            out.extend(self._give(*self._held.popleft()))
        return self._give_waiting() + out

    def _give(self, record: MeasurementRecord, shape) -> list[MeasurementRecord]:
        """The record settled: given out, or kept while the stream has had fewer than
        :data:`CURVATURE_POOL_FRAMES` frames (the curvature pool's coherent mean needs them: a far
        recording's second frame, 18 mm off, was given out with σ 1.2 mm while the pool counted its surface
        image's bend from the eighth frame on, 10–15 mm for the others)."""
        settled = self._settle(record, shape)
        if self._pushed >= CURVATURE_POOL_FRAMES:
            return [settled]  # (those kept go out before it: push, flush)
        used_s, metres_per_s = shape[0], shape[1]
        self._waiting.append((settled, max(used_s, _K_MERGE * self.measurer.pooled_merge_delay_s), metres_per_s))
        return []

    def _give_waiting(self) -> list[MeasurementRecord]:
        """The kept records, each range σ raised to the curvature pool's bound now if that is the larger."""
        out = []
        later_s = _K_MERGE * self.measurer.pooled_merge_delay_s
        while self._waiting:
            record, used_s, metres_per_s = self._waiting.popleft()
            if later_s > used_s:
                record = dataclasses.replace(record, sigma_range_m=math.sqrt(
                    record.sigma_range_m**2 + metres_per_s**2 * (later_s**2 - used_s**2)))
            out.append(record)
        return out

    def _settle(self, record: MeasurementRecord,
                shape: tuple[float, float, tuple[float, float, MergedImage | None] | None, float]
                ) -> MeasurementRecord:
        used_s, metres_per_s, fade, noise_s = shape
        meas = self.measurer
        later_s = _K_MERGE * meas.pooled_merge_delay_s
        # the speed's σ without the Doppler term of an image a bend showed (bend_image): the speed's check
        # below measures the same wander, and reads the speeds' σ's with no such term
        bend_v = bend_image_term_mps(fade, meas)
        var = record.sigma_range_m**2 + metres_per_s**2 * max(0.0, later_s**2 - used_s**2)
        base = var
        var += track_gap_m2(record, list(self._released) + [held[0] for held in list(self._held)[:2]],
                            sigma_range_m=math.sqrt(var), half_frame_s=meas.config.frame_duration_s / 2)
        unbent_v = unbent_sigma_v_mps(record, fade, meas)
        nb = self._window(record, metres_per_s * noise_s, unbent_v)
        if nb is not None:
            index = nb.index
            whole = np.array([r.sigma_range_m for r in nb.records])
            gaps, (nb_var, nb_full) = range_gaps(nb.times_s, nb.ranges_m, nb.speeds_mps, [nb.noise_m, whole],
                                                 nb.sigma_speeds_mps, frame_s=meas.config.frame_duration_s)
            own = whole**2
            own[index] = base
            z = np.abs(gaps) / np.sqrt(own + nb_full)
            # a range whose two neighbours put it beyond 3 combined σ (all of each σ: a neighbour uncertain
            # for any reason, a frame on decisions, weighs as such) is an error of its own, unless a
            # neighbour's is the larger (an outlier shows in its neighbours' gaps too, at a half or so). A
            # neighbour with no gap of its own (a recording's last record) is the outlier when the one-sided
            # track check finds it so (the last record 15 m off had put its σ on the one before it)
            with np.errstate(invalid="ignore"):
                suspect = z > 3
            outlier = bool(suspect[index])
            for i in (index - 1, index + 1):
                if not (outlier and 0 <= i < len(z)):
                    continue
                zi = z[i]
                if not math.isfinite(zi):
                    others = [r for j, r in enumerate(nb.records) if j != i]
                    zi = math.inf if track_gap_m2(nb.records[i], others, sigma_range_m=nb.records[i].sigma_range_m,
                                                  half_frame_s=meas.config.frame_duration_s / 2) > 0 else 0.0
                outlier = zi <= z[index]
            # a gap beyond 3σ says one of its three ranges is off: the gaps that read them are set aside
            near = suspect.copy()
            near[1:] |= suspect[:-1]
            near[:-1] |= suspect[1:]
            # the ranges' error that changes from frame to frame (a merged echo whose phase the waves turn,
            # impulses): the gaps of the record and its neighbours, less their noise, pooled (those set
            # aside left out); σ's of noise, as a bias common to neighbours cancels in them
            spared = gaps.copy()
            spared[near] = np.nan
            gap_var = np.asarray(nb.noise_m) ** 2 + nb_var
            wander = gap_excess(spared, gap_var, index, own=False)
            # as noise to the speed's check, any of it: a wander that stands out in some windows and not in the
            # next would flicker the speeds' σ's (a far recording, its range bias moving by ±10 mm)
            wander_any = gap_excess(spared, gap_var, index, own=False, k=0.0, trim=False)
            if outlier:
                var = max(var, float(gaps[index] ** 2 - nb_full[index]))
            else:
                var += wander
        changes = {}
        if var > record.sigma_range_m**2:
            changes["sigma_range_m"] = math.sqrt(var)
        if fade is not None:
            # a whole-frame v_r: its fading-rate term from the pool that spans it (the frames before and after
            # it) in place of the pool before it: the first frames of a recording have no earlier ones (a far
            # recording's first frame 1.9 mm/s off with σ 0.4 where the next frames' σ was 1.2–2), and the
            # larger of two pools' noise would inflate the rest. The frame's own rate stays the floor.
            # A merged surface image's Doppler term (image_doppler_sigma_mps) reads the same rate, and is
            # settled with it: a far recording's first frame, the pool still empty, took it from its own rate
            # alone (the depths given: 2.7–6.3 mm/s off with σ 0.6–2.0, 3.2–4.6σ)
            # Without the depths, the image a bend shows is settled with the bend pooled since (as the range's
            # σ is, above): the first frames of a recording, the bend not yet standing out, had none
            own_hz, used_hz, image = fade
            settled_hz = max(own_hz, meas.pooled_fade_rate_hz)
            later = image
            if (image is None or image.from_bend) and not meas.images_modelled:
                found = meas.doppler_image(record.range_m)
                if found is not None and (image is None or found.wave_doppler_mps > image.wave_doppler_mps):
                    later = found
            if settled_hz != used_hz or later is not image:
                var_v = (record.sigma_v_r_mps**2 + fade_image_term_mps(settled_hz, later, meas) ** 2
                         - fade_image_term_mps(used_hz, image, meas) ** 2)
                changes["sigma_v_r_mps"] = math.sqrt(max(var_v, 0.0))
                bend_v = bend_image_term_mps((own_hz, settled_hz, later), meas)
        if nb is not None:
            # the speed against its neighbours' ranges (its own gap, and theirs pooled; not through a range
            # set aside above)
            # the ranges' wander is noise to it: a range gap is the record's error less ~½ of each
            # neighbour's (1.5 of a frame's variance at equal spacing), which a merged image's bias moving
            # by ±5 mm from frame to frame would otherwise put on the speeds (corpus, far family)
            noise_r = np.sqrt(np.asarray(nb.noise_m) ** 2 + wander_any / 1.5)
            gaps, var_g = kinematic_gaps(nb.times_s, nb.ranges_m, nb.speeds_mps, noise_r, nb.speed_sigmas_unbent_mps,
                                         frame_s=meas.config.frame_duration_s)
            gaps[near] = np.nan
            extra_v = gap_excess(gaps, var_g, nb.index)
            if extra_v > 0:
                # the gaps' excess and a bend's image term are two measures of one wander: the larger counts
                var_v = changes.get("sigma_v_r_mps", record.sigma_v_r_mps) ** 2
                changes["sigma_v_r_mps"] = math.sqrt(var_v + max(0.0, extra_v - bend_v**2))
        self._measured.append((record, metres_per_s * noise_s, unbent_v))
        if changes:
            record = dataclasses.replace(record, **changes)
        self._released.append(record)
        return record

    def _window(self, record: MeasurementRecord, noise_m: float, sigma_v_mps: float) -> _Neighbours | None:
        """The record (its range's σ of noise ``noise_m``, its speed's σ without a bend's image term
        ``sigma_v_mps``) and its neighbours as measured, up to ``_KIN_HALF_WINDOW`` on each side; None for a
        two-way record or fewer than three."""
        if record.two_way:
            return None
        meas = self.measurer
        before = [item for item in self._measured if not item[0].two_way]
        after = [(r, shape[1] * shape[3], unbent_sigma_v_mps(r, shape[2], meas))
                 for r, shape in list(self._held)[:_KIN_HALF_WINDOW + 1] if not r.two_way]
        window = before + [(record, noise_m, sigma_v_mps)] + after
        if len(window) < 3:
            return None
        return _Neighbours([r.t_arrival_s for r, _, _ in window], [r.range_m for r, _, _ in window],
                           [r.v_r_mps for r, _, _ in window], [n for _, n, _ in window],
                           [r.sigma_v_r_mps for r, _, _ in window], [r for r, _, _ in window], len(before),
                           [v for _, _, v in window])


def track_gap_m2(record: MeasurementRecord, neighbours: list[MeasurementRecord], *,
                 sigma_range_m: float, half_frame_s: float = 0.0) -> float:
    """The variance [m²] a record's range σ needs to reach its neighbours' track (``RecordLookahead``).

    Parameters
    ----------
    record : MeasurementRecord
        The record checked (its ``sigma_range_m`` replaced by ``sigma_range_m``).
    neighbours : list of MeasurementRecord
        Records of the same stream before and after it.
    sigma_range_m : float
        The record's range σ so far [m].
    half_frame_s : float
        Half the frame's duration [s]: a record's v_r is its mean over the frame's reception, the speed
        half a frame after the arrival its range is timed at, so the speeds are brought back to the
        arrivals with the acceleration between them ((v_k − v_j)/dt: (v_k − v_j)·δ of range; circling at
        8 m, 0.3 m/s per second and 0.15 s: 4.5 cm).

    Returns
    -------
    float
        0 unless the neighbours within 10 s that put the range beyond 3 combined σ all do so on the same
        side, and none of the others could have seen such a gap (3 combined σ below the smallest of
        theirs) and did not: those others abstain (a neighbour on the same wrong path with its σ already
        grown by its own check, or one so far that the jerk allowed hides it); then the smallest of the
        flagging gaps² less 9 combined variances. One flagging neighbour and no other that could tell is
        enough: which of the two is off is then not known, and the σ covers the gap (a file's last two
        frames on a fading direct path's echo, 1.0 m long: the last kept σ 48 mm, its neighbour's grown
        to 0.53 m vetoed it, and the one 3 s away had 0.45 m of jerk allowance).

    Examples
    --------
    >>> from seamodem.receive.records import MeasurementRecord
    >>> def rec(t, r):
    ...     return MeasurementRecord(frame_index=0, t_emit_s=t, t_arrival_s=t, tof_s=r / 1500, range_m=r,
    ...         v_r_mps=1.0, snr_db=10, v_r_tone_eq9_mps=1.0, v_r_bank_mps=1.0, detection_z=9,
    ...         detection_rho=0.5, sigma_range_m=0.002, sigma_v_r_mps=0.002, sigma_v_r_bank_mps=0.01,
    ...         tone_c_n0_dbhz=60)
    >>> track = [rec(0.0, 100.0), rec(1.0, 99.0), rec(3.0, 97.0), rec(4.0, 96.0)]
    >>> track_gap_m2(rec(2.0, 98.0), track, sigma_range_m=0.002)
    0.0
    >>> round(track_gap_m2(rec(2.0, 99.0), track, sigma_range_m=0.002) ** 0.5, 2)  # an echo 1 m behind
    0.92
    """
    r, v, t = record.range_m, record.v_r_mps, record.t_arrival_s
    sigma_v = record.sigma_v_r_mps
    gaps = []
    for n in neighbours:
        dt = t - n.t_arrival_s
        if not (0 < abs(dt) <= _TRACK_MAX_GAP_S):
            continue
        d = r - (n.range_m - (n.v_r_mps + v) / 2 * dt + (v - n.v_r_mps) * half_frame_s)
        s2 = (sigma_range_m**2 + n.sigma_range_m**2 + (sigma_v**2 + n.sigma_v_r_mps**2) / 4 * dt**2
              + (TRACK_JERK_MPS3 * abs(dt) ** 3 / 12) ** 2)
        if not (math.isfinite(d) and math.isfinite(s2)):
            continue
        gaps.append((d, s2))
    flags = [(d, s2) for d, s2 in gaps if d * d > 9 * s2]
    if not flags or not (all(d > 0 for d, _ in flags) or all(d < 0 for d, _ in flags)):
        return 0.0
    smallest = min(d * d for d, _ in flags)
    if any(9 * s2 < smallest for d, s2 in gaps if d * d <= 9 * s2):
        return 0.0  # a neighbour that could have seen the gap and did not
    return min(d * d - 9 * s2 for d, s2 in flags)


def _mean_weights(times_s: np.ndarray, lo_s: float, hi_s: float, frame_s: float) -> tuple[np.ndarray, float]:
    """Weights w with ∫_lo^hi v dt = w · (v_j) for a quadratic speed v whose mean over [t_j, t_j + D] is v_j,
    and the same sum's error for v = t³/6 (a unit third derivative) [m per m/s⁴]."""
    t = np.asarray(times_s, dtype=float)
    d = float(frame_s)
    # mean of 1, t, t², t³ over [t_j, t_j + D]
    means = np.column_stack([np.ones_like(t), t + d / 2, t**2 + t * d + d**2 / 3,
                             ((t + d) ** 4 - t**4) / (4 * d) if d > 0 else t**3])
    integ = np.array([hi_s - lo_s, (hi_s**2 - lo_s**2) / 2, (hi_s**3 - lo_s**3) / 3, (hi_s**4 - lo_s**4) / 4])
    w = np.linalg.solve(means[:, :3].T, integ[:3])
    return w, abs(float(integ[3] - w @ means[:, 3])) / 6


def _turn_bounds(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Per record, the largest |second difference| of the speeds (2·v[t₀, t₁, t₂]·h₀h₁, Δ²v at equal
    spacing) at it and at its two neighbours (NaN where none), within ``_KIN_MAX_GAP_S``."""
    n = len(t)
    d2 = np.full(n, np.nan)
    for j in range(1, n - 1):
        h0, h1 = t[j] - t[j - 1], t[j + 1] - t[j]
        if 0 < h0 <= _KIN_MAX_GAP_S and 0 < h1 <= _KIN_MAX_GAP_S:
            d2[j] = abs(2 * ((v[j + 1] - v[j]) / h1 - (v[j] - v[j - 1]) / h0) / (h0 + h1) * h0 * h1)
    padded = np.concatenate([[np.nan], d2, [np.nan]])
    stack = np.vstack([padded[:-2], padded[1:-1], padded[2:]])
    out = np.full(n, np.nan)
    seen = np.any(np.isfinite(stack), axis=0)
    out[seen] = np.nanmax(stack[:, seen], axis=0)
    return out


def _turn_bounds_from_ranges(t: np.ndarray, r: np.ndarray, sigma_r: np.ndarray) -> np.ndarray:
    """Per record, the same as ``_turn_bounds`` from the ranges: the second difference of the speed that
    the ranges' third differences show (6·r[t₀…t₃]·h², h their mean spacing; the motion's, free of the
    speeds' own errors) beyond 2 of its σ of noise (a turn stands far out of it: 0.26 m/s² at 1 s is
    0.13 m), the largest over the four-record spans within three records of it."""
    n = len(t)
    q = np.full(n, np.nan)  # by the span's first record
    for i in range(n - 3):
        tt = t[i : i + 4]
        if np.all(np.diff(tt) > 0) and tt[-1] - tt[0] <= 3 * _KIN_MAX_GAP_S:
            coef = np.eye(4)
            for k in range(1, 4):  # divided differences, of each range's unit vector: the weights on r
                coef = (coef[1:] - coef[:-1]) / (tt[k:] - tt[:-k])[:, None]
            scale = 6 * ((tt[-1] - tt[0]) / 3) ** 2
            value = abs(float(coef[0] @ r[i : i + 4])) * scale
            noise = math.sqrt(float(np.sum((coef[0] * sigma_r[i : i + 4]) ** 2))) * scale
            q[i] = max(value - 2 * noise, 0.0)
    out = np.full(n, np.nan)
    for j in range(n):
        near = q[max(j - 3, 0) : j + 1]
        near = near[np.isfinite(near)]
        if near.size:
            out[j] = float(near.max())
    return out


def _beyond(gap: float, bound: float) -> float:
    """The gap less a bound on its size from the model (towards 0, not across it)."""
    if not math.isfinite(bound):
        return gap
    return math.copysign(max(abs(gap) - bound, 0.0), gap)


def kinematic_gaps(times_s, ranges_m, speeds_mps, sigma_ranges_m, sigma_speeds_mps, *,
                   frame_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each record's closing speed against the one its neighbours' ranges and speeds imply (``RecordLookahead``).

    A range and a closing speed are one motion seen twice: the range lost between two arrivals is the speed's
    integral between them. With three records j − 1, j, j + 1 (arrival times t, ranges r, speeds v, each
    speed the mean over its frame's reception [t, t + D]),
    r_{j−1} − r_{j+1} = Σ w_i v_i for a speed quadratic in time (Simpson's rule, w = T/3·(1, 4, 1) at equal
    spacing T and D → 0; exact here for any spacing and frame), within ``TRACK_SNAP_MPS4`` times the rule's
    error on a cubic. r_j is not used: a bias common to the ranges (a merged echo, the sound speed) cancels,
    and what is left is the speeds' error, which the ranges do not share: a phase that wanders with time
    (a merged surface image whose own Doppler follows the waves: the corpus's far family at 15–20 dB, whole-
    frame speeds 3–6 mm/s off, alternating with a 4–8 s period, σ 0.5) moves v and not r.

    Parameters
    ----------
    times_s, ranges_m, speeds_mps : array_like
        The records' arrival times [s] (increasing), ranges [m] and closing speeds [m/s].
    sigma_ranges_m : array_like
        The ranges' σ of *noise* [m]: a bias common to neighbouring frames cancels and is not counted.
    sigma_speeds_mps : array_like
        The speeds' σ [m/s].
    frame_s : float
        The frame's duration D [s].

    Returns
    -------
    gaps, variances : numpy.ndarray
        Per record, v_j less the speed the neighbours' ranges and speeds give it [m/s], and that difference's
        variance under the σ's given [m²/s²]; NaN for the first and last records and where neighbours are
        further than 4 s away.

    Examples
    --------
    A track closing at 1 m/s and slowing by 0.1 m/s²; the third speed 5 mm/s off:

    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> v = 1.0 - 0.1 * (t + 0.15)  # the mean over a 0.3 s frame of 1 − 0.1 t
    >>> r = 100 - t + 0.05 * t**2
    >>> v[2] += 0.005
    >>> g, s2 = kinematic_gaps(t, r, v, np.full(5, 1e-3), np.full(5, 5e-4), frame_s=0.3)
    >>> np.round(g * 1e3, 2)  # mm/s: the neighbours see a share of it
    array([ nan, 0.76, 5.  , 1.91,  nan])
    >>> np.round(np.sqrt(s2[2]) * 1e3, 2)
    np.float64(1.21)
    """
    t = np.asarray(times_s, dtype=float)
    r = np.asarray(ranges_m, dtype=float)
    v = np.asarray(speeds_mps, dtype=float)
    sr = np.asarray(sigma_ranges_m, dtype=float)
    sv = np.asarray(sigma_speeds_mps, dtype=float)
    gaps = np.full(len(t), np.nan)
    var = np.full(len(t), np.nan)
    # what a turn can make of the gap, bounded from the speeds' second differences and from the ranges' third
    # differences: a turn shows in both, and the smaller bound holds. Each alone would take in the errors
    # looked for: a speed error alternating by 5 mm/s makes 10 mm/s of second differences, and the range
    # bias of the merged image that makes it changes by ±5 mm from frame to frame (corpus, far family)
    turns = _TURN_SHARE * _turn_bounds(t, v)
    from_ranges = _TURN_SHARE_RANGES * _turn_bounds_from_ranges(t, r, sr)
    turns = np.where(np.isfinite(from_ranges), np.fmin(turns, from_ranges), turns)
    for j in range(1, len(t) - 1):
        lo, hi = t[j - 1] - t[j], t[j + 1] - t[j]
        if not (-_KIN_MAX_GAP_S <= lo < 0 < hi <= _KIN_MAX_GAP_S):
            continue
        w, cubic = _mean_weights(t[j - 1 : j + 2] - t[j], lo, hi, frame_s)
        others = (r[j - 1] - r[j + 1]) - w[0] * v[j - 1] - w[2] * v[j + 1]
        g = _beyond(v[j] - others / w[1], turns[j])
        s2 = sv[j] ** 2 + (sr[j - 1] ** 2 + sr[j + 1] ** 2 + (w[0] * sv[j - 1]) ** 2 + (w[2] * sv[j + 1]) ** 2
                           + (TRACK_SNAP_MPS4 * cubic) ** 2) / w[1] ** 2
        if math.isfinite(g) and math.isfinite(s2):
            gaps[j], var[j] = g, s2
    return gaps, var


def gap_excess(gaps: np.ndarray, variances: np.ndarray, index: int, *, own: bool = True,
               k: float = 3.0, trim: bool = True) -> float:
    """The variance a record's σ needs for the gaps (``kinematic_gaps``, ``range_gaps``) around it.

    Each gap's square less its variance estimates the unmodelled variance; over the records given (the
    record's neighbours) but the largest gap (with ``trim``), weighted by their precision, it counts when it stands ``k`` of
    its σ out of 0 (a gap² is χ²₁ in noise alone: its σ is √2 its variance; neighbouring gaps share records,
    which √2 more allows for). With ``own``, the record's own gap beyond 3 of its σ then counts too, as its
    square less its variance, the larger of the two (alone, a gap is as often the ranges' wander beyond
    the σ's given: a far recording's merged image moving its range bias by ±10 mm a frame). 0 without
    gaps (NaN: not counted).
    """
    ok = np.isfinite(gaps) & np.isfinite(variances) & (variances > 0)
    pool = ok.copy()
    if trim and np.count_nonzero(pool) >= 4:
        # the largest gap is left out of the pool: one frame's gap (a turn's start at 3 s spacing, 10–14 mm/s
        # against 0.6) is its own, counted by its own record; what the pool looks for is shared
        pool[np.argmax(np.where(ok, gaps**2 / np.where(ok, variances, 1.0), -np.inf))] = False
    out = 0.0
    if np.count_nonzero(pool) >= 3:
        x = gaps[pool] ** 2 - variances[pool]
        wt = 1.0 / variances[pool] ** 2
        pooled = float(np.sum(wt * x) / np.sum(wt))
        if pooled > k * 2 * math.sqrt(1.0 / float(np.sum(wt))):
            out = pooled
    if own and out > 0 and ok[index] and gaps[index] ** 2 > 9 * variances[index]:
        out = max(out, float(gaps[index] ** 2 - variances[index]))
    return out


def range_gaps(times_s, ranges_m, speeds_mps, sigma_ranges_m, sigma_speeds_mps, *,
               frame_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each record's range against the one its two neighbours' ranges and speeds put at its arrival.

    The range r(t) cubic through the neighbours' ranges r_{j±1}, whose mean closing speeds over their frames
    [t, t + D] are v_{j±1} (Hermite interpolation: exact for a constant jerk), evaluated at t_j; within
    ``TRACK_SNAP_MPS4`` times the rule's error on a quartic. The neighbours' weights on their ranges sum to
    1, so a bias common to them cancels: what is left is the record's own error (an echo taken for a faded
    direct path, 0.4 m behind: 15σ on the corpus's fading family where each neighbour alone, through its
    speed's σ of 8–18 cm/s over 1–2 s, could not show it).

    Parameters
    ----------
    times_s, ranges_m, speeds_mps, sigma_speeds_mps, frame_s
        As :func:`kinematic_gaps`.
    sigma_ranges_m : array_like, shape (n,) or (m, n)
        The ranges' σ [m]; m sets of them give m rows of variances from the one interpolation (the receiver
        reads the ranges' σ of noise and their whole σ).

    Returns
    -------
    gaps, variances : numpy.ndarray
        Per record, r_j less the neighbours' range at its arrival [m] (where the first set's variance is
        finite), and that range's variance under the neighbours' σ's (the record's own not in it) [m²],
        shaped as ``sigma_ranges_m``; NaN for the first and last records and where neighbours are further
        than 4 s away.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> r = 100 - t + 0.05 * t**2
    >>> v = 1.0 - 0.1 * (t + 0.15)  # the mean of −r′ over a 0.3 s frame
    >>> r[2] += 0.4  # an echo 0.4 m behind taken at the third arrival
    >>> g, s2 = range_gaps(t, r, v, np.full(5, 0.002), np.full(5, 0.1), frame_s=0.3)
    >>> np.round(g, 3)  # the neighbours see it through the interpolation's weights
    array([   nan, -0.154,  0.4  , -0.246,    nan])
    >>> round(float(np.sqrt(s2[2])), 3)  # mostly the speeds' (weights ≈ ±D/4... T/4 on them)
    0.041
    """
    t = np.asarray(times_s, dtype=float)
    r = np.asarray(ranges_m, dtype=float)
    v = np.asarray(speeds_mps, dtype=float)
    sr = np.asarray(sigma_ranges_m, dtype=float)
    sets = np.atleast_2d(sr)
    sv = np.asarray(sigma_speeds_mps, dtype=float)
    d = float(frame_s)
    gaps = np.full(len(t), np.nan)
    var = np.full((len(sets), len(t)), np.nan)

    def rows(x: float) -> tuple[np.ndarray, np.ndarray]:
        # r(x) and the mean of −r' over [x, x + D], on the powers t⁰…t⁴ (the last for the rule's error)
        p = np.arange(5)
        val = x**p
        if d > 0:
            mean = -((x + d) ** p - x**p) / d
        else:
            mean = -p * np.where(p > 0, x ** np.maximum(p - 1, 0), 0.0)
        return val, mean

    turns = _turn_bounds(t, v)
    for j in range(1, len(t) - 1):
        lo, hi = t[j - 1] - t[j], t[j + 1] - t[j]
        if not (-_KIN_MAX_GAP_S <= lo < 0 < hi <= _KIN_MAX_GAP_S):
            continue
        (r_lo, v_lo), (r_hi, v_hi) = rows(lo), rows(hi)
        m = np.array([r_lo, r_hi, v_lo, v_hi])
        # weights u on (r_{j−1}, r_{j+1}, v_{j−1}, v_{j+1}) giving the cubic's value at t_j (its constant term)
        u = np.linalg.solve(m[:, :4].T, np.eye(4)[0])
        quartic = abs(float(u @ m[:, 4])) / 24  # the rule's value at 0 (the truth 0) for r = t⁴/24
        est = u @ np.array([r[j - 1], r[j + 1], v[j - 1], v[j + 1]])
        s2 = ((u[0] * sets[:, j - 1]) ** 2 + (u[1] * sets[:, j + 1]) ** 2 + (u[2] * sv[j - 1]) ** 2
              + (u[3] * sv[j + 1]) ** 2 + (TRACK_SNAP_MPS4 * quartic) ** 2)
        g = _beyond(r[j] - est, _TURN_SHARE * turns[j] * (hi - lo) / 2)
        if math.isfinite(g):
            var[:, j] = np.where(np.isfinite(s2), s2, np.nan)
            if math.isfinite(s2[0]):
                gaps[j] = g
    return gaps, (var if sr.ndim > 1 else var[0])
