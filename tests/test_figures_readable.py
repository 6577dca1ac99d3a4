"""Issue 29 item 11: in the demo's and nav's figures no curve hides under another and no legend covers the data."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from scipy.spatial import cKDTree

import seamodem.demo.figures as demo_figures
import seamodem.navigation.figures as nav_figures
from seamodem.cli import main


def hidden_lines(ax) -> list[tuple[str, str]]:
    """(hidden, by) label pairs: a line every point of which lies under a later line that hides it.

    A later line hides an earlier one when it covers each of its points (within half its width plus a pixel,
    in display coordinates) and either has the same colour (the two cannot be told apart) or is solid and
    at least as wide (nothing of the earlier one shows beside it).
    """
    fig = ax.figure
    px_per_pt = fig.dpi / 72
    lines = [ln for ln in ax.lines if ln.get_visible() and len(ln.get_xydata()) > 1]
    found = []
    for below, above in itertools.combinations(lines, 2):  # ax.lines is in drawing order
        if above.get_zorder() < below.get_zorder():
            below, above = above, below
        same_colour = to_rgba(below.get_color(), below.get_alpha()) == to_rgba(above.get_color(), above.get_alpha())
        covers = above.get_linestyle() == "-" and above.get_linewidth() >= below.get_linewidth()
        if not (same_colour or covers):
            continue
        pts_below = ax.transData.transform(below.get_xydata())
        pts_above = ax.transData.transform(above.get_xydata())
        distance, _ = cKDTree(pts_above).query(pts_below)
        if np.all(distance <= above.get_linewidth() * px_per_pt / 2 + 1.0):
            found.append((below.get_label(), above.get_label()))
    return found


def legend_overlaps_axes(ax) -> bool:
    legend = ax.get_legend()
    renderer = ax.figure.canvas.get_renderer()
    return legend is not None and legend.get_window_extent(renderer).overlaps(ax.get_window_extent(renderer))


FIGURES = ["map.png", "errors.png", "psd.png", "fig7_top_view.png", "fig8_error.png", "track.png"]


@pytest.fixture(scope="module")
def demo_figures_drawn(tmp_path_factory):
    """The figures of a 60 s demo, of nav track on its files and of a small nav simulate, kept open, not saved."""
    kept = {}
    def keep(fig, path, **_):  # nav track draws into its outputs' temporary files, .track.png.*.part
        kept[re.sub(r"^\.(.+?\.png)\..*\.part$", r"\1", Path(path).name)] = fig

    originals = demo_figures.save_figure, nav_figures.save_figure
    demo_figures.save_figure = nav_figures.save_figure = keep
    d = tmp_path_factory.mktemp("figures")
    try:
        assert main(["demo", "--duration", "60", "-q", "-o", str(d / "d")]) == 0
        assert main(["nav", "track", str(d / "d" / "measurements.csv"), "--imu", str(d / "d" / "imu.csv"),
                     "--beacon", "45,-25", "--start", "0,0", "--start-speed", "1", "--truth",
                     str(d / "d" / "truth.csv"), "-o", str(d / "track.csv")]) == 0
        assert main(["nav", "simulate", "--tcom", "3", "6", "--runs", "4", "-q", "-o", str(d / "sim")]) == 0
    finally:
        demo_figures.save_figure, nav_figures.save_figure = originals
    for fig in kept.values():
        fig.canvas.draw()
    return kept


@pytest.mark.parametrize("name", FIGURES)
def test_no_curve_hides_under_another(demo_figures_drawn, name):
    """The emulated tracks (dotted, same colour) were drawn on the decoded ones and could not be seen."""
    fig = demo_figures_drawn[name]
    for ax in fig.axes:
        assert hidden_lines(ax) == [], (name, ax.get_title())


@pytest.mark.parametrize("name", FIGURES)
def test_legends_are_outside_the_data(demo_figures_drawn, name):
    fig = demo_figures_drawn[name]
    assert any(ax.get_legend() for ax in fig.axes)
    for ax in fig.axes:
        assert not legend_overlaps_axes(ax), (name, ax.get_title())


def test_the_hidden_line_check_sees_a_hidden_line():
    """The check itself: a dotted copy drawn over a solid line of its colour is hidden; a wider band is not."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    t = np.linspace(0, 10, 200)
    ax.plot(t, np.sin(t), color="C0", label="solid")
    ax.plot(t, np.sin(t), color="C0", ls=":", label="dotted copy")
    ax.plot(t, np.cos(t), color="C1", lw=5, alpha=0.3, label="band")
    ax.plot(t, np.cos(t), color="C1", lw=1, label="line over the band")
    fig.canvas.draw()
    assert hidden_lines(ax) == [("solid", "dotted copy")]
    plt.close(fig)
