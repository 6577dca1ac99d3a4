"""Channel simulator benchmark: speed and memory on a 10-minute 96 kHz recording with 4 paths.

Run: python benchmarks/bench_channel.py [--minutes 10] [--repeats 1]

Writes a jmse2024 beacon recording (a frame every 3 s), then runs the whole
``seamodem channel`` pipeline (read WAV, 4 geometric paths with per-sample
delays, spreading and absorption, noise, write WAV + JSON truth) on one core,
for three scenarios: real path gains, fluctuating (complex) path gains, and the
same with a clock offset. Prints simulated seconds per wall second (goal ≥ 20)
and peak memory: Python allocations (tracemalloc, a separate run) and the
process's peak resident set (ru_maxrss).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy and numba start their pools

import argparse
import resource
import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path


from seamodem import BeaconSchedule, get_preset
from seamodem.channel import parse_scenario, simulate_file
from seamodem.transmit.beacon import write_beacon

BASE = {
    "mode": "geometry",
    "seed": 1,
    "environment": {"sound_speed_mps": 1500.0, "water_depth_m": 30.0},
    "beacon": {"position_m": [0.0, 0.0, -10.0]},
    "vehicle": {"start_m": [-400.0, 60.0, -5.0], "velocity_mps": [1.5, 0.0, 0.0]},
    "multipath": {"max_bounces": 2, "max_paths": 4, "surface_rms_height_m": 0.02},
    "noise": {"kind": "white", "snr_db": 15.0},
}

SCENARIOS = {
    "4 paths, real gains": {},
    "4 paths, fading echoes (0.5 Hz)": {"fluctuation": {"doppler_spread_hz": 0.5, "k_factor_db": 3.0}},
    "4 paths, fading + clock 2 ppm": {"fluctuation": {"doppler_spread_hz": 0.5, "k_factor_db": 3.0},
                                      "clock": {"offset_s": 0.001, "sample_rate_offset_ppm": 2.0}},
}


def scenario(extra: dict):
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in BASE.items()}
    data.update(extra)
    return parse_scenario(data)


def run(wav: Path, out: Path, sc) -> float:
    t0 = time.perf_counter()
    simulate_file(wav, sc, out, progress=False)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    cfg = get_preset("jmse2024")
    count = int(args.minutes * 60 / 3.0)
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "beacon.wav"
        write_beacon(wav, cfg, BeaconSchedule(count=count, period_s=3.0), progress=False)
        duration = count * 3.0
        n_samples = int(duration * cfg.sample_rate_hz)
        run(wav, Path(tmp) / "warm.wav", scenario({}))  # compile the numba kernel outside the timing
        print(f"input: {duration / 60:.1f} min at {cfg.sample_rate_hz:g} Hz ({n_samples / 1e6:.1f} M samples), "
              f"{count} jmse2024 frames; one core")
        print(f"{'scenario':36s} {'wall s':>8s} {'sim s / wall s':>15s} {'goal':>6s}")
        for name, extra in SCENARIOS.items():
            sc = scenario(extra)
            times = [run(wav, Path(tmp) / "out.wav", sc) for _ in range(args.repeats)]
            wall = statistics.median(times)
            print(f"{name:36s} {wall:8.1f} {duration / wall:15.1f} {'>= 20':>6s}")
        tracemalloc.start()
        run(wav, Path(tmp) / "out.wav", scenario(SCENARIOS["4 paths, fading echoes (0.5 Hz)"]))
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
        print(f"peak Python allocations (tracemalloc, fading run): {peak / 2**20:.1f} MiB; "
              f"peak resident set of the whole benchmark: {rss:.0f} MiB "
              f"(the output alone would be {n_samples * 8 / 2**20:.0f} MiB as float64)")


if __name__ == "__main__":
    main()
