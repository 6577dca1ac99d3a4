"""Two revisions of the tree side by side: same outputs, and the shape figures of a restructuring (issue 13).

Each revision is exported with ``git archive`` into a temporary folder and run
from there (``PYTHONPATH``), so uncommitted edits in the working tree play no
part. Outputs compared byte for byte (times and paths left out):

- ``nav simulate --paper --tcom 3 20 --runs 60 --seed 1`` and the default
  ``nav simulate --tcom 3 20 --runs 30 --seed 1``: table.csv, fig7, fig8;
- ``ber --snr 2 6 --frames 10 --seed 3``: ber.csv;
- ``tx`` 6 frames → ``channel`` examples/scenarios/doppler_profile.toml → ``rx``: the records;
- ``rx --array tetra:0.08`` on the same frames through the channel on 4 elements: the records;
- ``tx --reference`` LFM and HFM → ``channel`` → ``rx --reference``: the records;
- ``demo --duration 30``: every CSV and figure, summary.json without its wall times.

Speed: real-time factors of ``rx`` (measurement only, with decoding, ``--array``, ``--reference``) on
60 s recordings, by the child's CPU time, interleaved between the revisions
(:func:`bench_rx_revisions.rx_speed`).

Shape figures: the largest modules' line counts, the import cycles the scan of
the newer revision's tests/test_architecture.py finds in each, ``duplicates``
pairs over src/ (when the tool is on PATH), and timings interleaved between the
revisions (``--help`` and a one-line error, median of 5; ``rx`` on 30 s of
noise, with the share taken by starting Python and importing what it needs).
Timings depend on the machine's load: the script prints the load average.

Usage::

    python benchmarks/compare_revisions.py 41d5d38 HEAD
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_rx_revisions import rx_speed  # noqa: E402
CLI = [sys.executable, "-c", "import sys; from seamodem.cli import main; sys.exit(main())"]


def export(rev: str, into: Path) -> Path:
    into.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def seamodem(tree: Path, *args, cwd=None) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "MPLBACKEND": "Agg"}
    start = time.perf_counter()
    subprocess.run([*CLI, *map(str, args)], env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def outputs(tree: Path, work: Path) -> dict[str, bytes]:
    """Every compared output of one revision, by name."""
    out: dict[str, bytes] = {}
    for name, args in (("nav_paper", ["--paper", "--tcom", 3, 20, "--runs", 60, "--seed", 1]),
                       ("nav_default", ["--tcom", 3, 20, "--runs", 30, "--seed", 1])):
        seamodem(tree, "nav", "simulate", *args, "-o", work / name)
        for f in ("table.csv", "fig7_top_view.png", "fig8_error.png"):
            out[f"{name}/{f}"] = (work / name / f).read_bytes() if (work / name / f).exists() else b"(missing)"
    seamodem(tree, "ber", "--snr", 2, 6, "--frames", 10, "--seed", 3, "-o", work / "ber", "-q")
    out["ber/ber.csv"] = (work / "ber" / "ber.csv").read_bytes()
    seamodem(tree, "tx", "--count", 6, "--period", 2, "-o", work / "tx.wav", "-q")
    seamodem(tree, "channel", work / "tx.wav", "--scenario", tree / "examples/scenarios/doppler_profile.toml",
             "-o", work / "rx.wav", "-q")
    seamodem(tree, "rx", work / "rx.wav", "-o", work / "records.csv", "-q")
    text = (work / "records.csv").read_text(encoding="utf-8") if (work / "records.csv").exists() else ""
    out["rx doppler_profile records"] = "\n".join(r for r in text.splitlines() if not r.startswith("#")).encode()
    # the array receiver: 4 elements through a geometry channel, rx --array
    seamodem(tree, "channel", work / "tx.wav", "--scenario", tree / "examples/scenarios/straight_line.toml",
             "--array", "tetra:0.08", "-o", work / "rx4.wav", "-q")
    seamodem(tree, "rx", work / "rx4.wav", "--array", "tetra:0.08", "-o", work / "array.csv", "-q")
    out["rx --array records"] = (work / "array.csv").read_bytes() if (work / "array.csv").exists() else b"(missing)"
    # the reference receiver: LFM and HFM pings and a pre/postamble pair through the channel
    for name, spec in (("lfm", "lfm:18000-30000:0.08"), ("hfm", "hfm:19000-29000:0.05")):
        seamodem(tree, "tx", "--reference", spec, "--count", 8, "--period", 2, "--start", 0.2,
                 "-o", work / f"{name}.wav", "-q")
        seamodem(tree, "channel", work / f"{name}.wav", "--scenario",
                 tree / "examples/scenarios/doppler_profile.toml", "-o", work / f"{name}_rx.wav", "-q")
        seamodem(tree, "rx", work / f"{name}_rx.wav", "--reference", work / f"{name}_rx.json",
                 "-o", work / f"{name}.csv", "-q")
        f = work / f"{name}.csv"
        out[f"rx --reference {name} records"] = f.read_bytes() if f.exists() else b"(missing)"
    seamodem(tree, "demo", "--duration", 30, "-o", work / "demo")
    for f in sorted((work / "demo").glob("*")):
        if f.name == "summary.json":
            summary = json.loads(f.read_text(encoding="utf-8"))
            summary.pop("wall_time_s", None)
            out["demo/summary.json (no wall times)"] = json.dumps(summary, sort_keys=True).encode()
        else:
            out[f"demo/{f.name}"] = f.read_bytes()
    return out


def shape(tree: Path, scan_tests: Path) -> dict[str, str]:
    files = sorted(((len(p.read_text(encoding="utf-8").splitlines()), p.relative_to(tree / "src"))
                    for p in (tree / "src").rglob("*.py")), reverse=True)
    scan = subprocess.run(
        [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(scan_tests)!r}); "
         "from test_architecture import import_graph, import_cycles; "
         "print(len(import_cycles(import_graph())), len(import_cycles(import_graph(module_level=False))))"],
        env={**os.environ, "PYTHONPATH": str(tree / "src")}, capture_output=True, text=True).stdout.split()
    result = {"largest modules": ", ".join(f"{p.name} {n}" for n, p in files[:6]),
              "import cycles (module level / with function-level imports)": " / ".join(scan) or "scan failed"}
    if shutil.which("duplicates"):
        first = subprocess.run(["duplicates", "--seconds", "90"], cwd=tree / "src", capture_output=True,
                               text=True).stdout.splitlines()
        result["duplicates over src/"] = first[0].split(",")[0] if first else "?"
    return result


def timings(trees: dict[str, Path], work: Path) -> dict[str, dict[str, str]]:
    import numpy as np
    import soundfile as sf

    noise = work / "noise30.wav"
    sf.write(noise, 0.05 * np.random.default_rng(0).standard_normal(30 * 96153), 96153, subtype="PCM_16")
    runs = {k: {"help": [], "error": [], "rx": [], "imports": []} for k in trees}
    for tree in trees.values():  # numba caches of the export, once
        seamodem(tree, "rx", noise, "--emit-start", 0, "--emit-period", 3, "-o", work / "warm.csv", "-q")
    for i in range(5):
        for k, tree in trees.items():
            runs[k]["help"].append(seamodem(tree, "--help"))
            runs[k]["error"].append(seamodem(tree, "rx", work / "missing.wav", "-o", work / "x.csv"))
            if i < 2:
                runs[k]["rx"].append(seamodem(tree, "rx", noise, "--emit-start", 0, "--emit-period", 3,
                                              "-o", work / "n.csv", "-q"))
                start = time.perf_counter()
                subprocess.run([sys.executable, "-c", "import seamodem.cli.rx, scipy.signal, numba; "
                                "from seamodem import receive_file"], env={**os.environ, "PYTHONPATH": str(tree / "src")})
                runs[k]["imports"].append(time.perf_counter() - start)
    out = {}
    for k, r in runs.items():
        rx, imp = min(r["rx"]), min(r["imports"])
        out[k] = {"seamodem --help [s], median of 5": f"{statistics.median(r['help']):.3f}",
                  "rx one-line error [s], median of 5": f"{statistics.median(r['error']):.3f}",
                  "rx 30 s noise [s], best of 2 (start-up share)": f"{rx:.2f} ({100 * imp / rx:.0f} %)"}
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("base")
    parser.add_argument("head", nargs="?", default="HEAD")
    parser.add_argument("--no-timing", action="store_true")
    args = parser.parse_args()
    lines = []
    with tempfile.TemporaryDirectory(prefix="seamodem-compare-") as tmp:
        tmp = Path(tmp)
        trees = {rev: export(rev, tmp / f"tree{i}") for i, rev in enumerate((args.base, args.head))}
        scan_tests = trees[args.head] / "tests"
        out = {rev: outputs(tree, tmp / f"out{i}") for i, (rev, tree) in enumerate(trees.items())}
        a, b = out.values()
        lines.append(f"{'output':45} | same bytes in {args.base} and {args.head}")
        for name in sorted(set(a) | set(b)):
            same = a.get(name) == b.get(name)
            missing = b"(missing)" in (a.get(name), b.get(name))
            lines.append(f"{name:45} | {'MISSING' if missing else 'yes' if same else 'NO'}")
        figures = {rev: shape(tree, scan_tests) for rev, tree in trees.items()}
        if not args.no_timing:
            for rev, t in timings(trees, tmp).items():
                figures[rev].update(t)
        lines += ["", f"{'figure':60} | {args.base:>28} | {args.head:>28}"]
        for key in figures[args.base]:
            values = [figures[rev].get(key, "") for rev in trees]
            if len(max(values, key=len)) > 28:
                lines += [f"{key}:"] + [f"    {rev}: {v}" for rev, v in zip(trees, values)]
            else:
                lines.append(f"{key:60} | {values[0]:>28} | {values[1]:>28}")
        if not args.no_timing:
            lines += ["", rx_speed(trees, tmp)]
        lines.append(f"\nload average during the run: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    text = "\n".join(lines)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "compare_revisions.txt").write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
