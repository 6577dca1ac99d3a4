"""Receiver: front end, detection, time of flight, Doppler, compensation, measurement records.

From a hydrophone recording to one :class:`MeasurementRecord` per frame
(SPEC §4): :func:`receive_file` (or :class:`Receiver` on blocks of samples)
yields them as frames are found; :func:`write_measurements` /
:func:`read_measurements` store them as CSV or JSON Lines;
:func:`compensate_frame` returns a frame's Doppler-compensated symbols for the
equaliser.
"""

from .bounds import (
    delay_crlb_s,
    gabor_bandwidth_hz,
    pilot_velocity_crlb_mps,
    tone_c_n0_hz,
    tone_frequency_crlb_hz,
    tone_velocity_crlb_mps,
)
from .compensate import CompensatedFrame, compensate_frame
from .detect import Detection, PilotDetector, pilot_template
from .doppler import PilotFit, ToneFit, fit_pilot, matched_filter, tone_frequency_ml, tone_track_eq9
from .frontend import FrontEnd, FrontEndPlan, plan_front_end
from .receiver import Emissions, FrameMeasurement, Receiver, ReceiverWarning, measure_frame, receive_file
from .records import MeasurementRecord, read_measurements, write_measurements
from .two_way import two_way_range_m

__all__ = [
    "delay_crlb_s",
    "gabor_bandwidth_hz",
    "pilot_velocity_crlb_mps",
    "tone_c_n0_hz",
    "tone_frequency_crlb_hz",
    "tone_velocity_crlb_mps",
    "CompensatedFrame",
    "compensate_frame",
    "Detection",
    "PilotDetector",
    "pilot_template",
    "PilotFit",
    "ToneFit",
    "fit_pilot",
    "matched_filter",
    "tone_frequency_ml",
    "tone_track_eq9",
    "FrontEnd",
    "FrontEndPlan",
    "plan_front_end",
    "Emissions",
    "FrameMeasurement",
    "Receiver",
    "ReceiverWarning",
    "measure_frame",
    "receive_file",
    "MeasurementRecord",
    "read_measurements",
    "write_measurements",
    "two_way_range_m",
]
