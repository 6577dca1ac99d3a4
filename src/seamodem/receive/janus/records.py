"""The JANUS measurement record: the common record plus the packet's fields."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..records import MeasurementRecord

__all__ = ["JanusRecord", "JANUS_FIELDS"]


@dataclass(frozen=True)
class JanusRecord(MeasurementRecord):
    """One JANUS packet's measurement (:class:`~seamodem.receive.records.MeasurementRecord`) and its fields.

    Attributes
    ----------
    packet_hex : str
        The 8 base-packet bytes.
    version, class_user_id, application_type, application_data : int
        Base-packet fields.
    mobility, schedule, tx_rx, forward : bool
        Flags.
    station_id, pset_id, cargo_size : int
        Class 16 / application type 0 fields (−1 otherwise).
    cargo_hex, cargo_text : str
        Decoded cargo (no CRC protects it), and as text when printable.
    agreement, margin : float
        Decoder metrics of the base packet (:class:`~seamodem.receive.janus.demod.BlockDecision`).
    cargo_margin : float
        The margin of the cargo (NaN without cargo).
    t_arrival_preamble_s, sigma_t_preamble_s : float
        Arrival of the first preamble chip from the preamble alone, and its σ [s].
    scale_eps : float
        Whole-packet time scale ε (v_r = c·ε).
    coherence : float
        The whole-packet fit's Es/N0 over the tones' non-coherent Es/N0: about 1 when the packet's
        phase follows one path's delay and Doppler; below 0.05 (``v_r_source`` then
        ``whole_packet_incoherent``) fading or beating echoes turned it, and σ's are widened to a
        resolution cell.
    """

    packet_hex: str = ""
    version: int = -1
    mobility: bool = False
    schedule: bool = False
    tx_rx: bool = False
    forward: bool = False
    class_user_id: int = -1
    application_type: int = -1
    application_data: int = -1
    station_id: int = -1
    pset_id: int = -1
    cargo_size: int = -1
    cargo_hex: str = ""
    cargo_text: str = ""
    agreement: float = math.nan
    margin: float = math.nan
    cargo_margin: float = math.nan
    t_arrival_preamble_s: float = math.nan
    sigma_t_preamble_s: float = math.nan
    scale_eps: float = math.nan
    coherence: float = math.nan


JANUS_FIELDS = tuple(f.name for f in dataclasses.fields(JanusRecord))
