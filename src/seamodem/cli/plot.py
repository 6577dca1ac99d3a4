"""``seamodem plot``: PSD, waveform and spectrogram of a recording, as PNG, read block by block."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..config import FrameConfig
from ..errors import SeamodemError
from ._common import output_path, reported_warnings

#: spectrogram window [s] when neither --start nor --duration is given
DEFAULT_WINDOW_S = 2.0


def add_parser(sub) -> None:
    p = sub.add_parser(
        "plot",
        help="plot a recording's PSD, waveform and spectrogram (PNG)",
        description=(
            "Power spectral density (Welch) and waveform envelope of the whole file, and a spectrogram of its "
            f"first {DEFAULT_WINDOW_S:g} s; with --start and/or --duration, all three of that span only, and only "
            "that span is read. The file is read in blocks: memory stays bounded whatever its length. With a "
            "sidecar beside the WAV, the data band and the tone are marked."
        ),
    )
    p.add_argument("recording", metavar="FILE.wav")
    p.add_argument("-o", "--output", metavar="OUT.png", help="default: FILE.png beside the recording")
    p.add_argument("--channel", type=int, help="channel of a multichannel file, numbered from 0")
    p.add_argument("--start", type=float, metavar="SECONDS", help="start of the span to plot [s] (default 0)")
    p.add_argument("--duration", type=float, metavar="SECONDS",
                   help=f"length of the span to plot [s] (default {DEFAULT_WINDOW_S:g} with --start)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..io.blocks import channel_blocks
    from ..io.sidecar import read_sidecar, sidecar_path
    from ..io.source import open_recording
    from ..plots import plot_recording_blocks

    wav = Path(args.recording)
    out = output_path(args.output or wav.with_suffix(".png"), ".png")
    with reported_warnings("plot"):
        source = open_recording(wav)
        ch = source.one_channel(args.channel)
        fs, total_s, n = source.sample_rate_hz, source.duration_s, source.n_samples
        whole = args.start is None and args.duration is None
        start_s = 0.0 if args.start is None else args.start
        duration_s = DEFAULT_WINDOW_S if args.duration is None else args.duration
        if not (math.isfinite(start_s) and 0 <= start_s < total_s):
            raise SeamodemError(f"start: must be in [0, {total_s:g}) s (the recording's length), got {start_s!r}")
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise SeamodemError(f"duration: must be > 0 s, got {duration_s!r}")
        config = None
        if sidecar_path(wav).is_file():
            config = FrameConfig.from_dict(read_sidecar(sidecar_path(wav))["config"])
        i0, i1 = (0, n) if whole else (int(start_s * fs), min(int(math.ceil((start_s + duration_s) * fs)), n))
        blocks = channel_blocks(source, ch, start=i0, stop=i1)
        span = "whole file" if whole else f"{i0 / fs:g}–{i1 / fs:g} s"
        plot_recording_blocks(blocks, fs, out, n_samples=i1 - i0, t0_s=i0 / fs,
                              window_s=(start_s, start_s + duration_s), config=config, title=wav.name, span=span)
    print(f"wrote {out}")
    return 0
