"""A Monte Carlo study (small): paper 000's EKF (range + v_r) and ROSB (range only) beside the inertial filter, §4.1.

    python examples/monte_carlo.py [OUTDIR]        (default: monte_carlo_out/)

Paper 000's boustrophedon mission (1567 m in 1550 s, beacon at (50, 100)),
40 seeded runs per row instead of the paper's 300, at two frame periods, with
the receiver-grade measurement noise of docs/navigation.md ("Beyond the
paper": σ_range = 0.5 m, σ_vr = 0.05 m/s) and the controller steering on the
truth. The full reproduction is ``seamodem nav simulate`` (300 runs, six T_com).
Writes the table as text and CSV.
"""

import csv
import sys
from pathlib import Path

from seamodem.navigation import MissionConfig, NoiseModel, run_monte_carlo
from seamodem.navigation.montecarlo import format_table


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    config = MissionConfig(noise=NoiseModel(sigma_range_m=0.5, sigma_vr_mps=0.05), steer_on_estimate=False)
    result = run_monte_carlo(config, tcoms=(3, 12), runs=40, seed=0,
                             filters=("proposed", "rosb", "inertial", "inertial_range"))
    table = format_table(result)
    print(table)
    (out / "table.txt").write_text(table + "\n", encoding="utf-8")
    with open(out / "table.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(result.rows[0]))
        writer.writeheader()
        writer.writerows(result.rows)


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "monte_carlo_out"))
