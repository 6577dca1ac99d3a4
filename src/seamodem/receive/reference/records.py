"""The reference receiver's records: a fitted detection (:class:`FittedPing`) and its measurement record."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ...transmit.reference import ReferenceWaveform
from ..records import MeasurementRecord
from .detect import ReferenceDetection
from .fit import ReferenceFit

__all__ = ["ReferenceRecord", "REFERENCE_FIELDS", "FittedPing", "to_record"]


@dataclass(frozen=True)
class ReferenceRecord(MeasurementRecord):
    """A :class:`MeasurementRecord` (same columns, same meanings) plus what a reference detection adds.

    The tone columns (``v_r_tone_eq9_mps``, ``tone_c_n0_dbhz``) are NaN; ``v_r_mps``
    and ``v_r_bank_mps`` are both the bank + dichotomy estimate.

    Parameters
    ----------
    **measurement
        Every :class:`MeasurementRecord` column.
    reference : str
        Name of the reference that matched.
    channel : int
        Recording channel the measurement comes from (the best one when all are searched).
    e_n0_db : float
        Measured E/N0 of the ping [dB].
    misfit : float
        Residual χ² per sample over the noise (≈ 1 when only noise is left); σ's are inflated by √misfit.
    role : str
        "ping", "preamble" or "postamble". For a chirp of a packet (pre/postamble pair or trains),
        ``t_arrival_s`` (and so ``tof_s``, ``range_m`` and ``sigma_range_m``) uses the packet's Doppler to
        place the arrival on the ping's delay–Doppler ridge when that is the more accurate, and so do
        ``v_r_mps`` and ``sigma_v_r_mps``: the packet's Doppler at the chirp (``v_r_source`` "packet"; the
        ping's own Doppler stays in ``v_r_bank_mps``).
    train_position : int
        The chirp's place in its train (0: first; always 0 for a lone ping).
    v_r_pair_mps, sigma_v_r_pair_mps : float
        The packet's mean Doppler over its span from the chirps' measured spacings (pre/postamble, trains)
        and its σ [m/s] (NaN for lone pings).
    clipped_samples : int
        Clipped input samples within the ping.
    """

    reference: str = ""
    channel: int = 0
    e_n0_db: float = math.nan
    misfit: float = math.nan
    role: str = "ping"
    train_position: int = 0
    v_r_pair_mps: float = math.nan
    sigma_v_r_pair_mps: float = math.nan
    clipped_samples: int = 0


REFERENCE_FIELDS = tuple(f.name for f in dataclasses.fields(ReferenceRecord))


@dataclass
class FittedPing:
    """One fitted detection, before it is tied to an emission (what :meth:`~seamodem.receive.reference.ReferenceReceiver.run` yields).

    :func:`~seamodem.receive.reference.pair_up` fills the pair fields in place;
    :func:`to_record` turns it into a :class:`ReferenceRecord`.

    Parameters
    ----------
    reference : ReferenceWaveform
        The reference that matched.
    detection : ReferenceDetection
        The coarse detection.
    fit : ReferenceFit
        The fine fit.
    channel : int
        Channel it was found on (index into the channels fed to the receiver, then the recording's).
    clipped : int
        Clipped input samples within the ping.
    role : str
        "ping", "preamble" or "postamble".
    eps_pair, sigma_eps_pair : float
        Doppler scale ε of its packet, the mean over the packet from the chirps' spacings, and its σ (NaN
        for lone pings).
    eps_chirp, sigma_eps_chirp : float
        The packet's ε at this chirp's emission (its change over the packet fitted, within the acceleration
        prior) and its σ (NaN for lone pings).
    t_pair_s, sigma_t_pair_s : float
        Arrival placed on the ridge at the packet's ε, and its σ [s] (NaN for lone pings).
    train_position : int
        Place of the chirp in its train (0: the first).
    offset_s : float
        Emission offset of the chirp from its packet's first chirp [s].
    """

    reference: ReferenceWaveform
    detection: ReferenceDetection
    fit: ReferenceFit
    channel: int
    clipped: int = 0
    role: str = "ping"
    eps_pair: float = math.nan
    sigma_eps_pair: float = math.nan
    t_pair_s: float = math.nan
    sigma_t_pair_s: float = math.nan
    eps_chirp: float = math.nan
    sigma_eps_chirp: float = math.nan
    train_position: int = 0
    offset_s: float = 0.0


def to_record(f: FittedPing, emissions, *, sound_speed_mps: float, clock_offset_s: float = 0.0, source: str = "") -> ReferenceRecord:
    """The measurement record of one fitted detection, tied to its emission.

    Parameters
    ----------
    f : FittedPing
        The fitted detection (paired or not).
    emissions : Emissions or None
        When the reference was emitted (:class:`~seamodem.receive.settings.Emissions`); None: unknown
        (frame index −1, range NaN).
    sound_speed_mps : float
        c [m/s].
    clock_offset_s : float
        Receiver clock minus beacon clock [s].
    source : str
        The record's ``source`` column.

    Returns
    -------
    ReferenceRecord
        Range, Doppler, σ's and the reference's own columns.
    """
    c = sound_speed_mps
    fit = f.fit
    if math.isfinite(f.t_pair_s) and f.sigma_t_pair_s < fit.sigma_t_s:
        fit = dataclasses.replace(fit, t_arrival_s=f.t_pair_s, sigma_t_s=f.sigma_t_pair_s)
    if emissions is None:
        k, t_emit = -1, math.nan
    else:
        k, t_emit = emissions.frame_for(fit.t_arrival_s - f.offset_s - clock_offset_s)
        if k >= 0:
            t_emit += f.offset_s
    tof = fit.t_arrival_s - t_emit - clock_offset_s
    eps, sigma_eps, source = fit.eps, fit.sigma_eps, "bank"
    if math.isfinite(f.eps_chirp) and f.sigma_eps_chirp < fit.sigma_eps:
        eps, sigma_eps, source = f.eps_chirp, f.sigma_eps_chirp, "packet"
    return ReferenceRecord(
        frame_index=k,
        t_emit_s=t_emit,
        t_arrival_s=fit.t_arrival_s,
        tof_s=tof,
        range_m=c * tof,
        v_r_mps=eps * c,
        snr_db=fit.snr_db,
        v_r_tone_eq9_mps=math.nan,
        v_r_bank_mps=fit.eps * c,
        v_r_source=source,
        n_paths=fit.n_paths,
        detection_z=f.detection.z,
        detection_rho=f.detection.rho,
        sigma_range_m=c * fit.sigma_t_s,
        sigma_v_r_mps=c * sigma_eps,
        sigma_v_r_bank_mps=c * fit.sigma_eps,
        tone_c_n0_dbhz=math.nan,
        source=source,
        reference=f.reference.name,
        channel=f.channel,
        e_n0_db=10 * math.log10(max(fit.e_n0, 1e-30)),
        misfit=fit.misfit,
        role=f.role,
        train_position=f.train_position,
        v_r_pair_mps=f.eps_pair * c,
        sigma_v_r_pair_mps=f.sigma_eps_pair * c,
        clipped_samples=f.clipped,
    )
