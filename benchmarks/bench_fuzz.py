"""Readers that never crash (issue 25 item 5): thousands of damaged files per reader, outcomes tallied.

Run: ``python benchmarks/bench_fuzz.py [--per-reader N] [--seed S]`` (default 1000 per reader, 11 readers).

Uses the damage operations and readers of ``tests/io/test_fuzz_readers.py`` (truncation, flipped bytes, lying
size fields, NaN/inf over samples, values of the wrong type, dropped lines), drawn here from a seeded generator
rather than by hypothesis, so that a large run is cheap and every outcome is counted: read (possibly with a
warning), refused with one line naming the file (``SeamodemError``), or a defect (any other exception, a message
over several lines or not naming the file), with the first example of each defect. Results in
benchmarks/results/bench_fuzz.txt.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "io"))

from test_fuzz_readers import READERS, SIZES, WRONG, damaged_copy, message_defect  # noqa: E402

from seamodem.errors import SeamodemError  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "bench_fuzz.txt"


def random_ops(rng: np.random.Generator) -> list[tuple]:
    ops = []
    for _ in range(rng.integers(1, 4)):
        kind = rng.choice(["truncate", "flip", "u32", "float", "token", "drop_line"])
        if kind == "truncate":
            ops.append((kind, float(rng.random())))
        elif kind == "flip":
            ops.append((kind, float(rng.random()), int(rng.integers(1, 256))))
        elif kind == "u32":
            ops.append((kind, int(rng.integers(0, 81)), int(rng.choice(SIZES))))
        elif kind == "float":
            ops.append((kind, float(rng.random()), float(rng.choice([math.nan, math.inf, -math.inf, 1e30, 2.0]))))
        elif kind == "token":
            ops.append((kind, float(rng.random()), WRONG[int(rng.integers(len(WRONG)))]))
        else:
            ops.append((kind, float(rng.random())))
    return ops


def outcome(name: str, tmp: Path, ops) -> tuple[str, str]:
    target = damaged_copy(name, tmp, ops)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            READERS[name][2](target)
        except SeamodemError as exc:
            problem = message_defect(str(exc), target)
            if problem is not None:
                return "defect", f"bad message ({type(exc).__name__}): {problem[:160]}"
            return "refused", ""
        except Exception as exc:  # noqa: BLE001 - what the benchmark counts
            return "defect", f"{type(exc).__name__}: {str(exc)[:160]}"
    return ("read, warned" if caught else "read"), ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-reader", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    lines = [f"# bench_fuzz: {args.per_reader} damaged inputs per reader, seed {args.seed}\n",
             "| reader | inputs | read | read, warned | refused in one line | defects | defects seen (first of each kind) |",
             "|---|---|---|---|---|---|---|"]
    total = defects = 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        for name in sorted(READERS):
            tmp = Path(d) / name
            tmp.mkdir()
            tally: Counter = Counter()
            kinds: dict[str, str] = {}
            for _ in range(args.per_reader):
                kind, detail = outcome(name, tmp, random_ops(rng))
                tally[kind] += 1
                if kind == "defect":
                    kinds.setdefault(detail.split(":")[0], detail.replace("|", "/"))
            first = "; ".join(list(kinds.values())[:4])
            total += args.per_reader
            defects += tally["defect"]
            lines.append(f"| {name} | {args.per_reader} | {tally['read']} | {tally['read, warned']} | "
                         f"{tally['refused']} | {tally['defect']} | {first or '–'} |")
            print(lines[-1], file=sys.stderr)
    lines.append(f"\n{total} inputs in {time.perf_counter() - t0:.0f} s; defects: {defects} (goal 0)")
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    return 0 if defects == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
