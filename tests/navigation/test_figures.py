"""Track plot: error ellipses from covariances, GNSS fixes, the old sigma_xy callers."""

import numpy as np
import pytest

from seamodem.errors import ConfigError
from seamodem.navigation import figures
from seamodem.navigation.figures import error_ellipses, plot_track


def rotated_cov(sigma_major, sigma_minor, angle_rad):
    """C = R(θ) diag(a², b²) R(θ)ᵀ: an ellipse built from its axes, independently of any eigen-solver."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([sigma_major**2, sigma_minor**2]) @ rot.T


def test_ellipse_axes_are_n_sigma_times_the_root_eigenvalues():
    angles = np.radians([0.0, 30.0, -60.0, 89.0])
    cov = np.array([rotated_cov(3.0, 1.0, a) for a in angles] + [np.diag([0.25, 4.0])])
    major, minor, angle = error_ellipses(cov, n_sigma=2.0)
    # Built from known axes: only float64 rounding (≈1e-15 relative) separates the answer from the inputs.
    np.testing.assert_allclose(major, [6.0] * 4 + [4.0], rtol=1e-12)
    np.testing.assert_allclose(minor, [2.0] * 4 + [1.0], rtol=1e-12)
    np.testing.assert_allclose(angle, np.r_[angles, np.pi / 2], atol=1e-12)  # σ_y > σ_x: major axis along y


def test_ellipse_boundary_is_the_n_sigma_contour():
    cov = rotated_cov(2.0, 0.5, 0.7) + np.array([[0.1, 0.05], [0.05, 0.0]])  # not built from the axes
    major, minor, angle = error_ellipses(cov, n_sigma=3.0)
    phi = np.linspace(0, 2 * np.pi, 17)
    c, s = np.cos(angle[0]), np.sin(angle[0])
    boundary = np.c_[major[0] * np.cos(phi) * c - minor[0] * np.sin(phi) * s,
                     major[0] * np.cos(phi) * s + minor[0] * np.sin(phi) * c]
    mahalanobis2 = np.einsum("ij,jk,ik->i", boundary, np.linalg.inv(cov), boundary)
    np.testing.assert_allclose(mahalanobis2, 9.0, rtol=1e-10)  # pᵀC⁻¹p = n² on the whole boundary; rounding only


def test_ellipse_input_errors_name_the_parameter():
    with pytest.raises(ConfigError, match=r"^cov_xy: must have shape \(n, 2, 2\), got \(4, 3\)$"):
        error_ellipses(np.zeros((4, 3)))
    with pytest.raises(ConfigError, match=r"^cov_xy: must be symmetric$"):
        error_ellipses([[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(ConfigError, match=r"^cov_xy: must be positive semi-definite, matrix 0 has eigenvalue -1 m²$"):
        error_ellipses([[1.0, 0.0], [0.0, -1.0]])


def capture_figure(monkeypatch):
    """Keep the figure plot_track saves (and closes), to inspect its patches."""
    saved = {}
    real_save = figures._save

    def keep_and_save(fig, path):
        saved["fig"] = fig
        real_save(fig, path)

    monkeypatch.setattr(figures, "_save", keep_and_save)
    return saved


def test_plot_track_draws_about_thirty_ellipses_and_the_fixes(tmp_path, monkeypatch):
    from matplotlib.patches import Ellipse

    saved = capture_figure(monkeypatch)
    n = 500
    t = np.arange(n) * 0.25
    xy = np.c_[t, np.sin(t / 10)]
    cov = np.array([rotated_cov(1 + 0.01 * k, 0.5, 0.3) for k in range(n)])
    path = tmp_path / "track.png"
    plot_track(t, xy, path, beacon_xy=(50.0, 30.0), cov_xy=cov, fixes_xy=[(0.0, 0.0), (120.0, 0.5)], truth_xy=xy)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ax = saved["fig"].axes[0]
    ellipses = [p for p in ax.patches if isinstance(p, Ellipse)]
    assert len(ellipses) == 30
    # the last ellipse sits on the last estimate with the 2-σ axes of its covariance
    assert ellipses[-1].center == pytest.approx(tuple(xy[-1]))
    assert ellipses[-1].width == pytest.approx(2 * 2 * (1 + 0.01 * (n - 1)))
    labels = [h.get_label() for h in ax.get_legend().legend_handles]
    assert "2-σ error ellipse (86.5 %)" in labels and "GNSS fix" in labels


def test_plot_track_still_takes_sigma_xy(tmp_path, monkeypatch):
    from matplotlib.patches import Ellipse

    saved = capture_figure(monkeypatch)
    t = np.arange(10.0)
    plot_track(t, np.c_[t, t], tmp_path / "old.png", beacon_xy=(0, 0), sigma_xy=np.c_[np.full(10, 2.0), np.ones(10)])
    assert (tmp_path / "old.png").stat().st_size > 1000
    ellipses = [p for p in saved["fig"].axes[0].patches if isinstance(p, Ellipse)]
    assert len(ellipses) == 10  # fewer estimates than n_ellipses: one each
    assert (ellipses[0].width, ellipses[0].height) == pytest.approx((8.0, 4.0))  # 2-σ of σx = 2, σy = 1


def top_view_result(truth_end_xy, *, rows):
    """A Monte Carlo result as nav simulate returns it, with tracks we choose (the planned path of a real config)."""
    from types import SimpleNamespace

    from seamodem.navigation.montecarlo import MissionConfig

    config = MissionConfig()
    planned = config.reference()[0][:, :2]
    drift = np.linspace(0.0, 1.0, len(planned))[:, None] * (np.asarray(truth_end_xy) - planned[-1])
    mean_track = {(3.0, "inertial"): planned + 0.5, (20.0, "inertial"): np.full_like(planned, np.nan)}
    return SimpleNamespace(config=config, runs=300, tcoms=(3.0, 20.0), truth_track=planned + drift,
                           mean_track=mean_track, rows=rows), planned


def test_top_view_draws_no_diverged_track_and_counts_the_runs_it_averages(tmp_path, monkeypatch):
    saved = capture_figure(monkeypatch)
    rows = [{"tcom_s": 3.0, "filter": "inertial", "outliers": 4, "diverged": 0},
            {"tcom_s": 20.0, "filter": "inertial", "outliers": 300, "diverged": 300}]
    # the last run diverged: its vehicle, steered on the estimate, ended at (-1600, -500) m
    result, planned = top_view_result((-1600.0, -500.0), rows=rows)
    figures.plot_top_view(result, tmp_path / "fig7.png")
    ax = saved["fig"].axes[0]
    drawn = np.vstack([line.get_xydata() for line in ax.get_lines() if len(line.get_xdata())])
    assert np.isfinite(drawn).all()
    lo, hi = planned.min(axis=0) - 50.0, planned.max(axis=0) + 50.0
    assert ((drawn >= lo) & (drawn <= hi)).all(), "a line leaves the planned area by more than divergence_m"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "actual (one run)" not in labels
    assert "estimate, T_com = 3 s (mean of 296 of 300 runs)" in labels
    assert "T_com = 20 s: every run diverged or strayed" in labels
    assert "mean of 300" not in ax.get_title() and (tmp_path / "fig7.png").stat().st_size > 0


def test_top_view_draws_a_run_that_stayed_and_a_count_range_when_ambiguous(tmp_path, monkeypatch):
    saved = capture_figure(monkeypatch)
    rows = [{"tcom_s": 3.0, "filter": "inertial", "outliers": 5, "diverged": 2},
            {"tcom_s": 20.0, "filter": "inertial", "outliers": 300, "diverged": 300}]
    result, planned = top_view_result((0.0, 0.0), rows=rows)
    result.truth_track = planned + 3.0  # 4.2 m off the plan, within divergence_m = 50 m
    figures.plot_top_view(result, tmp_path / "fig7.png")
    labels = [t.get_text() for t in saved["fig"].axes[0].get_legend().get_texts()]
    # the 2 diverged runs may or may not be among the 5 outliers: 293 to 295 runs averaged
    assert "actual (one run)" in labels and "estimate, T_com = 3 s (mean of 293-295 of 300 runs)" in labels
