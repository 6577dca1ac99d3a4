"""``seamodem ber``: bit- and frame-error rates against SNR through beacon → channel scenario → receiver."""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

from ..errors import ConfigError, SeamodemError
from ..io.files import atomic_outputs, check_writable
from ._common import add_config_options, command_line, config_from_args

FILES = ("ber.csv", "ber.json", "ber.png")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "ber",
        help="sweep SNR over a channel scenario: BER and frame-error rate beside the AWGN theory",
        description=(
            "For each SNR, send --frames random payloads through the scenario's channel (default: AWGN) "
            "with its noise set to that in-band SNR, and let the receiver detect, compensate, equalise "
            "and decode them. Writes DIR/ber.csv (per SNR: frames, detected, DFE and turbo successes, "
            "frame-error rates, raw and decoded BER), DIR/ber.png (curves with the uncoded AWGN theory "
            "Q(sqrt(2Eb/N0))) and DIR/ber.json (the configuration and scenario used)."
        ),
    )
    add_config_options(p)
    p.add_argument("--scenario", metavar="S.toml", help="channel scenario (default: AWGN, one still path)")
    p.add_argument(
        "--snr",
        type=float,
        nargs="+",
        default=[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0],
        metavar="DB",
        help="in-band SNRs [dB] (default 0 1 2 3 4 5 6 8)",
    )
    p.add_argument("--frames", type=int, default=50, help="frames per SNR (default 50)")
    p.add_argument("--period", type=float, metavar="TCOM", help="time between frames [s] (default frame + 0.2 s)")
    p.add_argument("--passes", type=int, default=3, metavar="N", help="most equaliser passes (default 3; 1 = DFE only)")
    p.add_argument("--seed", type=int, default=0, help="seed of the payloads and the channel (default 0)")
    p.add_argument("--workers", type=int, default=1, metavar="N", help="local processes (default 1)")
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the SNR points on a Dask cluster (tcp://HOST:8786; pip install 'seamodem[dask]'); same numbers",
    )
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")
    p.set_defaults(run=run)


def _scenario(path: str | None) -> tuple[dict | None, Path]:
    """The scenario's tables (validated now, for one-line errors before any work) and its folder."""
    if path is None:
        return None, Path(".")
    from ..channel.scenario import parse_scenario, read_scenario_tables

    data = read_scenario_tables(path)
    parse_scenario(data, base_dir=Path(path).parent)
    return data, Path(path).parent


def run(args: argparse.Namespace) -> int:
    from ..studies.ber import ber_sweep, snr_at_fer, theory_ber

    config = config_from_args(args)
    if args.frames < 1:
        raise SeamodemError(f"frames: must be >= 1, got {args.frames}")
    if args.passes < 1:
        raise SeamodemError(f"passes: must be >= 1, got {args.passes}")
    if args.workers < 1:
        raise SeamodemError(f"workers: must be >= 1, got {args.workers}")
    if not all(math.isfinite(s) for s in args.snr):
        raise SeamodemError("snr: every SNR must be a finite number of dB")
    scenario, base_dir = _scenario(args.scenario)
    if scenario is not None and scenario.get("mode") == "geometry" and args.period is None:
        raise ConfigError("period", "give --period with a geometry scenario (the vehicle's path sets the timing)")
    out_dir = Path(args.output)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [check_writable(out_dir / name) for name in FILES]
    snrs = sorted(args.snr)

    points = _sweep(ber_sweep, config, scenario, snrs, args, base_dir)
    rows = [p.row() for p in points]
    theory = theory_ber(snrs, config)
    run_config = {
        "created_by": command_line(),
        "config": config.to_dict(),
        "scenario": scenario or "AWGN (seamodem.studies.ber.AWGN_SCENARIO)",
        "snr_db": snrs,
        "frames": args.frames,
        "period_s": args.period,
        "passes": args.passes,
        "seed": args.seed,
        "backend": "dask" if args.scheduler else ("serial" if args.workers == 1 else "processes"),
    }
    with atomic_outputs(*paths) as (csv_tmp, json_tmp, png_tmp):
        with open(csv_tmp, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=[*rows[0].keys(), "theory_uncoded_ber"])
            writer.writeheader()
            for row, th in zip(rows, theory):
                writer.writerow({**row, "theory_uncoded_ber": float(th)})
        Path(json_tmp).write_text(json.dumps(run_config, indent=2) + "\n", encoding="utf-8")
        plot_ber(png_tmp, points, config, title=(scenario or {}).get("description", "AWGN"))
    if not args.quiet:
        print(format_table(points, theory))
        fer_dfe = snr_at_fer(snrs, [p.fer_dfe for p in points])
        fer_turbo = snr_at_fer(snrs, [p.fer for p in points])
        if math.isfinite(fer_dfe) and math.isfinite(fer_turbo):
            print(f"FER 10 %: DFE at {fer_dfe:.2f} dB, turbo at {fer_turbo:.2f} dB: gain {fer_dfe - fer_turbo:.2f} dB")
        print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0


