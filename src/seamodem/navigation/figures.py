"""Navigation figures: paper 000 Fig. 7 (top view) and Fig. 8 (error versus time), track plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import atomic_outputs
from ..plots import _pyplot

__all__ = ["plot_top_view", "plot_error_curves", "plot_track"]


def plot_top_view(result, path: str | Path, *, filter: str = "proposed", n_tcom: int = 4) -> None:
    """Fig. 7: the true track and the run-averaged estimated tracks of the ``n_tcom`` shortest T_com."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5, 7))
    ax.plot(*result.truth_track.T, "k", lw=1.5, label="actual (last run)")
    for t in sorted(result.tcoms)[:n_tcom]:
        if (t, filter) in result.mean_track:
            ax.plot(*result.mean_track[(t, filter)].T, lw=0.9, label=f"estimate, T_com = {t:g} s")
    ax.plot(*result.config.beacon_xy, "b*", ms=12, label="beacon")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(f"{filter}: mean of {result.runs} runs")
    _save(fig, path)


def plot_error_curves(result, path: str | Path) -> None:
    """Fig. 8: run-averaged position error versus mission time, per T_com, both filters."""
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    travelled = np.cumsum(np.r_[0.0, np.hypot(*np.diff(result.truth_track, axis=0).T)])[-1]
    for ax, filter in zip(axes, ("proposed", "rosb")):
        for t in result.tcoms:
            if (t, filter) in result.mean_error_curve:
                curve = result.mean_error_curve[(t, filter)]
                ax.plot(result.t_s, curve, lw=0.8, label=f"T_com = {t:g} s")
        ax.set_ylabel("mean position error [m]")
        ax.set_title(f"{filter} ({result.runs} runs, outliers excluded); 1 m = {100 / travelled:.3f} %etd")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=3)
    axes[-1].set_xlabel("mission time [s]")
    _save(fig, path)


def plot_track(t_s, estimate_xy, path: str | Path, *, beacon_xy, sigma_xy=None, truth_xy=None, title="") -> None:
    """A navigation track with its 1-σ band, the beacon and the truth when known."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 6))
    if truth_xy is not None:
        ax.plot(*np.asarray(truth_xy).T, "k", lw=1.2, label="truth")
    ax.plot(*np.asarray(estimate_xy).T, "C0", lw=1.0, label="estimate")
    if sigma_xy is not None:
        radius = np.hypot(*np.asarray(sigma_xy).T)
        step = max(1, len(radius) // 40)
        for (x, y), r in zip(np.asarray(estimate_xy)[::step], radius[::step]):
            ax.add_patch(plt.Circle((x, y), r, color="C0", alpha=0.15, lw=0))
    ax.plot(*np.asarray(beacon_xy, dtype=float).reshape(-1, 2).T, "b*", ms=12, label="beacon")
    ax.set_aspect("equal")
    ax.set_xlabel("east x [m]")
    ax.set_ylabel("north y [m]")
    ax.legend(fontsize=8)
    ax.set_title(title)
    _save(fig, path)


def _save(fig, path) -> None:
    """Write ``fig`` as PNG atomically (``path`` may itself be a temporary name without the suffix)."""
    plt = _pyplot()
    fig.tight_layout()
    with atomic_outputs(path) as (tmp,):
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
