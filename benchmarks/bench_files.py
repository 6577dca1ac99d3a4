"""Peak memory of ``seamodem plot`` and ``seamodem rx`` on a 30-minute 96 kHz recording (issue 14 item 3).

Writes a 30-minute PCM-16 file at 96 kHz in blocks (white noise at 0.1 full scale,
a beacon frame every 3 s is not needed for memory), then runs each command under
``/usr/bin/time -v`` and reads "Maximum resident set size". Goal for plot: < 400 MB
(issue 14; before the streaming reader: 6.96 GB measured in the issue, with or without
--start/--duration). Prints a table and saves it to results/bench_files.txt.

Run: python benchmarks/bench_files.py [--minutes 30]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import soundfile

HERE = Path(__file__).resolve().parent
GOAL_MB = 400.0


def write_noise(path: Path, minutes: float, fs: int = 96000) -> int:
    rng = np.random.default_rng(0)
    n, block = int(minutes * 60 * fs), 1 << 20
    with soundfile.SoundFile(str(path), "w", fs, 1, "PCM_16") as f:
        for i in range(0, n, block):
            f.write(0.1 * rng.standard_normal(min(block, n - i)))
    return n


def peak_rss_mb(argv: list[str]) -> tuple[float, float]:
    t0 = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-v", *argv], capture_output=True, text=True,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    if proc.returncode:
        raise RuntimeError(proc.stderr[-2000:])
    kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1))
    return kb / 1024.0, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=30.0)
    args = ap.parse_args()
    exe = [sys.executable, "-m", "seamodem"]
    with tempfile.TemporaryDirectory() as d:
        wav = Path(d) / "long.wav"
        n = write_noise(wav, args.minutes)
        rows = []
        for label, extra in (("plot (whole file)", []), ("plot --start 300 --duration 1", ["--start", "300",
                                                                                          "--duration", "1"])):
            mb, s = peak_rss_mb([*exe, "plot", str(wav), "-o", str(Path(d) / "p.png"), *extra])
            rows.append((label, mb, s))
        mb, s = peak_rss_mb([*exe, "rx", str(wav), "--emit-start", "0", "--emit-period", "3", "--no-decode", "-q",
                             "-o", str(Path(d) / "m.csv")])
        rows.append(("rx --no-decode (peer)", mb, s))
    lines = [f"recording: {args.minutes:g} min at 96 kHz, PCM-16 ({n} samples, {2 * n / 1e6:.0f} MB on disk)",
             f"{'command':34s} | {'peak RSS [MB]':>13s} | {'goal [MB]':>9s} | {'ratio':>6s} | {'wall [s]':>8s}"]
    for label, mb, s in rows:
        lines.append(f"{label:34s} | {mb:13.0f} | {GOAL_MB:9.0f} | {mb / GOAL_MB:6.2f} | {s:8.1f}")
    lines.append("before (issue 14, whole file read into memory): plot 6960 MB with or without --start/--duration")
    text = "\n".join(lines)
    print(text)
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "bench_files.txt").write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
