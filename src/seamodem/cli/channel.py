"""``seamodem channel``: pass a beacon recording through a simulated (or measured) channel."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import SeamodemError
from ._common import command_line, output_path


def add_parser(sub) -> None:
    p = sub.add_parser(
        "channel",
        help="simulate the underwater channel: Doppler, multipath, noise, clock errors (WAV + JSON truth)",
        description=(
            "Read IN.wav and its sidecar IN.json, apply the scenario (TOML; see docs/channel.md and "
            "examples/scenarios/), write OUT.wav and OUT.json: the input sidecar carried forward, a "
            "'channel' section (scenario as used, seed, paths, noise) and a 'truth' list per frame "
            "(true arrival, tof, range, mean v_r; SPEC §1). With a [two_way] table the input's frames are "
            "the beacon's replies to the vehicle's polls (two-way ranging; see docs/channel.md)."
        ),
    )
    p.add_argument("input", metavar="IN.wav", help="transmitted recording with its sidecar IN.json beside it")
    p.add_argument("--scenario", required=True, metavar="S.toml", help="scenario file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.wav", help="output WAV; the sidecar is OUT.json")
    p.add_argument("--seed", type=int, help="override the scenario's seed")
    p.add_argument(
        "--array",
        metavar="SPEC",
        help="a hydrophone array on the vehicle (geometry scenarios): tetra[:APERTURE_M], circleN[:APERTURE_M], "
        "lineN[:APERTURE_M] or a TOML/JSON file with an [array] table; OUT.wav gets one channel per element and the truth each path's "
        "azimuth/elevation (see docs/array.md)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..channel import load_scenario
    from ..channel.replay import replay_file
    from ..channel.simulate import simulate_file

    out = output_path(args.output, ".wav")
    if Path(args.input).resolve() == out.resolve():
        raise SeamodemError("output: must differ from the input recording")
    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        if args.seed < 0:
            raise SeamodemError(f"--seed: must be >= 0, got {args.seed}")
        scenario = replace(scenario, seed=args.seed)
    progress = False if args.quiet else None
    if args.array is not None:
        from ..channel.array import load_array, simulate_array_file

        array = load_array(args.array)
        if scenario.mode != "geometry":
            raise SeamodemError(f"array: needs a geometry scenario (paths with directions), got mode {scenario.mode!r}")
        side = simulate_array_file(args.input, scenario, array, out, command=command_line())
        if not args.quiet:
            print(f"wrote {out} ({side['recording']['duration_s']:.2f} s, {array.n_elements} channels, "
                  f"{len(side['channel']['paths'])} paths) and {out.with_suffix('.json')} with the truth of "
                  f"{len(side['truth'])} frames (directions per path)")
        return 0
    if scenario.mode == "replay":
        side = replay_file(args.input, scenario, out, command=command_line(), progress=progress)
    else:
        side = simulate_file(args.input, scenario, out, command=command_line(), progress=progress)
    if not args.quiet:
        ch = side["channel"]
        print(
            f"wrote {out} ({ch['output']['duration_s']:.2f} s, {len(ch['paths'])} paths, noise {ch['noise']['kind']}) "
            f"and {out.with_suffix('.json')} with the truth of {len(side['truth'])} frames"
        )
        if "two_way" in ch:
            print(f"two-way: {len(side['truth'])} polls answered after {ch['two_way']['turnaround_s']:g} s; "
                  f"the frames' t_emit_s are the polls (seamodem rx --turnaround {ch['two_way']['turnaround_s']:g})")
    return 0