def _sweep(ber_sweep, config, scenario, snrs, args, base_dir):
    """The sweep on seamodem.batch: serially, on local processes or on a Dask cluster (same numbers)."""
    from functools import partial

    from ..batch.runner import map_tasks

    if args.scheduler:
        backend = "dask"
    else:
        backend = "serial" if args.workers == 1 else "processes"
    mapper = partial(
        map_tasks,
        backend=backend,
        workers=args.workers,
        scheduler=args.scheduler,
        progress=False if args.quiet else None,
    )
    kwargs = dict(frames=args.frames, period_s=args.period, seed=args.seed, passes=args.passes, base_dir=base_dir)
    return ber_sweep(config, scenario, snrs, mapper=mapper, **kwargs)


def format_table(points, theory) -> str:
    lines = [
        f"{'SNR dB':>7} {'frames':>6} {'found':>5} {'FER DFE':>8} {'FER turbo':>9} {'raw BER':>9} "
        f"{'theory':>9} {'BER':>9} {'EQ SNR':>7}",
    ]
    for p, th in zip(points, theory):
        lines.append(
            f"{p.snr_db:7.1f} {p.frames:6d} {p.detected:5d} {p.fer_dfe:8.3f} {p.fer:9.3f} {p.raw_ber:9.2e} "
            f"{th:9.2e} {p.ber:9.2e} {p.mean_eq_snr_db:7.1f}"
        )
    return "\n".join(lines)


def plot_ber(path, points, config, *, title: str = "") -> None:
    """BER (raw and decoded) and FER (DFE, turbo) against SNR, with the uncoded AWGN theory."""
    import numpy as np

    from ..plots import pyplot, save_figure
    from ..studies.ber import theory_ber

    plt = pyplot()
    snr = np.array([p.snr_db for p in points])
    fine = np.linspace(snr.min() - 1, snr.max() + 1, 200)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    bit_floor = 0.5 / max(1, max(p.air_bits for p in points))
    frame_floor = 0.5 / max(p.frames for p in points)

    def curve(ax, values, style, label, floor):
        """Measured points; a zero count is drawn as ▽ at the floor (below what the run can show)."""
        v = np.asarray(values, dtype=float)
        line = ax.semilogy(snr, np.where(v > 0, v, np.nan), style, label=label)[0]
        zero = v == 0
        if zero.any():
            ax.semilogy(snr[zero], np.full(zero.sum(), floor), "v", color=line.get_color(), alpha=0.6)

    a.semilogy(fine, theory_ber(fine, config), "k-", lw=1, label=f"theory, uncoded {config.modulation.upper()}")
    curve(a, [p.raw_ber for p in points], "o-", "before decoding (DFE decisions)", bit_floor)
    curve(a, [p.ber for p in points], "s-", "after decoding", bit_floor)
    a.set(xlabel="in-band SNR [dB]", ylabel="bit error rate", title="BER (▽: no error seen)", ylim=(bit_floor / 2, 0.6))
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    curve(b, [p.fer_dfe for p in points], "o-", "DFE", frame_floor)
    curve(b, [p.fer for p in points], "s-", "DFE + turbo", frame_floor)
    b.set(xlabel="in-band SNR [dB]", ylabel="frame error rate", title="FER (▽: no error seen)", ylim=(frame_floor / 2, 1.2))
    b.grid(True, which="both", alpha=0.3)
    b.legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    save_figure(fig, path, dpi=110)
