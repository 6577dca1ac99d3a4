"""Navigation beyond paper 000: the receiver's own measurement noise, and RTS smoothing in post-processing.

Prints, for T_com = 3…20 s (paper 000 §4.1 mission, controller steering on the
truth, the paper's filter: eq 25 R and Q):

1. the mean positioning error of the proposed filter and of ROSB with the
   paper-grade noise of the reproduction (σ_d = 3.46 m, σ_vr = 0.447 m/s) and
   with the noise our receiver achieves (σ_d = 2 cm, σ_vr = 2 cm/s: docs/receiver.md
   — range ≤ 3 mm measured at 10 dB, goal ≤ 2 cm; v_r ≈ ±2 cm/s on the channel
   simulator's multipath scenario);
2. the same runs smoothed with the Rauch–Tung–Striebel smoother
   (``error_of="smoothed"``, what ``seamodem nav track --smooth`` does) and the gain.

All runs share the seeds (common random numbers), so the gain is not sampling noise.
Outliers (paper's IQR rule) are counted and excluded in every cell.

Usage: python benchmarks/bench_navigation_receiver.py [--runs 100] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from seamodem.navigation.montecarlo import (
    PAPER_TABLE,
    MissionConfig,
    NoiseModel,
    run_monte_carlo,
)

TCOMS = (3, 6, 9, 12, 15, 20)
NOISES = {
    "paper-grade (3.46 m, 0.447 m/s)": NoiseModel(),
    "receiver (0.02 m, 0.02 m/s)": NoiseModel(sigma_range_m=0.02, sigma_vr_mps=0.02),
}


def rows_of(result):
    return {(r["tcom_s"], r["filter"]): r for r in result.rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100, help="missions per cell (default 100)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    start = time.perf_counter()
    print(f"paper 000 mission, controller on the truth, eq 25 filter, {args.runs} runs per cell, seed {args.seed}; "
          "mean error m (outliers)")
    print(f"{'noise':<32} | {'T_com':>5} | {'proposed filter':>15} | {'smoothed':>13} | {'gain':>5} | "
          f"{'ROSB filter':>13} | {'smoothed':>13} | {'gain':>5} | {'paper proposed / ROSB':>21}")
    for name, noise in NOISES.items():
        config = MissionConfig(noise=noise, steer_on_estimate=False)
        filt = rows_of(run_monte_carlo(config, tcoms=TCOMS, runs=args.runs, seed=args.seed))
        smooth = rows_of(run_monte_carlo(replace(config, error_of="smoothed"), tcoms=TCOMS, runs=args.runs,
                                         seed=args.seed))
        for t in map(float, TCOMS):
            cells = []
            for f in ("proposed", "rosb"):
                a, b = filt[(t, f)], smooth[(t, f)]
                gain = 100 * (b["mean_error_m"] / a["mean_error_m"] - 1)
                cells += [f"{a['mean_error_m']:>8.2f} ({a['outliers']:>3})", f"{b['mean_error_m']:>6.2f} ({b['outliers']:>3})",
                          f"{gain:>+4.0f}%"]
            p = PAPER_TABLE[t]
            print(f"{name:<32} | {t:>4g}s | {cells[0]:>15} | {cells[1]:>13} | {cells[2]:>5} | {cells[3]:>13} | "
                  f"{cells[4]:>13} | {cells[5]:>5} | {p[0]:>9.2f} / {p[5]:>9.2f}")
    print(f"wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
