"""``seamodem plot``: PSD, waveform and spectrogram of a recording, as PNG."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..config import FrameConfig
from ..io.files import atomic_outputs
from ._common import output_path


def add_parser(sub) -> None:
    p = sub.add_parser(
        "plot",
        help="plot a recording's PSD, waveform and spectrogram (PNG)",
        description=(
            "Power spectral density of the whole file (Welch), waveform envelope, and a spectrogram of a "
            "window. With a sidecar beside the WAV, the data band and the tone are marked."
        ),
    )
    p.add_argument("recording", metavar="FILE.wav")
    p.add_argument("-o", "--output", metavar="OUT.png", help="default: FILE.png beside the recording")
    p.add_argument("--channel", type=int, help="channel of a multichannel file")
    p.add_argument("--start", type=float, default=0.0, metavar="SECONDS", help="spectrogram window start (default 0)")
    p.add_argument("--duration", type=float, default=2.0, metavar="SECONDS", help="spectrogram window length (default 2 s)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..io.sidecar import read_sidecar, sidecar_path
    from ..io.wav import read_wav
    from ..plots import plot_recording

    wav = Path(args.recording)
    out = output_path(args.output or wav.with_suffix(".png"), ".png")
    x, fs = read_wav(wav, channel=args.channel)
    config = None
    if sidecar_path(wav).is_file():
        config = FrameConfig.from_dict(read_sidecar(sidecar_path(wav))["config"])
    with atomic_outputs(out) as (tmp,):
        plot_recording(x, fs, tmp, config=config, title=wav.name, start_s=args.start, duration_s=args.duration)
    print(f"wrote {out}")
    return 0
