"""CPU real-time factor of the receiver (decoding on, as ``bench_corpus.py`` runs it) on one corpus recording.

Run: ``python benchmarks/bench_corpus_speed.py FAMILY SEED [--repeats N]``; to compare revisions, export
each (``git archive REV src | tar -x -C DIR``) and run with ``PYTHONPATH=DIR/src``. The recordings of
``bench_rx_revisions.py`` decode; a corpus recording at low SNR (e.g. ``fading 2718001``, none of whose
ten frames decodes) times the work done on frames whose CRC failed. Prints the median over ``--repeats``
runs after one to warm the numba caches.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("family", choices=("steep", "far", "fading", "impulsive"))
    ap.add_argument("seed", type=int)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)

    import bench_corpus
    from seamodem.receive import Emissions, Receiver, ReceiverSettings

    n = 10
    cfg, _, t_emit, rec = bench_corpus.recording(args.family, args.seed, n)

    def once() -> tuple[float, int]:
        rx = Receiver(cfg, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=True))
        before = resource.getrusage(resource.RUSAGE_SELF)
        records = list(rx.run([rec.samples], fs=cfg.sample_rate_hz))
        after = resource.getrusage(resource.RUSAGE_SELF)
        return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime), sum(
            r.crc_ok is True for r in records)

    once()
    runs = [once() for _ in range(args.repeats)]
    cpu = statistics.median(t for t, _ in runs)
    seconds = len(rec.samples) / cfg.sample_rate_hz
    print(f"{args.family} {args.seed}: {runs[0][1]} of {n} frames decoded; CPU {cpu:.2f} s (median of "
          f"{args.repeats}) for {seconds:.1f} s of recording: {seconds / cpu:.1f}x real time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
