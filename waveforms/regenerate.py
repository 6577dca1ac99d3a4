"""Regenerate the reference waveforms: `python waveforms/regenerate.py` from the repository root.

Each preset gets a two-frame beacon recording (frames 0.5 s apart, float32) and
its sidecar. tests/test_waveforms.py checks that running these commands again
gives identical samples.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: The `seamodem` arguments that make each reference file (output path last).
REFERENCES = {
    name: ["tx", "--preset", name, "--count", "2", "--period", "0.5",
           "--payload-text", f"seamodem {name} reference frame {{index}}", "-q", "-o"]
    for name in ("jmse2024", "oceans2021")
}


def regenerate(folder: Path = HERE) -> list[Path]:
    from seamodem.cli import main

    written = []
    for name, args in REFERENCES.items():
        out = folder / f"{name}.wav"
        try:  # record a repository-relative path in the sidecar's command when possible
            shown = out.resolve().relative_to(HERE.parent)
        except ValueError:
            shown = out
        if main([*args, str(shown if folder == HERE else out)]) != 0:
            raise SystemExit(f"failed to regenerate {out}")
        written.append(out)
    return written


if __name__ == "__main__":
    import os

    os.chdir(HERE.parent)
    for path in regenerate(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE):
        print(f"wrote {path} and {path.with_suffix('.json')}")
