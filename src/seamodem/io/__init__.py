"""File input and output: recordings (files and streams, one source interface), JSON sidecars, atomic writes,
the tables seamodem writes read with stable types.

Names are imported on first use, so that ``seamodem.io.files`` alone does not
bring in numpy or soundfile.
"""

from .._lazy import exports, lazy_module

_EXPORTS = exports(
    {
        "files": ("atomic_outputs", "check_writable"),
        "sidecar": ("SIDECAR_FORMAT", "read_sidecar", "sidecar_path", "write_json"),
        "wav": ("SUBTYPES", "RecordingWarning", "read_wav", "wav_info", "write_wav_blocks"),
        "source": ("BLOCK", "BlockStats", "RecordingSource", "open_recording", "read_recording"),
        "stream": ("StreamSource", "open_stream"),
        "blocks": ("read_blocks",),
        "tables": ("read_table", "table_schema"),
    }
)
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_module(__name__, _EXPORTS, globals())
