"""Where the ``.mat`` reader and the recording source lived: their names, kept importable.

The ``.mat`` format is read by :mod:`seamodem.io.matlab`; every recording,
``.mat`` or audio file or stream, through :mod:`seamodem.io.source`.
"""

from __future__ import annotations

from .matlab import MAT_RATE_NAMES, is_mat
from .source import BLOCK, RecordingSource, open_recording, read_recording
from .wav import RecordingWarning

__all__ = ["MAT_RATE_NAMES", "BLOCK", "RecordingSource", "open_recording", "read_recording", "is_mat", "RecordingWarning"]
