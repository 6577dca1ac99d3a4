"""Figures. matplotlib is imported only when a plot is made."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .config import FrameConfig
from .errors import SeamodemError

__all__ = ["plot_recording", "plot_recording_blocks", "envelope", "save_figure", "pyplot", "legend_outside"]


def pyplot():
    """matplotlib's ``pyplot``, imported on first use after ``matplotlib.use("Agg", force=False)``.

    Every figure of the package is drawn through it, so that importing a module
    that can plot does not import matplotlib.

    Returns
    -------
    module
        ``matplotlib.pyplot``.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def legend_outside(ax, **kwargs) -> None:
    """The axes' legend to the right of them, off the data (``kwargs`` go to ``ax.legend``, e.g. ``fontsize``)."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, **kwargs)


def save_figure(fig, path: str | Path, *, dpi: int = 100) -> None:
    """Write ``fig`` as a PNG at ``path`` and release it (every figure the package draws ends here).

    The PNG is written to a temporary file beside ``path`` and renamed over it
    (:func:`seamodem.io.files.atomic_outputs`): a failed or interrupted plot leaves
    no partial image, and ``path`` need not end in ``.png``. The figure is closed
    whether or not the write succeeds.
    """
    from .io.files import atomic_outputs

    try:
        with atomic_outputs(path) as (tmp,):
            fig.savefig(tmp, dpi=dpi, format="png")
    finally:
        pyplot().close(fig)


def envelope(x: np.ndarray, n_bins: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Min and max of ``x`` over ``n_bins`` equal bins: (bin start index, min, max)."""
    n_bins = max(1, min(n_bins, x.size))
    edges = np.linspace(0, x.size, n_bins + 1).astype(np.int64)
    starts = edges[:-1]
    return starts, np.minimum.reduceat(x, starts), np.maximum.reduceat(x, starts)


def plot_recording(
    x: np.ndarray,
    fs: float,
    path: str | Path,
    *,
    config: FrameConfig | None = None,
    title: str = "",
    start_s: float = 0.0,
    duration_s: float = 2.0,
) -> None:
    """Save a three-panel PNG: PSD (Welch, whole signal), waveform envelope, spectrogram window.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,)
        Real samples.
    fs : float
        Sample rate [Hz].
    path : str or Path
        PNG to write.
    config : FrameConfig, optional
        Marks the data band and the tone on the PSD.
    start_s, duration_s : float
        Spectrogram window [s].

    See Also
    --------
    plot_recording_blocks : the same from a stream of blocks, in bounded memory.
    """
    if not 0 <= start_s < x.size / fs:
        raise SeamodemError(f"start: must be in [0, {x.size / fs:g}) s, got {start_s!r}")
    if duration_s <= 0:
        raise SeamodemError(f"duration: must be > 0 s, got {duration_s!r}")
    plot_recording_blocks([x], fs, path, n_samples=x.size, window_s=(start_s, start_s + duration_s), config=config,
                          title=title)


#: Welch segment of the PSD panel [samples] (half-overlapping Hann segments)
PSD_NPERSEG = 8192
#: Spectrogram segment [samples], and the most time columns it draws (a long window is hopped, not stored whole)
SPECTROGRAM_NPERSEG, SPECTROGRAM_COLUMNS = 1024, 2000
#: Bins of the waveform envelope
ENVELOPE_BINS = 4000


class _Segments:
    """Cut a stream of blocks into segments of ``nperseg`` samples every ``hop``, from sample ``first`` on.

    ``feed`` returns the full segments the new samples complete, shape (k, nperseg),
    as a view of at most one block plus one segment: memory stays bounded.
    """

    def __init__(self, nperseg: int, hop: int, first: int = 0, stop: int | None = None):
        self.nperseg, self.hop, self.next, self.stop = nperseg, hop, first, stop
        self.buf, self.buf_start = np.empty(0), first

    def feed(self, block: np.ndarray, pos: int) -> np.ndarray:
        lo = max(self.next, pos)
        hi = pos + block.size if self.stop is None else min(pos + block.size, self.stop)
        if hi > lo:
            self.buf = np.concatenate([self.buf, block[lo - pos : hi - pos]]) if self.buf.size else block[lo - pos : hi - pos]
        k = 0 if self.buf.size < self.nperseg else 1 + (self.buf.size - self.nperseg) // self.hop
        if k == 0:
            return np.empty((0, self.nperseg))
        from numpy.lib.stride_tricks import sliding_window_view

        segments = sliding_window_view(self.buf, self.nperseg)[:: self.hop][:k]
        keep = k * self.hop
        tail = self.buf[keep:].copy() if keep < self.buf.size else np.empty(0)
        self.next += keep
        self.buf = tail
        return segments


def _power_spectra(segments: np.ndarray, window: np.ndarray) -> np.ndarray:
    """|FFT|² of each mean-removed, windowed segment (one-sided), shape (k, nperseg // 2 + 1)."""
    return np.abs(np.fft.rfft((segments - segments.mean(axis=1, keepdims=True)) * window, axis=1)) ** 2


