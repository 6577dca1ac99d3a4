"""Receiver: front end, detection, time of flight, Doppler, demodulation, measurement records.

From a hydrophone recording to one :class:`MeasurementRecord` per frame
(SPEC §4), one module per job: :mod:`.settings` (what the receiver is told),
:mod:`.measure` (one frame's arrival, Doppler and SNR), :mod:`.frame` (one detected frame
to its record: :class:`FrameMeasurer`), :mod:`.stream` (the block-fed
:class:`Receiver`), :mod:`.array` (hydrophone arrays), :mod:`.demodulate` (compensation,
equalisation, payload), :mod:`.recording` (:func:`receive_file`).
:func:`write_measurements` / :func:`read_measurements` store the records as
CSV or JSON Lines.

Names are imported on first use: ``seamodem.receive.settings`` alone (what the
command line needs to check its options) does not bring in scipy or numba.
"""

from .._lazy import exports, lazy_module

_EXPORTS = exports(
    {
        "bounds": (
            "delay_crlb_s",
            "gabor_bandwidth_hz",
            "pilot_velocity_crlb_mps",
            "tone_c_n0_hz",
            "tone_frequency_crlb_hz",
            "tone_velocity_crlb_mps",
        ),
        "compensate": ("CompensatedFrame", "compensate_frame"),
        "demodulate": ("FrameDecode", "decode_frame", "decode_received", "demodulate", "fractional_samples"),
        "detect": ("Detection", "PilotDetector", "pilot_template"),
        "doppler": ("PilotFit", "ToneFit", "fit_pilot", "matched_filter", "tone_frequency_ml", "tone_track_eq9"),
        "frame": ("BasebandBuffers", "FrameMeasurer"),
        "frontend": ("FrontEnd", "FrontEndPlan", "plan_front_end"),
        "measure": ("FrameMeasurement", "measure_frame"),
        "records": ("MeasurementRecord", "read_measurements", "write_measurements"),
        "recording": ("receive_file",),
        "settings": ("Emissions", "ReceiverSettings", "ReferenceSettings"),
        "stream": ("Receiver", "ReceiverWarning"),
        "two_way": ("two_way_range_m",),
    }
)
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_module(__name__, _EXPORTS, globals())
