"""Figures. matplotlib is imported only when a plot is made."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .config import FrameConfig
from .errors import SeamodemError

__all__ = ["plot_recording", "envelope", "save_figure"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


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
        _pyplot().close(fig)


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
    """Save a three-panel PNG: PSD (Welch, whole file), waveform envelope, spectrogram window.

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
    """
    from scipy.signal import welch

    if not 0 <= start_s < x.size / fs:
        raise SeamodemError(f"start: must be in [0, {x.size / fs:g}) s, got {start_s!r}")
    if duration_s <= 0:
        raise SeamodemError(f"duration: must be > 0 s, got {duration_s!r}")
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), constrained_layout=True)
    f, pxx = welch(x, fs=fs, nperseg=min(8192, x.size))
    ref = np.max(pxx) if np.max(pxx) > 0 else 1.0
    ax = axes[0]
    ax.plot(f / 1e3, 10 * np.log10(np.maximum(pxx / ref, 1e-20)), lw=0.8)
    ax.set(xlabel="frequency [kHz]", ylabel="PSD [dB rel. max]", title=f"{title}  power spectral density", ylim=(-120, 5))
    if config is not None:
        lo, hi = config.data_band_hz
        ax.axvspan(lo / 1e3, hi / 1e3, color="C1", alpha=0.15, label=f"data band {lo / 1e3:g}–{hi / 1e3:g} kHz")
        ax.axvline(config.tone_hz / 1e3, color="C3", ls="--", lw=0.8, label=f"tone {config.tone_hz / 1e3:g} kHz")
        ax.legend(loc="upper right")
    ax.grid(alpha=0.3)

    starts, lo_env, hi_env = envelope(x, 4000)
    t = starts / fs
    axes[1].fill_between(t, lo_env, hi_env, lw=0, color="C0")
    axes[1].set(xlabel="time [s]", ylabel="amplitude [full scale]", title="waveform (min/max envelope)")
    axes[1].grid(alpha=0.3)

    i0 = int(start_s * fs)
    seg = x[i0 : i0 + max(int(duration_s * fs), 256)]
    from scipy.signal import spectrogram

    fs_, ts_, sxx = spectrogram(seg, fs=fs, nperseg=min(1024, seg.size), noverlap=min(768, seg.size - 1))
    level = 10 * np.log10(np.maximum(sxx / max(np.max(sxx), 1e-300), 1e-12))  # silent guards drawn at -120 dB
    axes[2].pcolormesh(start_s + ts_, fs_, level, shading="auto", cmap="viridis", vmin=-120, vmax=0)
    axes[2].set(xlabel="time [s]", ylabel="frequency [Hz]", title="spectrogram")
    save_figure(fig, path)