def plot_recording_blocks(
    blocks,
    fs: float,
    path: str | Path,
    *,
    n_samples: int,
    t0_s: float = 0.0,
    window_s: tuple[float, float] | None = None,
    config: FrameConfig | None = None,
    title: str = "",
    span: str = "whole file",
) -> None:
    """Save the three-panel PNG of :func:`plot_recording` from a stream of sample blocks, in bounded memory.

    Parameters
    ----------
    blocks : iterable of numpy.ndarray
        Consecutive real samples, ``n_samples`` in all, the first at ``t0_s``.
    fs : float
        Sample rate [Hz].
    path : str or Path
        PNG to write.
    n_samples : int
        Samples the blocks hold (fixes the envelope's bins before reading).
    t0_s : float
        Time of the first sample [s].
    window_s : (float, float), optional
        Spectrogram window [s] (default: all the samples).
    config : FrameConfig, optional
        Marks the data band and the tone on the PSD and the spectrogram.
    title : str
    span : str
        What the PSD and the envelope cover, for the titles ("whole file", "10.0–12.0 s").

    Notes
    -----
    The PSD is Welch's (Hann segments of :data:`PSD_NPERSEG`, half overlap, mean
    of the periodograms), the segments the same as over the whole array. The
    spectrogram hops by max(256, window / :data:`SPECTROGRAM_COLUMNS`) samples,
    so a long window costs no more memory than a short one. Memory: one block
    plus a few segments, whatever ``n_samples``.
    """
    from scipy.signal import get_window

    if n_samples < 1:
        raise SeamodemError("plot: no samples to plot")
    nperseg = min(PSD_NPERSEG, n_samples)
    psd_cut = _Segments(nperseg, nperseg - nperseg // 2)
    psd_window = get_window("hann", nperseg)
    psd_sum, psd_count = np.zeros(nperseg // 2 + 1), 0
    w0, w1 = (0, n_samples) if window_s is None else (
        max(int(round((window_s[0] - t0_s) * fs)), 0), min(int(round((window_s[1] - t0_s) * fs)), n_samples))
    w1 = max(w1, min(w0 + SPECTROGRAM_NPERSEG, n_samples))
    w0 = min(w0, max(w1 - SPECTROGRAM_NPERSEG, 0))
    spec_n = min(SPECTROGRAM_NPERSEG, w1 - w0)
    spec_hop = max(spec_n // 4, -(-(w1 - w0) // SPECTROGRAM_COLUMNS))
    spec_cut = _Segments(spec_n, spec_hop, first=w0, stop=w1)
    spec_window = get_window("hann", spec_n)
    columns = []
    edges = np.linspace(0, n_samples, min(ENVELOPE_BINS, n_samples) + 1).astype(np.int64)
    env_lo, env_hi = np.full(edges.size - 1, np.inf), np.full(edges.size - 1, -np.inf)
    pos = 0
    for block in blocks:
        block = np.asarray(block, dtype=np.float64)
        if block.size == 0:
            continue
        # envelope: min/max of each bin's part in this block (a bin may span several blocks)
        first = int(np.searchsorted(edges, pos, side="right")) - 1
        last = int(np.searchsorted(edges, pos + block.size, side="left"))
        cuts = np.clip(edges[first:last], pos, pos + block.size) - pos
        cuts[0] = 0
        idx = np.arange(first, first + cuts.size)
        np.minimum.at(env_lo, idx, np.minimum.reduceat(block, cuts))
        np.maximum.at(env_hi, idx, np.maximum.reduceat(block, cuts))
        segments = psd_cut.feed(block, pos)
        if len(segments):
            psd_sum += _power_spectra(segments, psd_window).sum(axis=0)
            psd_count += len(segments)
        segments = spec_cut.feed(block, pos)
        if len(segments):
            columns.append(_power_spectra(segments, spec_window))
        pos += block.size
    if pos != n_samples:
        raise SeamodemError(f"plot: the blocks held {pos} samples, not the {n_samples} announced")

    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), constrained_layout=True)
    f_khz = np.fft.rfftfreq(nperseg, 1.0 / fs) / 1e3
    pxx = psd_sum / max(psd_count, 1)
    ref = np.max(pxx) if np.max(pxx) > 0 else 1.0
    ax = axes[0]
    ax.plot(f_khz, 10 * np.log10(np.maximum(pxx / ref, 1e-20)), lw=0.8)
    ax.set(xlabel="frequency [kHz]", ylabel="PSD [dB rel. max]", ylim=(-120, 5),
           title=f"{title}  power spectral density ({span})")
    if config is not None:
        lo, hi = config.data_band_hz
        ax.axvspan(lo / 1e3, hi / 1e3, color="C1", alpha=0.15, label=f"data band {lo / 1e3:g}–{hi / 1e3:g} kHz")
        ax.axvline(config.tone_hz / 1e3, color="C3", ls="--", lw=0.8, label=f"tone {config.tone_hz / 1e3:g} kHz")
        ax.legend(loc="upper right")
    ax.grid(alpha=0.3)

    t_env = t0_s + edges[:-1] / fs
    axes[1].fill_between(t_env, env_lo, env_hi, lw=0, color="C0")
    axes[1].set(xlabel="time [s]", ylabel="amplitude [full scale]", title=f"waveform (min/max envelope, {span})")
    axes[1].grid(alpha=0.3)

    sxx = np.concatenate(columns).T if columns else np.zeros((spec_n // 2 + 1, 1))
    level = 10 * np.log10(np.maximum(sxx / max(np.max(sxx), 1e-300), 1e-12))  # silent guards drawn at -120 dB
    t_spec = t0_s + (w0 + spec_n / 2 + spec_hop * np.arange(sxx.shape[1])) / fs
    mesh = axes[2].pcolormesh(t_spec, np.fft.rfftfreq(spec_n, 1.0 / fs) / 1e3, level, shading="auto",
                              cmap="viridis", vmin=-120, vmax=0)
    fig.colorbar(mesh, ax=axes[2], label="power [dB rel. max]")
    axes[2].set(xlabel="time [s]", ylabel="frequency [kHz]",
                title=f"spectrogram {t0_s + w0 / fs:.3g}–{t0_s + w1 / fs:.3g} s")
    save_figure(fig, path)
