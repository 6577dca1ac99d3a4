"""Monte Carlo reproduction of paper 000 §4.1 (Tables 3 and 4): proposed EKF versus ROSB.

Each run simulates a whole boustrophedon mission (:mod:`.mission_config`, :mod:`.missions`): the vehicle
follows the path with the feedback-linearization controller (eq 2), the IMU/AHRS
and the acoustic frames are emulated from the true geometry with the noise of
:class:`NoiseModel`, and the 6-state EKF (eq 5–7, 18–25) estimates the
position. This module runs the missions and tabulates them. Runs are
independent, seeded by (seed, run index) — the same noise for every T_com and
both filters (common random numbers), so differences between rows and filters
are not sampling noise — and spread over all local cores (the compiled kernel
releases the GIL, so threads suffice).

The names of :mod:`.mission_config` and :mod:`.missions` are re-exported here, where they were defined before.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
# re-exported: the mission settings and simulators were defined here before the split
from .mission_config import ALL_FILTERS, BIAS_MODELS, ERROR_OF, FILTERS, INERTIAL_FILTERS, MissionConfig, NoiseModel  # noqa: F401
from .missions import (  # noqa: F401
    held_fix_index,
    mission_noise,
    simulate_inertial_mission,
    simulate_mission,
    simulate_mission_reference,
)
from .paper import EQ25_R

__all__ = [
    "NoiseModel",
    "MissionConfig",
    "MonteCarloResult",
    "PAPER_TABLE",
    "FILTERS",
    "mission_noise",
    "simulate_mission",
    "simulate_mission_reference",
    "simulate_inertial_mission",
    "INERTIAL_FILTERS",
    "ALL_FILTERS",
    "BIAS_MODELS",
    "run_monte_carlo",
    "summarize_runs",
    "outlier_mask",
    "format_table",
]

#: Paper 000 Tables 3 and 4: T_com → (mean error [m], outliers, variance [m²], %etd max, %etd mean,
#: ROSB mean error [m], ROSB outliers).
PAPER_TABLE = {
    3.0: (3.6054, 1, 1.7549, 0.5268, 0.2281, 4.5870, 4),
    6.0: (5.0440, 5, 3.2143, 0.5850, 0.3152, 6.2255, 6),
    9.0: (6.4518, 1, 6.2173, 0.7662, 0.4032, 7.7197, 5),
    12.0: (8.0853, 6, 12.7455, 1.0938, 0.5053, 9.2462, 15),
    15.0: (9.5457, 6, 18.3823, 1.3950, 0.5966, 10.6684, 10),
    20.0: (12.1322, 6, 33.9161, 1.7825, 0.7583, 12.9695, 29),
}


def outlier_mask(values: np.ndarray) -> np.ndarray:
    """True for values outside [q1 − 1.5·IQR, q3 + 1.5·IQR] (paper 000 §4.1.1, lower bound as corrected in SPEC §5)."""
    q1, q3 = np.percentile(values, [25, 75])
    iqr = q3 - q1
    return (values < q1 - 1.5 * iqr) | (values > q3 + 1.5 * iqr)


def summarize_runs(mean_error: np.ndarray, var_error: np.ndarray, max_error: np.ndarray,
                   travelled: np.ndarray, *, divergence_m: float = 50.0) -> dict:
    """One row of Table 3 from per-run statistics; outliers counted then excluded.

    ``mean_error``, ``var_error``, ``max_error`` are each run's mean, variance and
    maximum of the position error over time [m, m², m]; ``travelled`` each run's
    travelled distance [m]. %etd = error / travelled distance × 100. ``diverged``
    counts the runs whose error ever exceeded ``divergence_m`` (or was not finite);
    they are among the outliers when the IQR rule catches them; ``diverged_in_mean``
    counts those it does not catch, which are inside the mean (:func:`format_table`
    then marks the mean as not a result).
    """
    diverged = ~np.isfinite(max_error) | (max_error > divergence_m)
    finite = np.isfinite(mean_error)
    out = ~finite
    out[finite] = outlier_mask(mean_error[finite])
    keep = ~out
    if not keep.any():
        nan = float("nan")
        return {"mean_error_m": nan, "error_variance_m2": nan, "etd_max_pct": nan, "etd_mean_pct": nan,
                "outliers": int(out.sum()), "diverged": int(diverged.sum()), "median_error_m": nan,
                "diverged_in_mean": 0}
    return {
        "mean_error_m": float(mean_error[keep].mean()),
        "error_variance_m2": float(var_error[keep].mean()),
        "etd_max_pct": float((100 * max_error[keep] / travelled[keep]).mean()),
        "etd_mean_pct": float((100 * mean_error[keep] / travelled[keep]).mean()),
        "outliers": int(out.sum()),
        "diverged": int(diverged.sum()),
        "median_error_m": float(np.median(mean_error[finite])) if finite.any() else float("nan"),
        "diverged_in_mean": int((diverged & keep).sum()),
    }


@dataclass
class MonteCarloResult:
    """Table rows plus what the figures need.

    ``rows``: list of dicts with ``tcom_s, filter`` and the :func:`summarize_runs` keys.
    ``mean_error_curve[(tcom, filter)]``: error averaged over the non-outlier runs, (n + 1,) [m].
    ``mean_track[(tcom, filter)]``: estimated track averaged over the same runs, (n + 1, 2) [m].
    ``per_run_mean_error[(tcom, filter)]``: each run's mean error, (runs,) [m].
    """

    config: MissionConfig
    tcoms: tuple
    runs: int
    seed: int
    rows: list
    t_s: np.ndarray
    truth_track: np.ndarray
    mean_error_curve: dict
    mean_track: dict
    per_run_mean_error: dict
    wall_time_s: float = 0.0


def _run_chunk(config, reference, filter, seed, runs):
    n = reference.shape[0] - 1
    stats = np.empty((len(runs), 4))
    curves = np.empty((len(runs), n + 1))
    track_sum = np.zeros((len(runs), n + 1, 2), dtype=np.float32)
    truth = None
    for i, run in enumerate(runs):
        error, estimate, truth = simulate_mission(config, mission_noise(seed, run, n), filter=filter,
                                                  reference=reference)
        travelled = np.sum(np.hypot(*np.diff(truth, axis=0).T))
        stats[i] = error.mean(), error.var(), error.max(), travelled
        curves[i] = error
        track_sum[i] = estimate
    return stats, curves, track_sum, truth


def _chunk_results(tasks, configs, reference, seed, workers, progress, backend, scheduler):
    """(T_com, filter, chunk output) in task order: on local threads, or with seamodem.batch."""
    if backend is None:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = [(t, f, pool.submit(_run_chunk, configs[t], reference, f, seed, r)) for t, f, r in tasks]
            for t, f, fut in futures:
                out = fut.result()
                if progress is not None:
                    progress(len(out[0]))
                yield t, f, out
        return
    from ..batch.runner import map_tasks

    outputs = map_tasks(
        _run_chunk_task,
        [(configs[t], reference, f, seed, r) for t, f, r in tasks],
        backend=backend,
        workers=workers,
        scheduler=scheduler,
        on_result=None if progress is None else (lambda res: progress(len(res.value[0])) if res.ok else None),
    )
    for (t, f, _), out in zip(tasks, outputs):
        yield t, f, out


def _run_chunk_task(args):
    return _run_chunk(*args)


def run_monte_carlo(config: MissionConfig, *, tcoms=(3, 6, 9, 12, 15, 20), runs: int = 300, seed: int = 0,
                    filters=FILTERS, workers: int | None = None, progress=None, backend: str | None = None,
                    scheduler=None) -> MonteCarloResult:
    """Reproduce paper 000 Tables 3–4: every (T_com, filter) pair over ``runs`` seeded missions.

    Parameters
    ----------
    config : MissionConfig
        Everything but ``tcom_s``, which takes each value of ``tcoms`` [s].
    runs : int
        Missions per row (paper: 300).
    seed : int
        Run ``r`` draws its noise from ``default_rng([seed, r])``.
    workers : int, optional
        Threads, or processes with ``backend`` (default: all local cores).
    progress : callable, optional
        Called with the number of runs finished, after each chunk.
    backend : {"serial", "processes", "dask"}, optional
        Run the chunks with :func:`seamodem.batch.run_tasks` instead of local
        threads: this process, local processes, or a Dask cluster
        (``scheduler``: address or client); the same numbers on every backend.
    scheduler : str or distributed.Client, optional
        Dask scheduler, with ``backend="dask"``.
    """
    import time

    if runs < 4:
        raise ConfigError("runs", f"must be >= 4 (quartiles for the outlier rule), got {runs!r}")
    for f in filters:
        if f not in ALL_FILTERS:
            raise ConfigError("filter", f"must be one of {ALL_FILTERS}, got {f!r}")
    configs = {float(t): replace(config, tcom_s=float(t)) for t in tcoms}
    reference, _ = config.reference()
    workers = workers or os.cpu_count() or 1
    chunk = max(1, min(25, runs // workers))
    tasks = [(t, f, range(a, min(a + chunk, runs))) for t in configs for f in filters for a in range(0, runs, chunk)]
    start = time.perf_counter()
    parts: dict = {}
    truth = None
    for t, f, (stats, curves, tracks, truth) in _chunk_results(tasks, configs, reference, seed, workers, progress,
                                                               backend, scheduler):
        parts.setdefault((t, f), []).append((stats, curves, tracks))
    wall = time.perf_counter() - start
    rows, curves_out, tracks_out, per_run = [], {}, {}, {}
    for (t, f), pieces in parts.items():
        stats = np.vstack([p[0] for p in pieces])
        finite = np.isfinite(stats[:, 0]) & np.isfinite(stats[:, 2])
        keep = finite & (stats[:, 2] <= config.divergence_m)
        keep[finite] &= ~outlier_mask(stats[finite, 0])
        curves, tracks = np.vstack([p[1] for p in pieces]), np.concatenate([p[2] for p in pieces])
        # every run diverged or strayed: no mean to draw (NaN, and the table says UNSTABLE)
        curves_out[(t, f)] = curves[keep].mean(axis=0) if keep.any() else np.full(curves.shape[1], np.nan)
        tracks_out[(t, f)] = tracks[keep].mean(axis=0) if keep.any() else np.full(tracks.shape[1:], np.nan)
        per_run[(t, f)] = stats[:, 0]
        rows.append({"tcom_s": t, "filter": f, **summarize_runs(*stats.T, divergence_m=config.divergence_m)})
    rows.sort(key=lambda r: (r["tcom_s"], ALL_FILTERS.index(r["filter"])))
    n = reference.shape[0] - 1
    return MonteCarloResult(config, tuple(configs), runs, seed, rows, np.arange(n + 1) * config.dt_s, truth,
                            curves_out, tracks_out, per_run, wall)


def _q_text(config: MissionConfig) -> str:
    q = config.process_diag
    if np.all(q == q[0]):
        return f"{q[0]:.3g} I6"
    return "diag(" + ", ".join(f"{v:.3g}" for v in q) + ")"


def format_table(result: MonteCarloResult, *, paper: bool = True) -> str:
    """The result as text: paper 000's Tables 3 and 4 (with the paper's values when ``paper``) for its
    filters, and one table of every estimator that ran, with outlier and divergence counts.

    Every cell gives its mean, with the outliers and the diverged runs counted beside it. A diverged
    run (error above ``divergence_m`` at some time: the filter lost the vehicle) is excluded from the
    mean with the outliers when the IQR rule catches it; a mean that still holds one is marked ``!``
    and is not a result. The lines under the table say which case each count is.
    """
    by = {(r["tcom_s"], r["filter"]): r for r in result.rows}
    ran = [f for f in ALL_FILTERS if any((t, f) in by for t in result.tcoms)]
    noise = result.config.noise
    lines = [
        f"Monte Carlo, {result.runs} runs per row, seed {result.seed}, dt = {result.config.dt_s} s, "
        f"controller steers on the {'estimate' if result.config.steer_on_estimate else 'truth'}",
        f"noise: range {noise.sigma_range_m:.3g} m, v_r {noise.sigma_vr_mps:.3g} m/s, heading "
        f"{noise.sigma_heading_deg:.3g} deg + bias {noise.heading_drift_deg_per_h:.3g} deg/h "
        f"({noise.heading_bias_model.replace('_', ' ')}), gyro {noise.sigma_omega_rad_s:.3g} rad/s, accel "
        f"{noise.sigma_accel_mps2:.3g} m/s^2"
        + (f", array bearing {noise.sigma_bearing_deg:.3g} deg" if noise.sigma_bearing_deg > 0 else ""),
    ]
    if any(f in FILTERS for f in ran):
        lines.append(f"paper filters: R = {result.config.r_diag} (d, v_r, psi, omega, a), "
                     f"Q = {_q_text(result.config)}; error of the {result.config.error_of.replace('_', ' ')}")
    if any(f in INERTIAL_FILTERS for f in ran):
        ic = result.config.inertial_config
        lines.append(f"inertial filter: sensor densities told the truth, bias drift state "
                     f"{'on' if ic.estimate_bias_drift else 'off'}, gate {ic.gate_probability}; fixed lag "
                     f"{result.config.lag_s:g} s")
    lines.append(f"mean over the runs kept: outliers (IQR rule on the runs' mean errors) are counted, then "
                 f"excluded; diverged = runs whose error exceeded {result.config.divergence_m:g} m at some time "
                 "(the filter lost the vehicle), counted beside the mean")

    def cell(r):
        if r is None:
            return f"{'':>22}"
        mark = "!" if r.get("diverged_in_mean", 0) else " "
        if not math.isfinite(r["mean_error_m"]):
            return f"{'no mean':>10} ({r['outliers']:>3}, {r['diverged']:>2}){mark}"
        return f"{r['mean_error_m']:>10.3f} ({r['outliers']:>3}, {r['diverged']:>2}){mark}"

    if "proposed" in ran and paper:
        lines += ["", "Table 3 (paper 000's proposed filter)",
                  f"{'T_com':>6} | {'mean error m (outliers, diverged)':>33} | {'variance m2':>11} | {'%etd max':>8} | "
                  f"{'%etd mean':>9} || {'paper mean (out)':>17} | {'paper var':>9} | {'ratio':>5}"]
        for t in result.tcoms:
            r = by.get((t, "proposed"))
            if r is None:
                continue
            line = (f"{t:>5g}s | {cell(r):>33} | {r['error_variance_m2']:>11.4f} | "
                    f"{r['etd_max_pct']:>8.4f} | {r['etd_mean_pct']:>9.4f}")
            if t in PAPER_TABLE:
                p = PAPER_TABLE[t]
                ratio = "  -  " if r.get("diverged_in_mean", 0) else f"{r['mean_error_m'] / p[0]:>5.2f}"
                line += f" || {p[0]:>11.4f} ({p[1]:>3}) | {p[2]:>9.4f} | {ratio}"
            lines.append(line)
    lines += ["", "Mean position error [m] (outliers, diverged) per estimator"
              + (" | paper proposed / ROSB" if paper else ""),
              f"{'T_com':>6} | " + " | ".join(f"{f:>22}" for f in ran) + (" | paper" if paper else "")]
    for t in result.tcoms:
        line = f"{t:>5g}s | " + " | ".join(cell(by.get((t, f))) for f in ran)
        if paper and t in PAPER_TABLE:
            line += f" | {PAPER_TABLE[t][0]:.2f} / {PAPER_TABLE[t][5]:.2f}"
        lines.append(line)
    if paper and (abs(noise.sigma_range_m - math.sqrt(EQ25_R["range"])) > 1e-9
                  or abs(noise.sigma_vr_mps - math.sqrt(EQ25_R["v_r"])) > 1e-9):
        lines.append(f"(the paper's values are at its own noise, range {math.sqrt(EQ25_R['range']):.3g} m and v_r "
                     f"{math.sqrt(EQ25_R['v_r']):.3g} m/s; this table is at the noise above)")
    diverged = sum(r["diverged"] for r in result.rows)
    inside = sum(r.get("diverged_in_mean", 0) for r in result.rows)
    if diverged:
        lines += ["", f"{diverged} run(s) diverged in all (of {result.runs} per row); "
                      + (f"{diverged - inside} are among the outliers, outside the means. " if diverged > inside
                         else "")
                      + (f"{inside} are inside the means marked '!': those means are not results. " if inside
                         else "Every mean above is over runs that stayed within "
                              f"{result.config.divergence_m:g} m. ")
                      + "(docs/navigation.md, 'Stable defaults')"]
    lines.append(f"wall time {result.wall_time_s:.1f} s")
    return "\n".join(lines)
