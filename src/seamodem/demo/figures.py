"""The demo mission's figures: map, errors, PSD of a received frame, constellation (matplotlib imported lazily)."""

from __future__ import annotations

import numpy as np

from ..config import FrameConfig
from ..plots import legend_outside, pyplot, save_figure
from .config import FILTER_COLOURS, FILTER_LABELS, FILTERS, DemoConfig, VehicleRun, receiver_settings

__all__ = ["plot_map", "plot_errors", "plot_psd", "plot_constellation"]


#: the map's line per filter: widths decrease in drawing order and the later ones are dashed, so a track
#: a few centimetres from another is seen beside it, not under it
MAP_STYLES = {"inertial": {"lw": 2.2, "ls": "-"}, "batch": {"lw": 1.2, "ls": (0, (4, 2))},
              "proposed": {"lw": 1.2, "ls": "--"}, "rosb": {"lw": 1.2, "ls": "-."}}


def _figure(*args, **kwargs):
    return pyplot().subplots(*args, **kwargs)



def plot_map(path, cfg: DemoConfig, vehicle: VehicleRun, tracks: dict, summary: dict) -> None:
    """Top view: the desired survey, the true track, both filters' estimates from the decoded frames, the beacon.

    Parameters
    ----------
    path : str or Path
        PNG written.
    cfg : DemoConfig
        The mission (survey, beacon).
    vehicle : VehicleRun
        The true vehicle.
    tracks : dict
        ``(source, filter)`` → track (:func:`~.mission.navigate`).
    summary : dict
        The mission's summary (mission length [s], frames, mean errors [m]).

    Returns
    -------
    None
    """
    fig, ax = _figure(figsize=(9.5, 6), constrained_layout=True)
    end = vehicle.t_s <= summary["mission_s"]
    plan = cfg.path().sample(np.linspace(0, cfg.path().duration_s, 600)).position
    ax.plot(plan[:, 0], plan[:, 1], color="0.75", lw=6, label="survey plan")
    # widest first, so each track stays visible around the narrower ones drawn over it (they differ by cm)
    ax.plot(*vehicle.xy_m[end].T, color="k", lw=3.5, label="true track")
    pos = summary["positioning"]["waveform"]
    for f in FILTERS:
        tr = tracks[("waveform", f)]
        keep = tr["t_s"] <= summary["mission_s"]
        ax.plot(*tr["xy_m"][keep].T, color=FILTER_COLOURS[f], **MAP_STYLES[f],
                label=f"{FILTER_LABELS[f]}: mean error {pos[f]['mean_error_m']:.2f} m")
    ax.plot(*cfg.beacon_xy_m, marker="^", color="C2", ms=12, ls="none", label="beacon")
    ax.plot(*vehicle.xy_m[0], marker="o", color="k", ms=6, ls="none", label="start (GNSS fix)")
    ax.set(xlabel="east [m]", ylabel="north [m]", aspect="equal",
           title=f"seamodem demo: positioned from {summary['frames_detected']} received frames "
                 f"({summary['payloads_correct']} payloads decoded)")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    save_figure(fig, path, dpi=110)


def plot_errors(path, tracks: dict, errs: dict) -> None:
    """Position error over time (both filters, decoded and emulated measurements); range and v_r errors per frame.

    Parameters
    ----------
    path : str or Path
        PNG written.
    tracks : dict
        ``(source, filter)`` → track (:func:`~.mission.navigate`).
    errs : dict
        The receiver's errors (:func:`~.mission.measurement_errors`).

    Returns
    -------
    None
    """
    fig, axes = _figure(3, 1, figsize=(11, 9), constrained_layout=True)
    ax = axes[0]
    for f in FILTERS:
        # the two sources give nearly the same curve: the emulated one as a wide pale band under the decoded one
        for source, style in (("emulated", {"lw": 5.0, "alpha": 0.3}), ("waveform", {"lw": 1.0})):
            tr = tracks[(source, f)]
            ax.plot(tr["t_s"], tr["error_m"], color=FILTER_COLOURS[f], solid_capstyle="butt", **style,
                    label=f"{FILTER_LABELS[f]}, {'decoded frames' if source == 'waveform' else 'emulated measurements'}")
    ax.set(xlabel="time [s]", ylabel="position error [m]", title="positioning error")
    legend_outside(ax, fontsize=8)
    axes[1].plot(errs["t_arrival_s"], 100 * errs["range_error_m"], "o", ms=3)
    axes[1].set(xlabel="arrival time [s]", ylabel="range error [cm]", title="receiver range − truth (direct path)")
    axes[2].plot(errs["t_arrival_s"], 100 * errs["v_r_error_mps"], "o", ms=3, color="C1")
    axes[2].set(xlabel="arrival time [s]", ylabel="v_r error [cm/s]", title="receiver v_r − truth (direct path)")
    for ax in axes:
        ax.grid(alpha=0.3)
    save_figure(fig, path, dpi=110)


