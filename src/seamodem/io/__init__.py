"""File input and output: WAV recordings, JSON sidecars, atomic writes."""

from .files import atomic_outputs, check_writable
from .sidecar import SIDECAR_FORMAT, read_sidecar, sidecar_path, write_json
from .wav import SUBTYPES, read_wav, wav_info, write_wav_blocks

__all__ = [
    "atomic_outputs",
    "check_writable",
    "SIDECAR_FORMAT",
    "read_sidecar",
    "sidecar_path",
    "write_json",
    "SUBTYPES",
    "read_wav",
    "wav_info",
    "write_wav_blocks",
]
