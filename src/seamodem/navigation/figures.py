"""Navigation figures: paper 000 Fig. 7 (top view) and Fig. 8 (error versus time), track plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..plots import legend_outside, pyplot, save_figure

__all__ = ["plot_top_view", "plot_error_curves", "plot_track", "error_ellipses"]


def _filters_run(result) -> list:
    seen = []
    for _, f in result.mean_track:
        if f not in seen:
            seen.append(f)
    return seen


def plot_top_view(result, path: str | Path, *, filter: str | None = None, n_tcom: int = 4) -> None:
    """Fig. 7: the planned path and the run-averaged estimated tracks of the ``n_tcom`` shortest T_com.

    ``filter`` defaults to the first estimator of the result. Each estimated track is the mean over the runs
    that neither diverged (error above ``config.divergence_m``) nor were outliers; its legend entry says how
    many runs that is. The one true track the result keeps (its last run) is drawn only if it stayed within
    ``divergence_m`` of the planned path: steering on the estimate, a diverged run's vehicle goes anywhere
    (one went to (-1600, -500) m), and no mean of runs should be drawn beside it unannounced.
    """
    filter = filter or _filters_run(result)[0]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 7))
    planned = result.config.reference()[0][:, :2]
    ax.plot(*planned.T, color="0.6", lw=3, alpha=0.6, label="planned path")
    truth = np.asarray(result.truth_track, dtype=float)
    if truth.shape == planned.shape:
        stray_m = float(np.max(np.hypot(*(truth - planned).T))) if np.isfinite(truth).all() else float("inf")
        if stray_m <= result.config.divergence_m:
            ax.plot(*truth.T, "k", lw=1.2, label="actual (one run)")
    rows = {r["tcom_s"]: r for r in result.rows if r["filter"] == filter}
    for t in sorted(result.tcoms)[:n_tcom]:
        track, row = result.mean_track.get((t, filter)), rows.get(t)
        if track is None or row is None:
            continue
        # the mean leaves out the outliers and the diverged runs; a diverged run is usually one of the
        # outliers, and the row does not say which, so the count is exact only when one set is empty
        low = max(result.runs - row["outliers"] - row["diverged"], 0)
        high = result.runs - max(row["outliers"], row["diverged"])
        if high == 0 or not np.isfinite(track).all():
            ax.plot([], [], " ", label=f"T_com = {t:g} s: every run diverged or strayed")
            continue
        n = f"{high}" if low == high else f"{low}-{high}"
        ax.plot(*track.T, lw=0.9, label=f"estimate, T_com = {t:g} s (mean of {n} of {result.runs} runs)")
    ax.plot(*result.config.beacon_xy, "b*", ms=12, label="beacon")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    legend_outside(ax, fontsize=7)
    ax.set_title(f"{filter}: mean estimated tracks (runs that diverged\n"
                 f"beyond {result.config.divergence_m:g} m or strayed left out)", fontsize=9)
    _save(fig, path)


def plot_error_curves(result, path: str | Path) -> None:
    """Fig. 8: run-averaged position error versus mission time, per T_com, one panel per estimator."""
    plt = pyplot()
    filters = _filters_run(result)
    fig, axes = plt.subplots(len(filters), 1, figsize=(10, 3 * len(filters)), sharex=True, squeeze=False)
    axes = axes[:, 0]
    travelled = np.cumsum(np.r_[0.0, np.hypot(*np.diff(result.truth_track, axis=0).T)])[-1]
    for ax, filter in zip(axes, filters):
        for t in result.tcoms:
            if (t, filter) in result.mean_error_curve:
                curve = result.mean_error_curve[(t, filter)]
                ax.plot(result.t_s, curve, lw=0.8, label=f"T_com = {t:g} s")
        ax.set_ylabel("mean position error [m]")
        ax.set_title(f"{filter} ({result.runs} runs, outliers excluded); 1 m = {100 / travelled:.3f} %etd")
        ax.grid(alpha=0.3)
        legend_outside(ax, fontsize=7)
    axes[-1].set_xlabel("mission time [s]")
    _save(fig, path)


def error_ellipses(cov_xy, n_sigma: float = 2.0):
    """Axes and orientation of the n-σ error ellipses of 2×2 position covariances.

    Parameters
    ----------
    cov_xy : array_like, shape (n, 2, 2) or (2, 2)
        Covariances of (x, y) [m²], symmetric positive semi-definite.
    n_sigma : float
        Scale of the ellipse: its boundary is the set of offsets p with
        pᵀ C⁻¹ p = n_sigma². A 2-D Gaussian falls inside with probability
        1 − exp(−n_sigma²/2): 39.3 % at 1, 86.5 % at 2, 98.9 % at 3.

    Returns
    -------
    semi_major_m, semi_minor_m : ndarray, shape (n,)
        n_sigma · √λ of the larger and smaller eigenvalue [m].
    angle_rad : ndarray, shape (n,)
        Direction of the major axis, counter-clockwise from +x, in (−π/2, π/2] [rad].

    Raises
    ------
    ConfigError
        A shape other than (n, 2, 2), an asymmetric matrix, or a negative eigenvalue
        beyond rounding.
    """
    cov = np.asarray(cov_xy, dtype=float)
    if cov.shape == (2, 2):
        cov = cov[None]
    if cov.ndim != 3 or cov.shape[1:] != (2, 2):
        raise ConfigError("cov_xy", f"must have shape (n, 2, 2), got {np.shape(cov_xy)}")
    if not n_sigma > 0:
        raise ConfigError("n_sigma", f"must be > 0, got {n_sigma!r}")
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), np.finfo(float).tiny)
    if np.any(np.abs(cov[:, 0, 1] - cov[:, 1, 0]) > 1e-9 * scale):
        raise ConfigError("cov_xy", "must be symmetric")
    eigenvalues, eigenvectors = np.linalg.eigh(cov)  # ascending
    if np.any(eigenvalues[:, 0] < -1e-9 * scale):
        k = int(np.flatnonzero(eigenvalues[:, 0] < -1e-9 * scale)[0])
        raise ConfigError("cov_xy", f"must be positive semi-definite, matrix {k} has eigenvalue {eigenvalues[k, 0]:.3g} m²")
    lam = np.maximum(eigenvalues, 0.0)
    major = eigenvectors[:, :, 1]
    angle = np.arctan2(major[:, 1], major[:, 0])
    angle = np.where(angle <= -np.pi / 2, angle + np.pi, np.where(angle > np.pi / 2, angle - np.pi, angle))
    return n_sigma * np.sqrt(lam[:, 1]), n_sigma * np.sqrt(lam[:, 0]), angle


def plot_track(t_s, estimate_xy, path: str | Path, *, beacon_xy, sigma_xy=None, cov_xy=None, truth_xy=None,
               fixes_xy=None, title="", n_sigma: float = 2.0, n_ellipses: int = 30) -> None:
    """A navigation track with its error ellipses, the beacon, GNSS fixes and the truth when known.

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Times of the estimates [s].
    estimate_xy : array_like, shape (n, 2)
        Estimated positions [m].
    path : str or Path
        PNG file to write.
    beacon_xy : array_like, shape (2,) or (k, 2)
        Beacon position(s) [m].
    sigma_xy : array_like, shape (n, 2), optional
        Standard deviations of x and y [m], used as a diagonal covariance when
        ``cov_xy`` is not given.
    cov_xy : array_like, shape (n, 2, 2), optional
        Position covariances [m²]: the full ellipse, orientation included.
    truth_xy : array_like, shape (n, 2), optional
        True positions [m].
    fixes_xy : array_like, shape (m, 2), optional
        GNSS fixes [m], drawn as markers.
    n_sigma : float
        Ellipse scale (:func:`error_ellipses`); the legend states it and its probability.
    n_ellipses : int
        About this many ellipses, at evenly spaced estimates.
    """
    plt = pyplot()
    from matplotlib.patches import Ellipse

    estimate = np.asarray(estimate_xy, dtype=float)
    if cov_xy is None and sigma_xy is not None:
        sigma = np.asarray(sigma_xy, dtype=float)
        cov_xy = np.zeros((len(sigma), 2, 2))
        cov_xy[:, 0, 0], cov_xy[:, 1, 1] = sigma[:, 0] ** 2, sigma[:, 1] ** 2
    fig, ax = plt.subplots(figsize=(8.5, 6))
    if truth_xy is not None:
        ax.plot(*np.asarray(truth_xy).T, "k", lw=1.2, label="truth")
    ax.plot(*estimate.T, "C0", lw=1.0, label="estimate")
    if cov_xy is not None and len(estimate):
        rows = np.unique(np.linspace(0, len(estimate) - 1, max(1, n_ellipses)).round().astype(int))
        major, minor, angle = error_ellipses(np.asarray(cov_xy, dtype=float)[rows], n_sigma)
        inside = 1 - np.exp(-(n_sigma**2) / 2)
        for k, (i, a, b, th) in enumerate(zip(rows, major, minor, angle)):
            ax.add_patch(Ellipse(tuple(estimate[i]), 2 * a, 2 * b, angle=np.degrees(th), facecolor="C0", alpha=0.2,
                                 edgecolor="C0", lw=0.5,
                                 label=f"{n_sigma:g}-σ error ellipse ({100 * inside:.1f} %)" if k == 0 else None))
    if fixes_xy is not None:
        ax.plot(*np.asarray(fixes_xy, dtype=float).reshape(-1, 2).T, "g^", ms=7, label="GNSS fix")
    ax.plot(*np.asarray(beacon_xy, dtype=float).reshape(-1, 2).T, "b*", ms=12, label="beacon")
    ax.set_aspect("equal")
    ax.set_xlabel("east x [m]")
    ax.set_ylabel("north y [m]")
    legend_outside(ax, fontsize=8)
    ax.set_title(title)
    _save(fig, path)


def _save(fig, path) -> None:
    """The navigation figures' layout and resolution (tight, 120 dpi), written by :func:`~seamodem.plots.save_figure`."""
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
