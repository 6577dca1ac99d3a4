"""``seamodem config``: show, check or write a frame configuration."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..config import PRESET_NOTES, PRESETS, config_text
from ..io.files import atomic_outputs, check_writable
from ._common import add_config_options, config_from_args


def add_parser(sub) -> None:
    p = sub.add_parser(
        "config",
        help="show, check or write a frame configuration",
        description="Print the configuration that --preset/--config/--set give (TOML), with its derived figures.",
    )
    add_config_options(p)
    p.add_argument("--list", action="store_true", help="list the presets and where their values come from, and the JANUS parameter sets")
    p.add_argument("-o", "--output", metavar="FILE", help="write the configuration to FILE (.toml or .json)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.list:
        for name in PRESETS:
            print(f"{name}: {PRESET_NOTES[name]}")
        from .janus import parameter_sets_text

        print(parameter_sets_text())
        return 0
    config = config_from_args(args)
    if args.output:
        out = check_writable(Path(args.output))
        with atomic_outputs(out) as (tmp,):
            tmp.write_text(config_text(config, out.suffix), encoding="utf-8")
        print(f"wrote {out}")
        return 0
    print(config.to_toml(), end="")
    lo, hi = config.data_band_hz
    print(
        f"# derived: T_F = {config.frame_duration_s * 1e3:.3f} ms, {config.samples_per_symbol:.4f} samples/symbol, "
        f"data band {lo:g}–{hi:g} Hz, capacity {config.capacity_bytes} bytes/frame"
    )
    return 0
