"""Per-frame receiver figures: correlation peak, tone Doppler track, constellations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..config import FrameConfig
from ..plots import pyplot, save_figure
from .compensate import compensate_frame
from .doppler import pilot_correlation
from .measure import FrameMeasurement

__all__ = ["plot_frame"]


def plot_frame(
    path: str | Path,
    m: FrameMeasurement,
    bb: np.ndarray,
    *,
    fs: float,
    t0_s: float,
    config: FrameConfig,
    pilot: np.ndarray,
    sound_speed_mps: float,
) -> None:
    """Save a four-panel PNG of one frame.

    Panels: the Doppler-scaled pilot correlation around the arrival (with the
    estimate marked), the eq 9 v_r track with the three mean estimates, and
    the constellation before and after eq 10–11 compensation.
    """
    plt = pyplot()
    T = config.symbol_period_s
    t_a = m.pilot.t_start_s
    offsets = np.linspace(-4 * T, 4 * T, 161)
    corr = pilot_correlation(
        bb, fs, t0_s, config=config, pilot=pilot, t_start_s=t_a + offsets, v_mps=m.pilot.v_mps,
        sound_speed_mps=sound_speed_mps,
    )
    comp = compensate_frame(
        bb, fs, t0_s, config=config, pilot=pilot, t_start_s=t_a, sound_speed_mps=sound_speed_mps,
        v_mps=m.v_tone_ml_mps,
    )
    fig, ax = plt.subplots(2, 2, figsize=(10, 8))
    ax[0, 0].plot(offsets * 1e3, corr)
    ax[0, 0].axvline(0.0, color="k", lw=0.8, ls="--")
    ax[0, 0].set(xlabel="t − t̂_arrival [ms]", ylabel="|pilot correlation|", title=f"arrival {t_a:.6f} s")
    ax[0, 1].plot(m.track_t_s - t_a, m.track_v_mps, lw=0.8, label="eq 9 track")
    for value, label, style in (
        (m.v_tone_eq9_mps, "eq 9 mean", "--"),
        (m.v_tone_ml_mps, "tone ML", "-"),
        (m.pilot.v_mps, "pilot bank", ":"),
    ):
        ax[0, 1].axhline(value, ls=style, color="k", lw=1, label=f"{label} {value:.4f}")
    ax[0, 1].set(xlabel="t − t̂_arrival [s]", ylabel="v_r [m/s] (closing > 0)", title="tone Doppler")
    ax[0, 1].legend(fontsize=8)
    for a, data, title in ((ax[1, 0], comp.raw, "before compensation"), (ax[1, 1], comp.symbols, "after eq 10–11")):
        a.plot(data.real, data.imag, ".", ms=2)
        a.set(xlabel="I", ylabel="Q", title=title, aspect="equal", xlim=(-2, 2), ylim=(-2, 2))
    fig.tight_layout()
    save_figure(fig, path)