def plot_psd(path, psd, config: FrameConfig) -> None:
    """PSD of the received recording over one frame, with the data band and the tone marked.

    Parameters
    ----------
    path : str or Path
        PNG written.
    psd : tuple of ndarray
        Frequencies [Hz] and power spectral density.
    config : FrameConfig
        The frame (data band, tone [Hz]).

    Returns
    -------
    None
    """
    f, pxx = psd
    fig, ax = _figure(figsize=(10, 4), constrained_layout=True)
    ax.plot(f / 1e3, 10 * np.log10(np.maximum(pxx / np.max(pxx), 1e-20)), lw=0.8)
    lo, hi = config.data_band_hz
    ax.axvspan(lo / 1e3, hi / 1e3, color="C1", alpha=0.15, label=f"data band {lo / 1e3:g}–{hi / 1e3:g} kHz")
    ax.axvline(config.tone_hz / 1e3, color="C3", ls="--", lw=0.8, label=f"tone {config.tone_hz / 1e3:g} kHz")
    ax.set(xlabel="frequency [kHz]", ylabel="PSD [dB rel. max]", ylim=(-80, 5),
           title="received: the first frame (direct, surface and bottom paths, noise)")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    save_figure(fig, path, dpi=110)


def plot_constellation(path, grabbed, config: FrameConfig, sidecar: dict) -> None:
    """One frame's data symbols: after Doppler compensation (eq 10–11) and after the DFE.

    The frame goes once more through the receiver's own decoding step
    (:func:`seamodem.receive.demodulate.demodulate`, same settings but the
    DFE alone), so the picture is what the receiver decoded.

    Parameters
    ----------
    path : str or Path
        PNG written.
    grabbed : tuple
        (measurement, baseband, t0 [s], fs [Hz]) of the frame (:func:`~.mission.receive`).
    config : FrameConfig
        The frame.
    sidecar : dict
        The recording's sidecar (pilot bits, sound speed).

    Returns
    -------
    None
    """
    import dataclasses

    from ..io.sidecar import sidecar_pilot_bits
    from ..receive.demodulate import demodulate

    m, bb, t0_s, fs = grabbed
    pilot = (1.0 - 2.0 * sidecar_pilot_bits(sidecar)).astype(complex)
    settings = dataclasses.replace(receiver_settings(sidecar), turbo_passes=1)
    dec = demodulate(m, bb, t0_s, fs, config=config, pilot=pilot, settings=settings)
    fig, axes = _figure(1, 2, figsize=(9, 4.5), constrained_layout=True)
    data = dec.compensated.symbols[config.n_pilot:]
    for ax, z, title in ((axes[0], data, "after Doppler compensation (eq 10–11)"),
                         (axes[1], dec.equalized, f"after the DFE (output SNR {dec.eq_snr_db:.1f} dB)")):
        ax.plot(z.real, z.imag, ".", ms=2, alpha=0.5)
        ax.set(xlabel="in-phase", ylabel="quadrature", title=title, aspect="equal", xlim=(-2, 2), ylim=(-2, 2))
        ax.grid(alpha=0.3)
    fig.suptitle(f"one received frame, data symbols (t_arrival = {m.pilot.t_start_s:.2f} s)")
    save_figure(fig, path, dpi=110)
