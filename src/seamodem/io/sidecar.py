"""The JSON sidecar written beside every WAV: configuration, pilot, schedule, frames.

Layout (``format = "seamodem.sidecar/1"``)::

    {
      "format": "seamodem.sidecar/1",
      "created_by": "seamodem 0.1.0",
      "command": "seamodem tx --preset jmse2024 ...",
      "config": {FrameConfig fields},
      "pilot": {"seed": 1, "bits": "0110..."},           # 0 → +1, 1 → −1
      "schedule": {"count": N, "period_s": T, "start_s": t0},
      "recording": {"file": "OUT.wav", "sample_rate_hz": fs, "n_samples": n,
                    "duration_s": d, "subtype": "FLOAT", "scale": k, "peak": p},
      "frames": [{"frame_index": k, "t_emit_s": t, "payload_hex": "...",
                  "payload_bytes": n}, ...]
    }

``recording.scale``: a WAV sample is scale · s(t), with s in model units (mean
frame power 1). Later stages (channel, receiver) add their own sections and
carry the rest forward unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typing import Any

from ..errors import InputFileError

__all__ = ["SIDECAR_FORMAT", "sidecar_path", "read_sidecar", "write_json", "sidecar_pilot_bits", "sidecar_payloads"]

SIDECAR_FORMAT = "seamodem.sidecar/1"


def sidecar_path(wav_path: str | Path) -> Path:
    """The sidecar that belongs to ``wav_path``: same name, ``.json`` suffix.

    Parameters
    ----------
    wav_path : str or Path
        A recording.

    Returns
    -------
    Path
        ``wav_path`` with its suffix replaced by ``.json``.
    """
    return Path(wav_path).with_suffix(".json")


def write_json(path: str | Path, data: dict[str, Any]) -> None:
    """Write ``data`` as indented UTF-8 JSON, ending in a newline.

    Parameters
    ----------
    path : str or Path
        Output file, overwritten.
    data : dict
        JSON-serializable mapping (e.g. a sidecar).
    """
    Path(path).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


def read_sidecar(path: str | Path) -> dict[str, Any]:
    """Read and check a sidecar.

    Parameters
    ----------
    path : str or Path
        The sidecar JSON file (see :func:`sidecar_path`).

    Returns
    -------
    dict
        The sidecar, with its ``format`` checked and its ``config``,
        ``pilot``, ``schedule``, ``recording`` and ``frames`` sections present.

    Raises
    ------
    InputFileError
        Missing file, invalid JSON, or not a seamodem sidecar.
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(f"sidecar not found: {path}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputFileError(f"sidecar {path} is not valid JSON: {exc}") from None
    except UnicodeDecodeError as exc:
        raise InputFileError(f"sidecar {path} is not UTF-8 text (byte {exc.start}): not a sidecar, or damaged") from None
    if not isinstance(data, dict) or data.get("format") != SIDECAR_FORMAT:
        raise InputFileError(f"{path} is not a seamodem sidecar (format {SIDECAR_FORMAT!r} expected)")
    for key, kind in (("config", dict), ("pilot", dict), ("schedule", dict), ("recording", dict), ("frames", list)):
        if key not in data:
            raise InputFileError(f"sidecar {path} lacks its {key!r} section")
        if not isinstance(data[key], kind):
            raise InputFileError(f"sidecar {path}: its {key!r} section is not a JSON {'object' if kind is dict else 'list'}")
    return data


def sidecar_pilot_bits(sidecar: dict[str, Any]) -> np.ndarray | None:
    """The pilot bits the sidecar records (0 → +1, 1 → −1), or None when it records none."""
    text = (sidecar.get("pilot") or {}).get("bits")
    if not isinstance(text, str) or not text or set(text) - {"0", "1"}:
        return None
    return np.array([int(ch) for ch in text], dtype=np.uint8)


def sidecar_payloads(sidecar: dict[str, Any]) -> list[bytes] | None:
    """Each frame's payload, by frame index, or None when a frame lacks a valid ``payload_hex``."""
    try:
        return [bytes.fromhex(f["payload_hex"]) for f in sidecar["frames"]]
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
