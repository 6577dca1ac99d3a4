"""Batch decoding benchmark (issue 8): throughput against local workers, a LocalCluster, memory per worker.

Run: ``python benchmarks/bench_batch.py`` (about 2 min here); ``--quick`` decodes
less audio. The job is the one ``seamodem rx a.wav b.wav ... -o all.csv`` runs:
jmse2024 beacon recordings (one frame per second, white noise, in-band SNR
≈ 25 dB), each frame measured and its payload equalised and decoded.

Throughput is seconds of audio decoded per second of wall time, including the
start of the pool or cluster; the speed-up is against one local worker on the
same files. The peak is this machine's core count (2 here, shared with other
work: the load average is printed). Memory is each worker's peak resident set
(``ru_maxrss``, so for forked workers it includes the pages shared with the
parent).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import soundfile

from seamodem import BeaconSchedule, get_preset, render_beacon
from seamodem.batch import default_workers, run_tasks
from seamodem.batch.decode import Recording, decode_part, plan_parts
from seamodem.receive import Emissions, ReceiverSettings

CFG = get_preset("jmse2024")
FS = int(CFG.sample_rate_hz)


def make_recordings(folder: Path, n_files: int, duration_s: float) -> list[Recording]:
    """``n_files`` recordings of ``duration_s``, a frame each second, different delays and noise."""
    count = int(duration_s) - 1
    sig = render_beacon(CFG, BeaconSchedule(count=count, period_s=1.0, start_s=0.0))
    x = np.concatenate(list(sig.blocks(progress=False)))
    x *= 0.3 / np.max(np.abs(x))
    recs = []
    for i in range(n_files):
        shift = int((0.1 + 0.05 * i) * FS)
        y = np.concatenate([np.zeros(shift), x])[: int(duration_s * FS)]
        y = y + 0.01 * np.random.default_rng(i).standard_normal(len(y))
        path = folder / f"rec{i}.wav"
        soundfile.write(path, y, FS, subtype="FLOAT")
        payloads = [fr.payload for fr in sig.frames]
        recs.append(Recording(str(path), CFG, Emissions(start_s=0.0, period_s=1.0),
                              settings=ReceiverSettings(decode=True), payloads=payloads))
    return recs


def decode_with_memory(part):
    """The batch task; its CPU time [s] and this worker's peak resident set [MiB]."""
    cpu = time.process_time()
    value = decode_part(part)
    cpu = time.process_time() - cpu
    return len(value["records"]), os.getpid(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, cpu


def burn(seed: int) -> float:
    """A pure-CPU task (no I/O, no shared state): what 2 workers can gain on this machine now."""
    x = 0.0
    for k in range(40):
        x += float(np.sum(np.sin(np.arange(1_000_000) * 1e-3 + seed + k)))
    return x


def ceiling() -> float:
    """Speed-up of 8 burn tasks on 2 worker processes against 1: the ceiling for the decode."""
    walls = []
    for n in (1, 2):
        start = time.perf_counter()
        run_tasks(burn, range(8), backend="processes", workers=n)
        walls.append(time.perf_counter() - start)
    return walls[0] / walls[1]


def run(parts, audio_s: float, repeat: int = 2, **options) -> dict:
    """Best of ``repeat`` runs (the machine is shared: the best is the least disturbed)."""
    best = None
    for _ in range(repeat):
        start = time.perf_counter()
        results = run_tasks(decode_with_memory, parts, **options)
        wall = time.perf_counter() - start
        assert all(r.ok for r in results), [r.error for r in results if not r.ok]
        if best is None or wall < best[0]:
            best = (wall, results)
    wall, results = best
    by_pid: dict[int, float] = {}
    for r in results:
        _, pid, rss, _ = r.value
        by_pid[pid] = max(by_pid.get(pid, 0.0), rss)
    return {
        "wall_s": wall,
        "frames": sum(r.value[0] for r in results),
        "throughput": audio_s / wall,
        "cpu_per_audio": sum(r.value[3] for r in results) / audio_s,
        "workers_used": len(by_pid),
        "rss_mib": max(by_pid.values()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="less audio (4 files of 15 s)")
    args = ap.parse_args()
    n_files, duration = (4, 15.0) if args.quick else (8, 30.0)
    with tempfile.TemporaryDirectory() as tmp:
        recs = make_recordings(Path(tmp), n_files, duration)
        audio_s = n_files * duration
        whole, _ = plan_parts(recs)
        segmented, _ = plan_parts(recs[:1], segment_s=duration / 4)
        print(f"{n_files} recordings of {duration:g} s ({audio_s:g} s of audio, {len(whole)} parts); "
              f"{os.cpu_count()} CPUs, {default_workers()} usable; load average before "
              f"{os.getloadavg()[0]:.2f}")
        rows = [("serial (this process)", run(whole, audio_s, backend="serial"))]
        for n in (1, 2):
            rows.append((f"processes, {n} worker{'s' if n > 1 else ''}",
                         run(whole, audio_s, backend="processes", workers=n)))
        try:
            import distributed
        except ImportError:
            print("(dask not installed: pip install 'seamodem[dask]' for the LocalCluster row)")
        else:
            start = time.perf_counter()
            cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                               dashboard_address=":0")
            client = distributed.Client(cluster)
            print(f"Dask LocalCluster of 2 worker processes started in {time.perf_counter() - start:.1f} s")
            rows.append(("Dask LocalCluster, 2 worker processes",
                         run(whole, audio_s, backend="dask", scheduler=client)))
            client.close()
            cluster.close()
        seg_audio = duration
        rows.append((f"1 recording in {len(segmented)} segments, processes, 2 workers",
                     run(segmented, seg_audio, backend="processes", workers=2)))
        one = rows[1][1]["throughput"]
        cpu_ceiling = ceiling()
        print()
        print(f"{'run':<58} | {'wall s':>7} | {'frames':>6} | {'audio s / s':>11} | {'speed-up vs 1 worker':>20} "
              f"| {'CPU s / audio s':>15} | {'workers':>7} | {'peak RSS / worker MiB':>21}")
        for name, r in rows:
            print(f"{name:<58} | {r['wall_s']:>7.2f} | {r['frames']:>6d} | {r['throughput']:>11.1f} | "
                  f"{r['throughput'] / one:>20.2f} | {r['cpu_per_audio']:>15.3f} | {r['workers_used']:>7d} | "
                  f"{r['rss_mib']:>21.0f}")
        print(f"\nload average after {os.getloadavg()[0]:.2f}; ideal speed-up with 2 workers on 2 idle cores: 2.00; "
              f"measured now for a pure-CPU task (the ceiling on this shared machine): {cpu_ceiling:.2f}")


if __name__ == "__main__":
    sys.exit(main())
