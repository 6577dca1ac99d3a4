"""Navigation benchmark: wall time of paper 000's full Monte Carlo, and speed against filterpy.

Prints, in one run:

1. the wall time of the full reproduction (2 filters × 6 T_com × 300 missions of
   1550 s at Δt = 0.25 s) with the compiled kernel on all local cores;
2. the time of one mission, single core, for: the compiled kernel, our general
   EKF class in pure Python, and the same filter written with filterpy's
   ``ExtendedKalmanFilter`` (if filterpy is installed; it is *not* a dependency
   of seamodem — ``pip install filterpy`` to measure it), with the ratios and the
   largest difference between their tracks (same noise, same algebra).

Usage: python benchmarks/bench_navigation.py [--runs 300] [--missions 3]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from seamodem.navigation.montecarlo import (
    MissionConfig,
    mission_noise,
    run_monte_carlo,
    simulate_mission,
    simulate_mission_reference,
)


def filterpy_factory():
    """An EKF built on filterpy, plugged into the reference mission loop; None if filterpy is missing."""
    try:
        from filterpy.kalman import ExtendedKalmanFilter
    except ImportError:
        return None

    def wrap(a, b):
        d = a - b
        d[len(d) - 3] = math.atan2(math.sin(d[len(d) - 3]), math.cos(d[len(d) - 3]))  # ψ is 3rd from last
        return d

    class FilterpyEkf:
        def __init__(self, x0, P0, Q, model):
            class _Nonlinear(ExtendedKalmanFilter):
                def predict_x(inner, u=0):
                    inner.x = model.transition(inner.x, None, self.dt)

            self.model = model
            self.dt = 0.25
            self.ekf = _Nonlinear(dim_x=6, dim_z=5)
            self.ekf.x = np.array(x0, dtype=float)
            self.ekf.P = np.array(P0, dtype=float)
            self.ekf.Q = np.array(Q, dtype=float)
            self.t = 0.0

        @property
        def x(self):
            return self.ekf.x

        def predict(self, t_s):
            self.dt = t_s - self.t
            self.ekf.F = self.model.transition_jacobian(self.ekf.x, None, self.dt)
            self.ekf.predict()
            self.t = t_s

        def update(self, z, kind, R):
            self.ekf.update(np.asarray(z, dtype=float), lambda x: self.model.measurement_jacobian(x, kind),
                            lambda x: self.model.measure(x, kind), R=R, residual=wrap)

    return FilterpyEkf


def time_mission(fun, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = fun()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=300, help="missions per row of the full reproduction")
    parser.add_argument("--missions", type=int, default=3, help="repeats of the single-mission timings (median)")
    args = parser.parse_args()

    config = MissionConfig()
    reference, path = config.reference()
    n = reference.shape[0] - 1
    noise = mission_noise(0, 0, n)
    simulate_mission(config, noise, reference=reference)  # compile / load the numba cache outside the timing

    result = run_monte_carlo(config, runs=args.runs, seed=0)
    missions = 2 * len(result.tcoms) * args.runs
    print(f"Full reproduction: {missions} missions of {path.duration_s:.0f} s ({n} steps), "
          f"{os.cpu_count()} cores: wall time {result.wall_time_s:.2f} s")
    print()

    t_kernel, fast = time_mission(lambda: simulate_mission(config, noise, reference=reference), 20)
    t_python, slow = time_mission(lambda: simulate_mission_reference(config, noise, reference=reference),
                                  args.missions)
    rows = [("compiled kernel (seamodem)", t_kernel, 0.0),
            ("EKF class, pure Python (seamodem)", t_python, float(np.abs(slow[1] - fast[1]).max()))]
    factory = filterpy_factory()
    if factory is not None:
        t_fp, fp = time_mission(lambda: simulate_mission_reference(config, noise, reference=reference,
                                                                   filter_factory=factory), args.missions)
        rows.append(("filterpy ExtendedKalmanFilter", t_fp, float(np.abs(fp[1] - fast[1]).max())))
    print(f"One mission, one core, median of repeats (proposed filter, T_com = {config.tcom_s:g} s):")
    print(f"{'implementation':<36} | {'time per mission':>16} | {'ratio to kernel':>15} | "
          f"{'full repro (extrapolated, 1 core)':>33} | {'max track diff vs kernel':>24}")
    for name, t, diff in rows:
        print(f"{name:<36} | {t * 1e3:>13.2f} ms | {t / t_kernel:>14.0f}x | {t * missions:>31.0f} s | "
              f"{diff:>22.2e} m")
    if factory is None:
        print("filterpy: not installed (pip install filterpy to compare; seamodem does not depend on it)")
    else:
        ratio = rows[2][1] / t_kernel
        print(f"goal >= 20x faster than filterpy: {'met' if ratio >= 20 else 'NOT met'} ({ratio:.0f}x)")


if __name__ == "__main__":
    main()
