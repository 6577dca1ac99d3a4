"""Real-time factors of ``seamodem rx`` in several revisions, interleaved, by CPU and wall time.

Run: ``python benchmarks/bench_rx_revisions.py REV [REV ...] [--repeats N]`` (e.g. ``40d721c HEAD``).

Each revision is exported with ``git archive`` and run from there. The recordings (60 s: 20 frames
through examples/scenarios/doppler_profile.toml; the same through straight_line.toml on a tetrahedral
array; 20 LFM pings) are made once with the first revision; the first is also run with the ends'
depths given (the merged surface image modelled, the whole-frame fit's clusters split). Each mode runs once per revision to warm
the numba caches, then ``--repeats`` times interleaved. The CPU time is the child's user + system
time (os.wait4), far less sensitive to the shared machine's load than the wall time; both are
printed as real-time factors (recording seconds per processing second), medians. A mode a revision
cannot run (an option it predates, e.g. ``--beacon-depth`` before issue 25) fails in its warm-up run and
is shown as "–" for that revision, without its ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-c", "import sys; from seamodem.cli import main; sys.exit(main())"]


def run(tree: Path, *args) -> tuple[float, float]:
    """(wall, CPU) seconds of one command."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "MPLBACKEND": "Agg"}
    start = time.perf_counter()
    proc = subprocess.Popen([*CLI, *map(str, args)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    if status != 0:
        raise RuntimeError(f"failed in {tree}: {args}")
    return time.perf_counter() - start, usage.ru_utime + usage.ru_stime


def rx_speed(trees: dict[str, Path], work: Path, *, repeats: int = 3) -> str:
    """The real-time factors table of ``rx`` in each exported tree (revision → tree), as markdown.

    The recordings are made once in ``work`` with the first tree; each mode runs once per tree to warm
    the numba caches, then ``repeats`` times interleaved between the trees.
    """
    import soundfile

    first = next(iter(trees.values()))
    scen = first / "examples" / "scenarios"
    run(first, "tx", "--count", 20, "--period", 3, "-o", work / "b.wav", "-q")
    run(first, "channel", work / "b.wav", "--scenario", scen / "doppler_profile.toml", "-o", work / "r.wav", "-q")
    run(first, "channel", work / "b.wav", "--scenario", scen / "straight_line.toml", "--array", "tetra:0.08",
        "-o", work / "r4.wav", "-q")
    run(first, "tx", "--reference", "lfm:18000-30000:0.08", "--count", 20, "--period", 3, "--start", 0.2,
        "-o", work / "p.wav", "-q")
    run(first, "channel", work / "p.wav", "--scenario", scen / "doppler_profile.toml", "-o", work / "p_rx.wav", "-q")
    duration = soundfile.info(str(work / "r.wav")).duration
    modes = {"measurement only": [work / "r.wav", "--no-decode"], "with decoding": [work / "r.wav"],
             "with decoding, the ends' depths given": [work / "r.wav", "--beacon-depth", 5, "--vehicle-depth", 10],
             "--array tetra (decoding)": [work / "r4.wav", "--array", "tetra:0.08"],
             "--reference lfm": [work / "p_rx.wav", "--reference", work / "p_rx.json"]}
    times = {(m, r): [] for m in modes for r in trees}
    runs = set()  # (mode, revision) that ran its warm-up
    for m, a in modes.items():
        for r, tree in trees.items():
            try:
                run(tree, "rx", *a, "-o", work / "x.csv", "-q")
            except RuntimeError as err:
                print(f"{r}: {m} not run ({err})", file=sys.stderr)
            else:
                runs.add((m, r))
    for _ in range(repeats):
        for m, a in modes.items():
            for r, tree in trees.items():
                if (m, r) in runs:
                    times[(m, r)].append(run(tree, "rx", *a, "-o", work / "x.csv", "-q"))
    lines = [f"# seamodem rx real-time factors, {duration:.0f} s recordings, median of {repeats} "
             f"interleaved runs (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)\n",
             "| mode | " + " | ".join(f"{r} CPU / wall" for r in trees) + " | speed last vs first (CPU) |",
             "|---|" + "---|" * (len(trees) + 1)]
    for m in modes:
        cells, cpus = [], []
        for r in trees:
            if not times[(m, r)]:
                cells.append("–")
                cpus.append(None)
                continue
            wall = statistics.median(t[0] for t in times[(m, r)])
            cpu = statistics.median(t[1] for t in times[(m, r)])
            cpus.append(cpu)
            cells.append(f"{duration / cpu:.1f}x / {duration / wall:.1f}x")
        ratio = "–" if None in (cpus[0], cpus[-1]) else f"{cpus[0] / cpus[-1]:.2f}"
        lines.append(f"| {m} | " + " | ".join(cells) + f" | {ratio} |")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("revisions", nargs="+")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="seamodem-rt-") as tmp:
        tmp = Path(tmp)
        trees = {}
        for i, rev in enumerate(args.revisions):
            tree = tmp / f"tree{i}"
            tree.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
            trees[rev] = tree
        print(rx_speed(trees, tmp, repeats=args.repeats))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
