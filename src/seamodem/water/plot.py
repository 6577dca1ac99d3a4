"""Figure of a sound-speed profile (matplotlib imported only when drawing)."""

from __future__ import annotations

from pathlib import Path

from ..plots import pyplot, save_figure
from .profile import SoundSpeedProfile

__all__ = ["plot_profile"]


def plot_profile(profile: SoundSpeedProfile, path: str | Path, *, depths_m: dict[str, float] | None = None,
                 water_depth_m: float | None = None) -> None:
    """Draw c(z), depth down, and save it as a PNG.

    Parameters
    ----------
    profile : SoundSpeedProfile
        The profile; its nodes are marked.
    path : str or Path
        The PNG to write.
    depths_m : dict of str to float, optional
        Named depths to mark [m] (e.g. ``{"beacon": 25, "vehicle": 5}``).
    water_depth_m : float, optional
        The bottom [m], drawn when given.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.5, 6.0))
    bottom = max(profile.depth_m[-1], water_depth_m or 0.0, *(depths_m or {}).values())
    z = sorted({0.0, *profile.depth_m.tolist(), bottom})
    ax.plot(profile.c(z), z, "-", color="C0", label="c(z), held beyond the nodes")
    ax.plot(profile.c_mps, profile.depth_m, "o", color="C0", ms=3, label="cast")
    for i, (name, d) in enumerate((depths_m or {}).items()):
        ax.axhline(d, color=f"C{i + 1}", ls="--", lw=1, label=f"{name} {d:g} m")
    if water_depth_m is not None:
        ax.axhline(water_depth_m, color="k", lw=2, label="bottom")
    ax.invert_yaxis()
    ax.set_xlabel("sound speed [m/s]")
    ax.set_ylabel("depth [m]")
    ax.set_title(Path(profile.source).name or "sound-speed profile", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    save_figure(fig, path)
