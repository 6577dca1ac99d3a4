"""File input and output: WAV recordings, JSON sidecars, the checked block reader, atomic writes.

Names are imported on first use, so that ``seamodem.io.files`` alone does not
bring in numpy or soundfile.
"""

from .._lazy import exports, lazy_module

_EXPORTS = exports(
    {
        "files": ("atomic_outputs", "check_writable"),
        "sidecar": ("SIDECAR_FORMAT", "read_sidecar", "sidecar_path", "write_json"),
        "wav": ("SUBTYPES", "read_wav", "wav_info", "write_wav_blocks"),
        "blocks": ("BlockStats", "read_blocks"),
    }
)
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_module(__name__, _EXPORTS, globals())
