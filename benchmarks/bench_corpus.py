"""The record's σ and decoding on a channel corpus nobody tuned to (issue 25).

Run: ``python benchmarks/bench_corpus.py`` (the report: fixed seed 2025, 25
recordings of 10 frames per family, 1000 frames) or ``--fresh`` (a new seed,
printed, for the check), ``--recordings N --frames M``, ``--jobs J``,
``--preset NAME`` (another frame than jmse2024, on which the receiver's constants were measured);
``--pool A_frames.csv B_frames.csv …`` runs nothing and reports over earlier
runs' frames tables together (fresh seeds of one revision: a cell of 20 rows
fails 97 % on one miss, 100–300 rows judge it).

The channel is :mod:`corpus` (independent of ``seamodem.channel``; see its
docstring for the families). Each recording goes through the default receiver
(``Receiver`` with ``ReceiverSettings(decode=True)``, as ``seamodem rx``) and is
scored against the corpus's direct-path truth. Per family and per
``v_r_source``: rows, RMSE, share within 2σ and 3σ, worst |error|/σ, median
σ / RMS error (goals: ≥ 0.97 within 3σ, none beyond 6σ, median σ / RMS in
[0.7, 1.5] per family). FER against in-band SNR per family, beside the same
recordings with the echoes removed (single path). Results:
benchmarks/results/bench_corpus.txt and the per-frame table bench_corpus_frames.csv (every record
column as rec_*).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from corpus import C, FAMILIES, draw_scenario, receiver_position, synthesize  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "bench_corpus.txt"
PERIOD = 1.0
SNR_BINS = (-3, 3, 8, 12, 20.01)


def recording(family: str, seed: int, n_frames: int, echoes: bool = True, preset: str = "jmse2024",
              paths: tuple | None = None):
    """(frame config, scenario, emission times [s], the synthesized recording) of one corpus recording: the
    beacon of ``preset`` (default jmse2024) every ``PERIOD`` through :func:`corpus.synthesize` (``paths``:
    those paths alone, as its ``only_paths``)."""
    from seamodem import BeaconSchedule, get_preset
    from seamodem.transmit.beacon import render_beacon

    cfg = get_preset(preset)
    sc = draw_scenario(family, seed)
    sched = BeaconSchedule(count=n_frames, period_s=PERIOD, start_s=0.2)
    beacon = render_beacon(cfg, sched)
    t_emit = sched.start_s + PERIOD * np.arange(n_frames)
    band = (cfg.carrier_hz - cfg.bandwidth_hz / 2, cfg.carrier_hz + cfg.bandwidth_hz / 2)
    return cfg, sc, t_emit, synthesize(sc, beacon, t_emit, cfg.sample_rate_hz, cfg.frame_duration_s, band,
                                       echoes=echoes, only_paths=paths)


def run_recording(family: str, seed: int, n_frames: int, echoes: bool = True, depths: bool = False,
                  preset: str = "jmse2024", paths: tuple | None = None, depth_log: bool = True) -> list[dict]:
    """One corpus recording through the default receiver: a row per frame sent (missed frames too); with
    ``depths``, the receiver is given the beacon's and the vehicle's depths (as a vehicle has them: a
    surveyed beacon, its pressure sensor); ``preset``: the frame (default jmse2024); ``paths``: those paths
    alone (:func:`recording`). A vehicle that changes depth (a track with ``climb_mps``) gives its depth log
    (10 Hz, as its pressure sensor), or with ``depth_log`` False its depth at the start alone."""
    from seamodem.receive import Emissions, Receiver, ReceiverSettings

    cfg, sc, t_emit, rec = recording(family, seed, n_frames, echoes, preset, paths)
    known = {}
    if depths:
        known["beacon_depth_m"] = float(-sc.beacon[2])
        if depth_log and sc.track.get("climb_mps", 0.0):
            times = np.arange(0.0, len(rec.samples) / cfg.sample_rate_hz + 0.1, 0.1)
            known["vehicle_depth_log"] = (times, -receiver_position(sc, times)[:, 2])
        else:
            known["vehicle_depth_m"] = float(-sc.track["z"])
    rx = Receiver(cfg, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=True, **known),
                  payloads=rec.payloads)
    found = {r.frame_index: r for r in rx.run([rec.samples], fs=cfg.sample_rate_hz) if 0 <= r.frame_index < n_frames}
    rows = []
    for k in range(n_frames):
        tr = rec.truth[k]
        echoes_v = [p[2] for p in tr["paths"][1:]]
        row = dict(family=family, seed=seed, frame=k, echoes=echoes, snr_nominal_db=sc.snr_db,
                   noise=sc.noise.get("kind"), range_true_m=tr["range"], v_r_true_mps=tr["v_r"],
                   n_paths_true=len(tr["paths"]),
                   echo_doppler_gap_mps=max((abs(v - tr["v_r"]) for v in echoes_v), default=0.0),
                   first_echo_delay_s=min((p[1] for p in tr["paths"][1:]), default=np.nan), detected=k in found)
        r = found.get(k)
        if r is not None:
            row.update(range_m=r.range_m, v_r_mps=r.v_r_mps, sigma_range_m=r.sigma_range_m,
                       sigma_v_r_mps=r.sigma_v_r_mps, v_r_source=r.v_r_source, crc_ok=bool(r.crc_ok),
                       snr_db=r.snr_db, v_r_tone_mps=r.v_r_tone_mps, v_r_bank_mps=r.v_r_bank_mps,
                       sigma_v_r_bank_mps=r.sigma_v_r_bank_mps,
                       **{f"rec_{k}": v for k, v in r.to_dict().items() if k not in ("payload_hex", "payload_text")})
        rows.append(row)
    return rows


def _scores(err: np.ndarray, sig: np.ndarray) -> dict:
    z = np.abs(err) / sig
    rms = float(np.sqrt(np.mean(err**2))) if len(err) else np.nan
    # the literal "median σ over RMS error" for the same σ's were every error drawn from its own σ: what a
    # perfectly calibrated σ scores on it (rows whose σ span decades score far below 1 however right they are)
    draws = np.random.default_rng(0).standard_normal((200, len(sig))) * sig
    oracle = float(np.median(np.median(sig) / np.sqrt(np.mean(draws**2, axis=1)))) if len(err) else np.nan
    return dict(n=len(err), rms=rms, w2=float(np.mean(z <= 2)) if len(z) else np.nan,
                w3=float(np.mean(z <= 3)) if len(z) else np.nan, worst=float(np.max(z)) if len(z) else np.nan,
                ratio=float(np.median(sig)) / rms if len(err) else np.nan, oracle=oracle,
                rmsz=float(np.sqrt(np.mean(z**2))) if len(z) else np.nan,
                medz=float(np.median(z)) if len(z) else np.nan)


def _calibration_lines(rows: list[dict], what: str, scale: float, unit: str) -> tuple[list[str], list[bool], list[bool]]:
    """The table's lines, and per row whether the issue's goals are met as written and with the family's σ
    scale judged by 1 / RMS(err/σ) in [0.7, 1.5] (RMS(err/σ) in [0.67, 1.43]) instead of median σ / RMS error."""
    col, sig_col, truth = {"v_r": ("v_r_mps", "sigma_v_r_mps", "v_r_true_mps"),
                           "range": ("range_m", "sigma_range_m", "range_true_m"),
                           "v_r_bank": ("v_r_bank_mps", "sigma_v_r_bank_mps", "v_r_true_mps")}[what]
    lines = [f"| family | v_r source | rows | RMSE {unit} | within 2σ | within 3σ | worst abs(err)/σ | "
             "median σ / RMS | same, σ exact | RMS err/σ | median abs(err)/σ | goals as written | goals, σ scale by RMS err/σ |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    met, met_z = [], []
    det = [r for r in rows if r["detected"] and r["echoes"]]
    for fam in FAMILIES:
        fr = [r for r in det if r["family"] == fam]
        groups = [(s, [r for r in fr if r["v_r_source"] == s]) for s in sorted({r["v_r_source"] for r in fr})]
        for source, g in groups + [("all", fr)]:
            if not g:
                continue
            err = np.array([r[col] - r[truth] for r in g])
            sig = np.array([r[sig_col] for r in g])
            s = _scores(err, sig)
            ok = ok_z = s["w3"] >= 0.97 and s["worst"] <= 6.0
            if source == "all":
                ok = ok and 0.7 <= s["ratio"] <= 1.5
                ok_z = ok_z and 0.7 <= 1 / s["rmsz"] <= 1.5
            met.append(ok)
            met_z.append(ok_z)
            lines.append(f"| {fam} | {source} | {s['n']} | {scale * s['rms']:.2f} | {s['w2']:.3f} | {s['w3']:.3f} | "
                         f"{s['worst']:.1f} | {s['ratio']:.2f} | {s['oracle']:.2f} | {s['rmsz']:.2f} | {s['medz']:.2f} | "
                         f"{'met' if ok else 'NOT met'} | {'met' if ok_z else 'NOT met'} |")
    return lines, met, met_z


def _fer_lines(rows: list[dict]) -> list[str]:
    head = "| family | paths | " + " | ".join(f"SNR [{a:g}, {b:.0f}) dB" for a, b in zip(SNR_BINS, SNR_BINS[1:])) + " |"
    lines = [head, "|---|---|" + "---|" * (len(SNR_BINS) - 1)]
    for fam in FAMILIES:
        for echoes, label in ((True, "echoes (own Doppler)"), (False, "single path")):
            cells = []
            for a, b in zip(SNR_BINS, SNR_BINS[1:]):
                g = [r for r in rows if r["family"] == fam and r["echoes"] == echoes and a <= r["snr_nominal_db"] < b]
                if not g:
                    cells.append("–")
                    continue
                fails = sum(1 for r in g if not (r["detected"] and r.get("crc_ok")))
                cells.append(f"{fails / len(g):.3f} ({fails}/{len(g)})")
            lines.append(f"| {fam} | {label} | " + " | ".join(cells) + " |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=25, help="recordings per family (default 25)")
    ap.add_argument("--frames", type=int, default=10, help="frames per recording (default 10)")
    ap.add_argument("--seed", type=int, default=2025, help="base seed of the report (default 2025)")
    ap.add_argument("--fresh", action="store_true", help="a fresh random base seed (printed)")
    ap.add_argument("--no-single-path", action="store_true", help="skip the single-path FER reference")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--label", default="", help="text for the report's title (e.g. 'before', a commit)")
    ap.add_argument("--depths", action="store_true",
                    help="give the receiver the beacon's and the vehicle's depths (ReceiverSettings.beacon_depth_m, "
                         "vehicle_depth_m), as a vehicle knows them")
    ap.add_argument("--preset", default="jmse2024",
                    help="the beacon's frame (a seamodem preset, default jmse2024: the receiver's constants were "
                         "measured on it; another one checks that they carry over)")
    ap.add_argument("--families", default=",".join(FAMILIES),
                    help="comma-separated families to run (default all; seeds as in the full run)")
    ap.add_argument("--pool", type=Path, nargs="+", metavar="FRAMES_CSV",
                    help="run nothing: the report over the frames tables (*_frames.csv) of earlier runs, pooled "
                         "(fresh seeds of one revision: cells of a few rows judge 97 %% on one miss)")
    args = ap.parse_args(argv)
    if args.pool:
        return _pooled(args.pool, args.out if args.out != RESULTS else None, args.label)
    only = [f.strip() for f in args.families.split(",")]
    if unknown := sorted(set(only) - set(FAMILIES)):
        ap.error(f"unknown family {', '.join(unknown)} (choose from {', '.join(FAMILIES)})")
    seed = int.from_bytes(os.urandom(3), "little") if args.fresh else args.seed
    from seamodem import get_preset
    from seamodem.errors import ConfigError

    try:
        get_preset(args.preset)
    except ConfigError as exc:
        ap.error(str(exc))
    jobs = [(fam, seed * 1000 + 37 * i + j, args.frames, True, args.depths, args.preset)
            for j, fam in enumerate(FAMILIES) for i in range(args.recordings) if fam in only]
    if not args.no_single_path:
        jobs += [(f, s, n, False, d, p) for f, s, n, _, d, p in jobs]
    t0 = time.perf_counter()
    rows: list[dict] = []
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as ex:
            for part in ex.map(run_recording, *zip(*jobs)):
                rows += part
    else:
        for i, job in enumerate(jobs):
            rows += run_recording(*job)
            print(f"\r{i + 1}/{len(jobs)} recordings", end="", file=sys.stderr, flush=True)
        print(file=sys.stderr)
    wall = time.perf_counter() - t0
    n_echo = sum(r["echoes"] for r in rows)
    det = [r for r in rows if r["echoes"] and r["detected"]]
    title = (f"# bench_corpus{(' — ' + args.label) if args.label else ''}: base seed {seed}"
             f"{' (fresh)' if args.fresh else ''}{', the ends depths given to the receiver' if args.depths else ''}, "
             f"{args.recordings} recordings x {args.frames} frames per family, "
             f"{n_echo} frames with echoes ({len(det)} detected), {args.preset}, T_com {PERIOD} s, c {C} m/s, "
             f"in-band SNR in [-3, 20] dB (SPEC §1); channel: benchmarks/corpus.py (independent of seamodem.channel); "
             f"{wall:.0f} s wall\n")
    text = _report(rows, title)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    write_frames(rows, args.out.with_name(args.out.stem + "_frames.csv"))
    return 0


def write_frames(rows: list[dict], path: Path) -> None:
    """The per-frame table (every key of :func:`run_recording`'s rows; :func:`read_frames` reads it back)."""
    keys = sorted({k for r in rows for k in r})
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


def _report(rows: list[dict], title: str) -> str:
    """The report's text: the title line, the calibration tables, the frames missed, FER, the goals met."""
    out = [title]
    out.append("Goals (issue 25): within 3σ ≥ 0.97 and worst abs(err)/σ ≤ 6 on every row; per family (row 'all') "
               "also median σ / RMS error in [0.7, 1.5]. 'same, σ exact' is what that ratio would be for these σ's "
               "were every error drawn from its own σ: a family whose σ's span decades (tone rows among whole-frame "
               "ones) cannot reach 0.7 however right each σ is, so the σ scale is also judged by RMS(err/σ) "
               "(1 when calibrated) in the last column: its inverse, σ over error as the ratio above, in [0.7, 1.5], "
               "i.e. RMS(err/σ) from 0.67 (below: σ inflated) to 1.43 (above: σ too small).\n")
    goals, goals_z = [], []
    for what, scale, unit in (("v_r", 1e3, "mm/s"), ("range", 1e3, "mm")):
        lines, met, met_z = _calibration_lines(rows, what, scale, unit)
        goals += met
        goals_z += met_z
        out += [f"## {what}: calibration of the record's σ against the direct-path truth\n", *lines, ""]
    # the pilot bank's own column (v_r_bank_mps, sigma_v_r_bank_mps): a σ the record writes too, tallied apart
    # so that the 32 goals above stay comparable with earlier reports
    bank_lines, bank_met, bank_met_z = _calibration_lines(rows, "v_r_bank", 1e3, "mm/s")
    out += ["## v_r_bank: calibration of the pilot bank's own σ column (`sigma_v_r_bank_mps`) against the "
            "direct-path truth, rows grouped by the record's v_r source\n", *bank_lines, ""]
    missed = {fam: sum(1 for r in rows if r["echoes"] and r["family"] == fam and not r["detected"]) for fam in FAMILIES}
    out.append("Frames not detected (no row): " + ", ".join(f"{k} {v}" for k, v in missed.items()) + "\n")
    out.append("## FER against nominal in-band SNR (a frame fails when it is missed or its CRC fails)\n")
    out += _fer_lines(rows)
    steep = [r for r in rows if r["family"] == "steep" and r["echoes"] and r["snr_nominal_db"] >= 12]
    if steep:
        fails = sum(1 for r in steep if not (r["detected"] and r.get("crc_ok")))
        out.append(f"\nSteep family at ≥ 12 dB: FER {fails}/{len(steep)} (goal 0: {'met' if fails == 0 else 'NOT met'})")
    out.append(f"\nGoals met: {sum(goals)} of {len(goals)} calibration rows as written; {sum(goals_z)} of "
               f"{len(goals_z)} with the σ scale judged by RMS(err/σ). The pilot bank's σ column: "
               f"{sum(bank_met)} of {len(bank_met)} as written; {sum(bank_met_z)} of {len(bank_met_z)} on the σ scale.")
    return "\n".join(out) + "\n"


def _csv_value(text: str):
    """A frames table's cell as run_recording wrote it: bool, number, text, or None when empty."""
    if text in ("True", "False"):
        return text == "True"
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return text


def read_frames(path: Path) -> list[dict]:
    """The rows of a frames table (``*_frames.csv``) as :func:`run_recording` returned them."""
    with open(path, newline="") as fh:
        return [{k: _csv_value(v) for k, v in row.items()} for row in csv.DictReader(fh)]


#: the columns of a frames table the report reads (:func:`_report`)
_POOLED_COLUMNS = ("family", "seed", "frame", "echoes", "detected", "snr_nominal_db", "v_r_source", "crc_ok",
                   "v_r_mps", "sigma_v_r_mps", "v_r_true_mps", "range_m", "sigma_range_m", "range_true_m")


def _pooled(paths: list[Path], out: Path | None, label: str) -> int:
    """The report over several runs' frames tables: each run's seeds are its own, so the rows are pooled as
    they are (a table read twice would count twice: refused)."""
    rows: list[dict] = []
    seen: dict = {}
    for path in paths:
        try:
            part = read_frames(path)
        except OSError as exc:
            print(f"bench_corpus: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        missing = sorted(set(_POOLED_COLUMNS) - set(part[0])) if part else []
        if not part or missing:
            what = f"no column {', '.join(missing)}" if missing else "no rows"
            print(f"bench_corpus: {path} is not a frames table of bench_corpus ({what})", file=sys.stderr)
            return 2
        for r in part:
            key = (r.get("family"), r.get("seed"), r.get("frame"), r.get("echoes"))
            if key in seen:
                print(f"bench_corpus: {path} repeats recording {r.get('seed'):.0f} frame {r.get('frame'):.0f} "
                      f"of {seen[key]}", file=sys.stderr)
                return 2
            seen[key] = path
        rows += part
    n_echo = sum(bool(r["echoes"]) for r in rows)
    det = [r for r in rows if r["echoes"] and r["detected"]]
    title = (f"# bench_corpus{(' — ' + label) if label else ''}: pooled over {len(paths)} runs "
             f"({', '.join(p.name for p in paths)}), {n_echo} frames with echoes ({len(det)} detected)\n")
    text = _report(rows, title)
    print(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
