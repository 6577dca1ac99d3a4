"""plots.save_figure: the one place every figure of the package is written (atomic, always closed)."""

import pytest

from seamodem.plots import pyplot, save_figure


def test_save_figure_writes_a_png_and_closes_the_figure(tmp_path):
    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    path = tmp_path / "plot_without_suffix"
    save_figure(fig, path, dpi=50)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # PNG whatever the name
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary left beside it
    assert not plt.fignum_exists(fig.number)


def test_failed_save_leaves_no_file_and_the_old_one_intact(tmp_path):
    plt = pyplot()
    path = tmp_path / "fig.png"
    path.write_bytes(b"previous figure")
    fig, _ = plt.subplots()

    def broken_savefig(target, **kwargs):
        with open(target, "wb") as f:
            f.write(b"\x89PNG half")  # a partial image, then the failure
        raise OSError("disk full")

    fig.savefig = broken_savefig
    with pytest.raises(OSError, match="disk full"):
        save_figure(fig, path)
    assert path.read_bytes() == b"previous figure"
    assert [p.name for p in tmp_path.iterdir()] == ["fig.png"]
    assert not plt.fignum_exists(fig.number)
