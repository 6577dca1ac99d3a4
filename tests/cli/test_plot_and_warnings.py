"""``seamodem plot`` streams its file; one warning helper for every command (issue 14 items 3 and 5)."""

import warnings

import numpy as np
import pytest
import soundfile
from scipy.signal import welch

from seamodem.cli import main
from seamodem.cli._common import reported_warnings


def test_streamed_psd_is_welchs_and_the_span_alone_is_read(tmp_path, monkeypatch):
    """The PSD from blocks equals scipy's Welch over the whole array; --start/--duration read only that span."""
    import seamodem.plots as plots

    fs, rng = 96000, np.random.default_rng(3)
    t = np.arange(5 * fs) / fs
    x = 0.2 * np.sin(2 * np.pi * 20e3 * t) + 0.01 * rng.standard_normal(t.size)
    wav = tmp_path / "x.wav"
    soundfile.write(wav, x, fs, subtype="FLOAT")
    seen = {}

    def spy(blocks, fs_, path, *, n_samples, t0_s=0.0, **kw):
        blocks = [np.array(b) for b in blocks]
        seen.update(n=sum(b.size for b in blocks), t0=t0_s, x=np.concatenate(blocks), blocks=len(blocks))
        return real(iter(blocks), fs_, path, n_samples=n_samples, t0_s=t0_s, **kw)

    real = plots.plot_recording_blocks
    monkeypatch.setattr(plots, "plot_recording_blocks", spy)
    monkeypatch.setattr("seamodem.io.blocks.BLOCK", 1 << 16)
    assert main(["plot", str(wav), "--start", "2", "--duration", "1", "-o", str(tmp_path / "a.png")]) == 0
    assert seen["n"] == fs and seen["t0"] == 2.0  # one second read, from 2 s
    np.testing.assert_array_equal(seen["x"], soundfile.read(wav)[0][2 * fs : 3 * fs])

    # Welch from blocks = Welch over the whole array (same segments), up to scipy's density scale
    cut = plots._Segments(plots.PSD_NPERSEG, plots.PSD_NPERSEG // 2)
    acc, k, pos = np.zeros(plots.PSD_NPERSEG // 2 + 1), 0, 0
    from scipy.signal import get_window

    for block in np.array_split(x, 7):
        seg = cut.feed(block, pos)
        pos += block.size
        if len(seg):
            acc += plots._power_spectra(seg, get_window("hann", plots.PSD_NPERSEG)).sum(axis=0)
            k += len(seg)
    _, pxx = welch(x, fs=fs, nperseg=plots.PSD_NPERSEG)
    ratio = (acc / k)[1:-1] / pxx[1:-1]  # DC and Nyquist: not doubled by the one-sided density
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)


def test_plot_has_a_colour_bar_and_khz_axes(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import seamodem.plots as plots

    saved = {}
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: saved.update(fig=fig))
    fs = 48000
    plots.plot_recording(np.random.default_rng(0).standard_normal(3 * fs), fs, tmp_path / "p.png")
    fig = saved["fig"]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels[0] == "PSD [dB rel. max]" and labels[2] == "frequency [kHz]"
    assert fig.axes[0].get_xlabel() == "frequency [kHz]"
    assert len(fig.axes) == 4 and "dB" in fig.axes[3].get_ylabel()  # the spectrogram's colour bar
    assert fig.axes[2].get_ylim()[1] == pytest.approx(fs / 2e3, rel=0.01)  # kHz, not Hz


def test_plot_bad_span_is_one_line(tmp_path, capsys):
    wav = tmp_path / "x.wav"
    soundfile.write(wav, np.zeros(9600), 96000)
    assert main(["plot", str(wav), "--start", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "start: must be in [0, 0.1) s" in err
    assert not (tmp_path / "x.png").exists()


def test_reported_warnings_prints_each_once_in_one_line_also_on_error(capsys):
    class Odd(UserWarning):
        pass

    with pytest.raises(ValueError), reported_warnings("demo"):
        warnings.warn("first line\nsecond line", Odd)
        warnings.warn("first line\nsecond line", Odd)
        warnings.warn("numpy said so", RuntimeWarning)
        raise ValueError("then it failed")
    err = capsys.readouterr().err.splitlines()
    assert err == ["seamodem demo: warning: first line", "seamodem demo: warning: numpy said so"]


def test_rx_and_nav_share_the_helper():
    import inspect

    from seamodem.cli import nav, rx

    for module in (nav, rx):
        source = inspect.getsource(module)
        assert "reported_warnings(" in source and "catch_warnings" not in source, module.__name__
