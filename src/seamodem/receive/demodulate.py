"""Demodulation of a measured frame: Doppler compensation (eq 10–11), fractionally spaced samples,
DFE / turbo equalisation and decoding (:mod:`seamodem.decode`), and the record's payload columns."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..config import FrameConfig
from ..decode.equalizer import DfeSettings
from ..decode.turbo import TurboResult, turbo_equalize
from ..transmit.coding import encode_info, info_block
from ..transmit.modulation import symbols_to_bits
from .compensate import compensate_frame
from .doppler import matched_filter
from .measure import FrameMeasurement
from .settings import ReceiverSettings

__all__ = [
    "fractional_samples",
    "decode_frame",
    "decode_received",
    "decode_through_echoes",
    "demodulate",
    "payload_fields",
    "FrameDecode",
    "channel_span_symbols",
    "dfe_for_span",
]


#: decoding passes with the echoes cancelled (:func:`decode_through_echoes`) run on a frame whose CRC failed
ECHO_CANCEL_ITERATIONS = 2
#: further passes (up to this many in all) while the whole-frame fits explain the frame better and better
#: (:func:`decode_through_echoes`): on ten fading and impulsive corpus recordings whose frames failed, 81 of
#: 100 frames decoded with 2 passes, 86 with 4 or 6 and 88 with 8 run unconditionally
ECHO_CANCEL_MAX_ITERATIONS = 8
#: the growth per pass of the explained power (the fitted paths' power over the fit's residual, from the
#: second fit's: the first on a cancelled pass's decisions) that earns a pass beyond
#: :data:`ECHO_CANCEL_ITERATIONS`. On those recordings, the frames decoded late grew by 1.2–7 times the second
#: fit's from the third fit on; on frames that never decode, and on a recording none of whose frames decodes,
#: the power wandered by ×0.45–1.7 from pass to pass about where it started. A gain of 1.02 from pass to pass
#: instead decoded 2 more frames of 300 on two fresh seeds' fading and impulsive families (frames whose fits
#: grew by 3–10 % a pass) and cost 13–20 % of the receiver's time on that recording; this one 3 %
ECHO_CANCEL_PROGRESS = 1.1


def fractional_samples(bb: np.ndarray, fs: float, t0_s: float, compensated, config: FrameConfig, sps: int = 2) -> np.ndarray:
    """Matched filter at ``sps`` instants per symbol along the Doppler-warped grid, phase removed.

    Parameters
    ----------
    bb : numpy.ndarray, complex
        Data-band baseband, bb[n] at t0 + n/fs [s].
    compensated : seamodem.receive.compensate.CompensatedFrame
        The receiver's eq 10–11 output: instants t̂_k, phases φ̂_k and pilot gain.
    config : FrameConfig
    sps : int
        Samples per symbol for the fractionally spaced equaliser.

    Returns
    -------
    numpy.ndarray, complex, shape (sps·(n_pilot + n_data),)
        x[sps·k + i] at t̂ interpolated at k + i/sps, divided by the pilot gain.

    Notes
    -----
    Instants and phases between symbols are linearly interpolated (extrapolated
    past the last symbol), which is exact for a constant speed.
    """
    k = np.arange(compensated.times_s.size)
    frac = np.arange(sps * k.size) / sps
    slope_t = compensated.times_s[-1] - compensated.times_s[-2]
    slope_p = compensated.phases_rad[-1] - compensated.phases_rad[-2]
    times = np.interp(frac, k, compensated.times_s) + np.maximum(frac - k[-1], 0) * slope_t
    phases = np.interp(frac, k, compensated.phases_rad) + np.maximum(frac - k[-1], 0) * slope_p
    y = matched_filter(bb, fs, t0_s, times, config=config) * np.exp(-1j * phases)
    return y / compensated.gain


def decode_frame(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    compensated,
    config: FrameConfig,
    pilot: np.ndarray,
    *,
    settings: DfeSettings | None = DfeSettings(),
    passes: int = 1,
) -> TurboResult:
    """Equalise and decode a Doppler-compensated frame (passes = 1: DFE only; more: turbo).

    Parameters
    ----------
    bb : numpy.ndarray, complex, (n_samples,)
        Data-band baseband around the frame.
    fs : float
        Its sample rate [Hz].
    t0_s : float
        Time of ``bb[0]`` on the recording's clock [s].
    compensated
        The frame's Doppler compensation (eq 10–11): symbol instants and phases
        (:func:`~seamodem.receive.compensate.compensate_frame`).
    config : FrameConfig
        The frame.
    pilot : numpy.ndarray, complex, (n_pilot,)
        The pilot symbols.
    settings : DfeSettings or None
        The equaliser; None sizes it to the frame's measured delay spread
        (:func:`channel_span_symbols`, :func:`dfe_for_span`).
    passes : int
        Most equaliser passes (1: DFE only; more: turbo while the CRC fails).

    Returns
    -------
    TurboResult
        Payload, CRC, equaliser output and passes run.
    """
    sps = DfeSettings().sps if settings is None else settings.sps
    x = fractional_samples(bb, fs, t0_s, compensated, config, sps)
    pilot = np.asarray(pilot, dtype=complex)
    if settings is None:
        settings = dfe_for_span(channel_span_symbols(x, pilot, sps))
    return turbo_equalize(x, pilot, config, settings=settings, passes=passes)


def channel_span_symbols(x: np.ndarray, pilots: np.ndarray, sps: int, *, max_lag: int = 48, fraction: float = 0.25) -> int:
    """Delay spread of the compensated frame, in whole symbols after the first arrival.

    The pilots are correlated with the fractionally spaced samples at every
    sample lag from 0 to ``max_lag`` symbols; the span is the last lag whose
    correlation reaches ``fraction`` of the strongest and 5× the median
    magnitude over the lags. The data after the pilots and the pilot's own
    sidelobes leave a floor of up to ~0.15 of the peak at some lag (150
    pilots), hence the default fraction 0.25: echoes weaker than −12 dB are
    left to the feedforward filter and the turbo passes. At an in-band SNR
    near 0 dB a noise lag can still pass (a few % of frames, measured), which
    lengthens that frame's equaliser, not more.

    Parameters
    ----------
    x : numpy.ndarray, complex
        Doppler-compensated samples, ``sps`` per symbol, x[sps·k] at pilot k on
        the first path.
    pilots : numpy.ndarray
    sps : int
    """
    p = np.asarray(pilots, dtype=complex)
    lags = np.arange(sps * max_lag + 1)
    idx = sps * np.arange(p.size)[None, :] + lags[:, None]
    ok = idx < x.size
    c = np.abs(np.where(ok, x[np.minimum(idx, x.size - 1)], 0) @ np.conj(p)) / p.size
    strong = (c >= fraction * c.max()) & (c >= 5 * np.median(c))
    return int(math.ceil(lags[strong].max() / sps - 1e-9)) if strong.any() else 0


def dfe_for_span(span_symbols: int, *, base: DfeSettings = DfeSettings()) -> DfeSettings:
    """Equaliser lengths sized to a measured delay spread of ``span_symbols`` symbols.

    Every tap adapts and adds its share of misadjustment noise: on a single path
    a 64-tap RLS DFE loses about 1 dB against the matched filter (measured raw
    BER 9e-4 against 2.6e-4 at 6 dB in-band SNR, jmse2024). So the feedback
    spans the delay spread D plus 3 symbols of pulse tail, and the feedforward
    filter 4 + min(D, 12) symbols at ``base.sps`` samples per symbol, 8 samples
    of them before the cursor (the first path). A single path (D ≤ 1) gets 4
    symbols of feedforward and 2 feedback taps.

    Parameters
    ----------
    span_symbols : int
        Delay spread D in symbols (:func:`channel_span_symbols`).
    base : DfeSettings
        Algorithm, forgetting factor, step and PLL gains to keep.
    """
    if span_symbols <= 1:
        return dataclasses.replace(base, n_ff=4 * base.sps, ff_centre=2 * base.sps, n_fb=2)
    return dataclasses.replace(
        base, n_ff=base.sps * (4 + min(span_symbols, 12)) + 8, ff_centre=8, n_fb=span_symbols + 3
    )


@dataclass(frozen=True)
class FrameDecode:
    """A received frame's payload, and how well it came through.

    Attributes
    ----------
    payload : bytes
        Decoded payload; meaningful only when ``crc_ok``.
    crc_ok : bool
        The frame check passed. Bytes are never reported valid otherwise.
    eq_snr_db : float
        SNR at the DFE output, 1/mean|z − decision|² over the data [dB].
    passes : int
        Equaliser passes run (1 = DFE only; more: turbo passes until the CRC passed).
    ber : float
        Information-bit error rate after decoding (NaN when the payload sent is unknown).
    raw_ber : float
        Bit error rate of the DFE's hard decisions before the decoder (NaN when unknown).
    compensated : CompensatedFrame
        The eq 10–11 symbols the decoder started from (for plots).
    equalized : numpy.ndarray, complex, shape (n_data,)
        The DFE's outputs over the data, before decisions (for plots).
    info_bits : numpy.ndarray of uint8, optional
        The decoder's information bits (its decisions, CRC passed or not).
    """

    payload: bytes
    crc_ok: bool
    eq_snr_db: float
    passes: int
    ber: float
    raw_ber: float
    compensated: object
    equalized: np.ndarray
    info_bits: np.ndarray | None = None


def decode_received(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    t_start_s: float,
    v_mps: float,
    sound_speed_mps: float,
    settings: DfeSettings | None = None,
    passes: int = 3,
    sent_payload: bytes | None = None,
    track_t_s: np.ndarray | None = None,
    track_v_mps: np.ndarray | None = None,
) -> FrameDecode:
    """Compensate (eq 10–11, constant ``v_mps``), equalise and decode one measured frame.

    Parameters
    ----------
    bb : numpy.ndarray, complex
        Data-band baseband around the frame, bb[n] at t0 + n/fs [s].
    pilot : numpy.ndarray
        Pilot symbols.
    t_start_s, v_mps : float
        The receiver's arrival time of the frame start [s] and mean closing speed [m/s].
    settings : DfeSettings, optional
        A fixed equaliser; default: sized to the frame's measured delay spread.
    passes : int
        Most equaliser passes; turbo passes run only while the CRC fails
        (BPSK and QPSK; 8PSK frames get the DFE alone).
    sent_payload : bytes, optional
        The payload transmitted (from the sidecar), to count bit errors.
    track_t_s, track_v_mps : numpy.ndarray, optional
        The eq 9 speed track over the frame: when given, compensation follows
        its least-squares line through ``v_mps`` (the frame's acceleration),
        not the constant ``v_mps``.
    """
    if track_t_s is not None and len(track_t_s) >= 8:
        # the eq 9 track smoothed to a straight line (constant acceleration over the frame),
        # through the mean speed v_mps: eq 10–11 driven by it
        t = np.asarray(track_t_s, dtype=float)
        slope = float(np.polyfit(t - t.mean(), np.asarray(track_v_mps, dtype=float), 1)[0])
        grid = t_start_s + np.linspace(0.0, config.frame_duration_s, 16)
        comp = compensate_frame(
            bb, fs, t0_s, config=config, pilot=pilot, t_start_s=t_start_s, sound_speed_mps=sound_speed_mps,
            track_t_s=grid, track_v_mps=v_mps + slope * (grid - t.mean()),
        )
    else:
        comp = compensate_frame(
            bb, fs, t0_s, config=config, pilot=pilot, t_start_s=t_start_s, sound_speed_mps=sound_speed_mps, v_mps=v_mps
        )
    if config.modulation not in ("bpsk", "qpsk"):
        passes = 1
    res = decode_frame(bb, fs, t0_s, comp, config, pilot, settings=settings, passes=passes)
    ber = raw_ber = math.nan
    if sent_payload is not None and len(sent_payload) <= config.capacity_bytes:
        sent_info = info_block(sent_payload, config)
        ber = float(np.mean(res.decoded.info_bits != sent_info))
        sent_air = encode_info(sent_info, config)
        hard = symbols_to_bits(res.dfe.decisions[config.n_pilot :], config.modulation)[: sent_air.size]
        raw_ber = float(np.mean(hard != sent_air[: hard.size]))
    return FrameDecode(
        payload=res.decoded.payload if res.decoded.crc_ok else b"",
        crc_ok=bool(res.decoded.crc_ok),
        eq_snr_db=res.dfe.snr_db,
        passes=res.passes,
        ber=ber,
        raw_ber=raw_ber,
        compensated=comp,
        equalized=res.dfe.soft[config.n_pilot :],
        info_bits=np.asarray(res.decoded.info_bits),
    )


def decode_through_echoes(
    bb: np.ndarray,
    fs: float,
    t0_s: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    first: FrameDecode,
    delays_s,
    first_s: float,
    v_mps: float,
    sound_speed_mps: float,
    settings: DfeSettings | None = None,
    passes: int = 3,
    sent_payload: bytes | None = None,
    iterations: int = 2,
    max_iterations: int | None = None,
) -> FrameDecode:
    """Second decoding pass of a frame whose CRC failed: every echo cancelled at its own Doppler.

    The first pass's decoder decisions (re-encoded: pilots and every data
    symbol) are the reference of a whole-frame fit of each resolved path's
    delay, gain, Doppler and drift (:func:`~seamodem.receive.wholeframe.fit_whole_frame`).
    Every path but the direct one is synthesized at its own delay, gain and
    Doppler (:func:`~seamodem.receive.compensate.echo_contributions`) and
    subtracted from the baseband (SAGE-style interference cancellation), and
    the cleaned signal is compensated at the direct path's fitted Doppler and
    drift, equalised and decoded again. Until the CRC passes, this repeats
    from the new decisions, up to ``iterations`` times (the equaliser's output
    SNR is no guide: on fading corpus frames a pass that left it flat took the
    BER from 0.34 to 0.09, and the next decoded), and then on, up to
    ``max_iterations``, while the fits explain the frame better and better:
    the k-th fit's paths' power over its residual (k = 0 first) at least
    :data:`ECHO_CANCEL_PROGRESS` ** (k − 1) times the second's, the first
    made on a cancelled pass's decisions (decisions that improve make the
    fit's reference better, and the power grows; on decisions that are noise
    it wanders about where it started), and the decoder's decisions still
    change. A lone resolved path is left as it is (nothing to cancel).

    Parameters
    ----------
    first : FrameDecode
        The first pass (its ``info_bits`` are the decisions).
    delays_s : array_like
        Frame-start arrival of each resolved path [s] (pilot fit with echoes).
    first_s : float
        The direct path's arrival [s].
    v_mps : float
        Starting closing speed of every path [m/s] (the first pass's).
    max_iterations : int, optional
        Most passes in all (default ``iterations``: none on progress). Beyond ``iterations``, a pass is run
        on progress from the third on: the second fit is the reference.

    Returns
    -------
    FrameDecode
        The first decode whose CRC passed, else ``first`` unchanged; its
        ``passes`` count every equaliser pass run on the frame (first pass
        included), so a count beyond ``passes`` says the echoes were cancelled.
    """
    from ..transmit.modulation import bits_to_symbols
    from .compensate import echo_contributions
    from .wholeframe import fit_whole_frame

    c = sound_speed_mps
    pilot = np.asarray(pilot, dtype=complex)
    delays = np.asarray(delays_s, dtype=float)
    dec, used = first, first.passes
    previous = first.info_bits
    v = v_mps
    if delays.size < 2:
        return first  # a lone resolved path: nothing to cancel
    explained = math.nan  # the second fit's explained power (the first on a cancelled pass's decisions)
    for it in range(max(iterations, max_iterations or 0)):
        if dec.info_bits is None:
            break
        data = bits_to_symbols(encode_info(np.asarray(dec.info_bits), config), config.modulation)[: config.n_data]
        reference = np.ones(config.n_pilot + config.n_data, bool)
        symbols = np.concatenate([pilot, data])
        try:
            wf = fit_whole_frame(bb, fs, t0_s, config=config, symbols=symbols, reference=reference, delays_s=delays,
                                 v_mps=v, sound_speed_mps=c)
        except ValueError:
            break
        power = float(np.sum(np.abs(wf.amplitudes) ** 2) / wf.noise_var) if wf.noise_var > 0 else math.nan
        if it == 1:
            explained = power
        if it >= max(iterations, 2) and not power >= ECHO_CANCEL_PROGRESS ** (it - 1) * explained:
            break  # beyond the passes always run, only while the fits explain the frame better and better
        d = int(np.argmin(np.abs(wf.delays_s - first_s)))
        others = [p for p in range(len(wf.delays_s)) if p != d]
        lo, contrib = echo_contributions(len(bb), fs, t0_s, config=config, symbols=symbols, fit=wf, paths=others,
                                         sound_speed_mps=c)
        clean = bb.copy()
        clean[lo : lo + contrib.size] -= contrib
        grid = float(wf.delays_s[d]) + np.linspace(0.0, config.frame_duration_s, 16)
        v_d, a_d = float(wf.v_mps[d]), float(wf.accel_mps2[d])
        dec = decode_received(
            clean, fs, t0_s, config=config, pilot=pilot, t_start_s=float(wf.delays_s[d]), v_mps=v_d,
            sound_speed_mps=c, settings=settings, passes=passes, sent_payload=sent_payload,
            track_t_s=grid, track_v_mps=v_d + a_d * (grid - grid.mean()),
        )
        used += dec.passes
        if dec.crc_ok:
            break
        if it + 1 >= iterations and np.array_equal(dec.info_bits, previous):
            break  # the same decisions again: the next fit would be this one
        previous = dec.info_bits
        delays, first_s, v = wf.delays_s, float(wf.delays_s[d]), v_d
    # a frame the cancellation did not recover keeps its first pass (its decisions feed the whole-frame
    # Doppler fit and its σ rules, frame.py), with the passes run counted
    return dataclasses.replace(dec if dec.crc_ok else first, passes=used)


def demodulate(
    m: FrameMeasurement,
    bb: np.ndarray,
    t0_s: float,
    fs: float,
    *,
    config: FrameConfig,
    pilot: np.ndarray,
    settings: ReceiverSettings,
    sent_payload: bytes | None = None,
) -> FrameDecode | None:
    """Payload of a measured frame, as ``settings`` ask (None when not decoding or the frame is cut).

    Compensation runs at the frame's mean speed
    (:attr:`FrameMeasurement.compensation_speed_mps`), along its eq 9 track when
    ``settings.follow_track``. When the CRC fails, every resolved echo is
    cancelled at its own delay, gain and Doppler and the frame decoded again
    (:func:`decode_through_echoes`, up to :data:`ECHO_CANCEL_ITERATIONS` times);
    frames that decode first time are untouched.
    """
    if not settings.decode or not m.complete:
        return None
    dec = decode_received(
        bb,
        fs,
        t0_s,
        config=config,
        pilot=pilot,
        t_start_s=m.pilot.t_start_s,
        v_mps=m.compensation_speed_mps,
        sound_speed_mps=settings.sound_speed_mps,
        settings=settings.equalizer,
        passes=settings.turbo_passes,
        sent_payload=sent_payload,
        track_t_s=m.track_t_s if settings.follow_track else None,
        track_v_mps=m.track_v_mps if settings.follow_track else None,
    )
    if dec.crc_ok or ECHO_CANCEL_ITERATIONS < 1 or config.modulation not in ("bpsk", "qpsk"):
        return dec
    # second pass: the echoes, each at its own delay and Doppler, cancelled with the first pass's decisions
    from .multipath import find_echoes

    c = settings.sound_speed_mps
    paths = m.echoes if m.echoes is not None else find_echoes(bb, fs, t0_s, config=config, pilot=pilot, paths=m.paths,
                                                              eps=m.pilot.v_mps / c)
    return decode_through_echoes(
        bb, fs, t0_s, config=config, pilot=pilot, first=dec, delays_s=paths.delays_s, first_s=paths.first_s,
        v_mps=m.compensation_speed_mps, sound_speed_mps=c, settings=settings.equalizer,
        passes=settings.turbo_passes, sent_payload=sent_payload, iterations=ECHO_CANCEL_ITERATIONS,
        max_iterations=ECHO_CANCEL_MAX_ITERATIONS,
    )


def payload_fields(dec: FrameDecode | None) -> dict:
    """The record's payload columns from a FrameDecode (or none, when the frame was not decoded)."""
    if dec is None:
        return {}
    text = ""
    if dec.crc_ok:
        try:
            text = dec.payload.decode("utf-8")
        except UnicodeDecodeError:
            text = ""
        if not text.isprintable():
            text = ""
    return {
        "crc_ok": dec.crc_ok,
        "payload_hex": dec.payload.hex() if dec.crc_ok else "",
        "payload_text": text,
        "eq_snr_db": dec.eq_snr_db,
        "decode_passes": dec.passes,
        "ber": dec.ber,
        "raw_ber": dec.raw_ber,
    }
