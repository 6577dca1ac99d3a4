"""The JANUS receiver: a recording in, one record per packet decoded with a valid CRC out.

Per candidate preamble (:mod:`.detect`): its arrival and time scale from the preamble's known
chips (:mod:`.measure`), the base packet demodulated and decoded there (:mod:`.demod`), the CRC
and the decoded path's margin checked, then the whole packet (preamble + base packet, + cargo
once decoded) refitted as known chips for the arrival time and the time scale that give
range and v_r.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...transmit.janus import (
    JanusPacket,
    JanusParameterSet,
    PREAMBLE_BITS,
    crc8,
    get_parameter_set,
    hop_slots,
    packet_chip_bits,
)
from ..settings import Emissions
from .demod import decode_block
from .detect import DETECTION_THRESHOLD, find_preambles, refine_candidate
from .frontend import to_baseband
from .measure import fit_delay_scale
from .records import JanusRecord

__all__ = ["JanusSettings", "receive_janus", "receive_segment", "MIN_MARGIN", "MIN_CARGO_MARGIN"]

#: the base packet's decoded-path margin (Es/N0 along the decoded codeword) a packet needs besides its CRC:
#: noise gives 0.83 (median), 1.2 at most in 20 000 decodings (benchmarks/bench_janus.py); a packet at -18 dB
#: over 0..fs/2 gives 2-2.6
MIN_MARGIN = 1.5
#: the cargo's margin for its chips to join the whole-packet fit (no CRC protects the cargo)
MIN_CARGO_MARGIN = 1.5
_N_BASE_CHIPS = 144
#: arrival searched ± this many baseband samples about the detector's start: its tone-share peak is
#: flat over a few samples at low SNR (a tenth of a chip)
_TAU_SPAN_SAMPLES = 4.0
#: below this coherence (coherent over non-coherent Es/N0) the packet's phase did not follow the model
_MIN_COHERENCE = 0.05


@dataclass(frozen=True, kw_only=True)
class JanusSettings:
    """What the JANUS receiver is told.

    Parameters
    ----------
    pset : JanusParameterSet
        Parameter set (default: set 1).
    sound_speed_mps : float
        c [m/s].
    v_max_mps : float
        Largest |v_r| searched [m/s].
    threshold : float
        Preamble statistic for a candidate (noise: 1 ± 0.18).
    min_margin : float
        Decoded-path margin the base packet needs besides its CRC.
    emissions : Emissions, optional
        When packets were sent (their preamble's first chip); without, tof and range are NaN.
    clock_offset_s : float
        Receiver clock minus beacon clock [s], taken off every time of flight.
    """

    pset: JanusParameterSet | None = None
    sound_speed_mps: float = 1500.0
    v_max_mps: float = 5.0
    threshold: float = DETECTION_THRESHOLD
    min_margin: float = MIN_MARGIN
    emissions: Emissions | None = None
    clock_offset_s: float = 0.0

    def __post_init__(self):
        if self.pset is None:
            object.__setattr__(self, "pset", get_parameter_set(1))
        if not 1000 <= self.sound_speed_mps <= 2000:
            raise ValueError(f"sound_speed_mps must be in [1000, 2000], got {self.sound_speed_mps!r}")
        if not 0 <= self.v_max_mps <= 50:
            raise ValueError(f"v_max_mps must be in [0, 50], got {self.v_max_mps!r}")


def _record(packet: JanusPacket, fit, pre, base, cargo_dec, settings: JanusSettings, stat: float,
            coherence: float) -> JanusRecord:
    c = settings.sound_speed_mps
    fields = packet.fields()
    t_beacon = fit.tau_s - settings.clock_offset_s  # the arrival on the beacon's clock
    frame_index, t_emit = (-1, math.nan) if settings.emissions is None else settings.emissions.frame_for(t_beacon)
    tof = t_beacon - t_emit
    text = ""
    if cargo_dec is not None:
        stripped = cargo_dec.data.rstrip(b"\0")
        if stripped and all(32 <= b < 127 for b in stripped):
            text = stripped.decode("ascii")
    snr_inband = fit.snr_chip / (settings.pset.chip_s * settings.pset.bandwidth_hz)
    return JanusRecord(
        frame_index=frame_index, t_emit_s=t_emit, t_arrival_s=fit.tau_s, tof_s=tof, range_m=c * tof,
        v_r_mps=c * fit.eps, snr_db=10 * math.log10(max(snr_inband, 1e-30)), v_r_tone_eq9_mps=math.nan,
        v_r_bank_mps=c * pre.eps, detection_z=stat, detection_rho=fit.rho, sigma_range_m=c * fit.sigma_tau_s,
        sigma_v_r_mps=c * fit.sigma_eps, sigma_v_r_bank_mps=c * pre.sigma_eps, tone_c_n0_dbhz=math.nan,
        crc_ok=True, payload_hex=cargo_dec.data.hex() if cargo_dec is not None else "", payload_text=text,
        v_r_source="whole_packet" if coherence >= _MIN_COHERENCE else "whole_packet_incoherent", n_paths=1,
        packet_hex=packet.to_bytes().hex(), version=packet.version, mobility=packet.mobility,
        schedule=packet.schedule, tx_rx=packet.tx_rx, forward=packet.forward, class_user_id=packet.class_user_id,
        application_type=packet.application_type, application_data=packet.application_data,
        station_id=fields.get("station_id", -1), pset_id=fields.get("pset_id", -1),
        cargo_size=fields.get("cargo_size", -1), cargo_hex=cargo_dec.data.hex() if cargo_dec is not None else "",
        cargo_text=text, agreement=base.agreement, margin=base.margin,
        cargo_margin=cargo_dec.margin if cargo_dec is not None else math.nan,
        t_arrival_preamble_s=pre.tau_s, sigma_t_preamble_s=pre.sigma_tau_s,
        scale_eps=fit.eps, coherence=coherence,
    )


def _decode_base(x_bb, fs_bb, pset, pre, cand, min_margin):
    """The base packet at the preamble's (τ, ε), else at the detector's ε; None unless CRC and margin pass."""
    for eps in (pre.eps, cand.scale_eps):
        base = decode_block(x_bb, fs_bb, pset, pre.tau_s * fs_bb, eps, 32, 8)
        if crc8(base.data[:7]) == base.data[7] and base.margin >= min_margin:
            return base
        if abs(cand.scale_eps - pre.eps) < 2e-4:
            break
    return None


def receive_segment(
    x_pb: np.ndarray, fs: float, settings: JanusSettings, *, t0_s: float = 0.0, after_s: float = -np.inf,
    final: bool = True,
) -> tuple[list[JanusRecord], float]:
    """Packets whose preamble starts in a stretch of a recording (the streaming receiver's step).

    Parameters
    ----------
    x_pb : numpy.ndarray, shape (n_samples,)
        Real passband samples; the first is at ``t0_s`` on the recording's clock.
    fs : float
        Sample rate [Hz].
    settings : JanusSettings
        Receiver settings.
    t0_s : float
        Time of ``x_pb[0]`` [s].
    after_s : float
        Preambles starting before this time were dealt with by an earlier stretch [s].
    final : bool
        Nothing follows: packets cut by the end are given up. Otherwise a preamble too close to the
        end for its base packet, or a packet whose cargo runs past the end, is left for the next stretch.

    Returns
    -------
    records : list of JanusRecord
        Times on the recording's clock.
    done_s : float
        Every preamble starting before this time has been dealt with (the next stretch's ``after_s``).
    """
    pset = settings.pset
    x_bb, fs_bb = to_baseband(x_pb, fs, pset)
    end_s = t0_s + len(x_pb) / fs
    # a candidate needs its preamble and base packet inside the stretch, unless nothing follows
    stop_s = end_s if final else end_s - (33 + _N_BASE_CHIPS) * pset.chip_s * 1.01
    candidates = find_preambles(x_bb, fs_bb, pset, v_max_mps=settings.v_max_mps,
                                sound_speed_mps=settings.sound_speed_mps, threshold=settings.threshold, refine=False)
    preamble_tones = 2 * hop_slots(32, pset) + PREAMBLE_BITS
    records: list[JanusRecord] = []
    busy_until = after_s - t0_s
    eps_max = 1.05 * settings.v_max_mps / settings.sound_speed_mps + 1e-4
    for cand in candidates:
        if cand.start / fs_bb < busy_until:
            continue
        if t0_s + cand.start / fs_bb >= stop_s:
            break
        cand = refine_candidate(x_bb, fs_bb, pset, cand, v_max_mps=settings.v_max_mps,
                                sound_speed_mps=settings.sound_speed_mps)
        tau0 = cand.start / fs_bb
        # the tone-share statistic barely sees ε over 32 chips: the coherent fit searches all of ±v_max/c
        pre = fit_delay_scale(x_bb, fs_bb, preamble_tones, pset, fs, tau0, 0.0,
                              tau_span_s=_TAU_SPAN_SAMPLES / fs_bb, eps_span=eps_max)
        base = _decode_base(x_bb, fs_bb, pset, pre, cand, settings.min_margin)
        if base is None:
            continue
        packet = JanusPacket.from_bytes(base.data)
        n_cargo = packet.announced_cargo_bytes
        n_chips = 32 + _N_BASE_CHIPS + (16 * (n_cargo + 1) if n_cargo else 0)
        if not final and t0_s + pre.tau_s + n_chips * pset.chip_s * 1.01 > end_s:
            return records, t0_s + cand.start / fs_bb - pset.chip_s
        tones = 2 * hop_slots(32 + _N_BASE_CHIPS, pset) + np.concatenate([PREAMBLE_BITS, packet_chip_bits(packet)])
        # the preamble's (τ, ε) ambiguity has sidelobes ~1/(fc·0.13 s) apart in ε, and at low SNR one can
        # win: the whole packet searches all of ±v_max again, coherently within 16-chip stretches first
        fit = fit_delay_scale(x_bb, fs_bb, tones, pset, fs, pre.tau_s, 0.0, tau_span_s=_TAU_SPAN_SAMPLES / fs_bb,
                              eps_span=eps_max, segment_chips=16)
        cargo_dec = None
        if n_cargo:
            cargo_dec = decode_block(x_bb, fs_bb, pset, fit.tau_s * fs_bb, fit.eps, 32 + _N_BASE_CHIPS, n_cargo)
            packet = JanusPacket.from_bytes(base.data, cargo_dec.data)
            if cargo_dec.margin >= MIN_CARGO_MARGIN:
                all_bits = np.concatenate([PREAMBLE_BITS, packet_chip_bits(packet)])
                tones = 2 * hop_slots(all_bits.size, pset) + all_bits
                fit = fit_delay_scale(x_bb, fs_bb, tones, pset, fs, fit.tau_s, fit.eps,
                                      tau_span_s=max(4 * fit.sigma_tau_s, 2e-6), eps_span=max(5 * fit.sigma_eps, 1e-7))
        # the coherent fit's Es/N0 against the tones' (non-coherent) Es/N0: ≈ 1 when the packet's phase
        # follows the model; far below when fading or beating echoes turn it: the arrival and the scale
        # are then known to a resolution cell only (1/U in delay, a 16-chip stretch's in scale)
        coherence = fit.snr_chip / max(base.es_n0, 1e-30)
        if coherence < _MIN_COHERENCE:
            fit = replace(fit, sigma_tau_s=max(fit.sigma_tau_s, 1 / pset.used_band_hz),
                          sigma_eps=max(fit.sigma_eps, 1 / (pset.fc_hz * 16 * pset.chip_s)))
        busy_until = fit.tau_s + n_chips * pset.chip_s / (1 + fit.eps) - pset.chip_s
        fit = replace(fit, tau_s=fit.tau_s + t0_s)
        pre = replace(pre, tau_s=pre.tau_s + t0_s)
        records.append(_record(packet, fit, pre, base, cargo_dec, settings, cand.statistic, coherence))
    return records, max(stop_s, t0_s + busy_until)


def receive_janus(x_pb: np.ndarray, fs: float, settings: JanusSettings | None = None) -> list[JanusRecord]:
    """Detect, decode and measure every JANUS packet of a recording held in memory.

    Parameters
    ----------
    x_pb : numpy.ndarray, shape (n_samples,)
        Real passband samples; t = 0 at the first.
    fs : float
        Sample rate [Hz].
    settings : JanusSettings, optional
        Receiver settings (default: parameter set 1, c = 1500 m/s, ±5 m/s).

    Returns
    -------
    list of JanusRecord
        One per packet whose base packet passed the CRC and the margin test, in time order.

    See Also
    --------
    seamodem.receive.janus.stream.JanusReceiver : the same, on a stream of blocks.
    """
    return receive_segment(x_pb, fs, settings or JanusSettings())[0]
