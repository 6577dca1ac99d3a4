"""The demo mission's summary: the figures of ``summary.json`` and the text ``seamodem demo`` prints."""

from __future__ import annotations

import math
import numpy as np

from .._version import __version__
from .config import FILTER_LABELS, FILTERS, DemoConfig, VehicleRun

__all__ = ["rms", "mission_summary", "format_summary"]


def rms(x) -> float:
    """Root mean square.

    Parameters
    ----------
    x : array_like
        Values.

    Returns
    -------
    float
        √mean(x²); NaN for no values.
    """
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x**2))) if x.size else math.nan


def mission_summary(cfg: DemoConfig, vehicle: VehicleRun, sidecar: dict, records, errs: dict, tracks: dict,
                    clock: dict, array_summary: dict | None) -> dict:
    """The figures of one demo mission, as written to ``summary.json`` (without the total wall time).

    Parameters
    ----------
    cfg : DemoConfig
        The mission's configuration.
    vehicle : VehicleRun
        The true vehicle (its track gives the distance travelled).
    sidecar : dict
        The received recording's sidecar (frames sent, their payloads).
    records : list of MeasurementRecord
        The receiver's records.
    errs : dict
        Their errors against the truth (:func:`~.mission.measurement_errors`).
    tracks : dict
        ``(source, filter)`` → track of :func:`~.mission.navigate`, source ``"waveform"`` or ``"emulated"``.
    clock : dict
        ``time.perf_counter()`` [s] at ``start``, ``channel``, ``receiver``, ``array``, ``navigation``.
    array_summary : dict or None
        :func:`~.mission.array_mission`'s summary, or None without an array.

    Returns
    -------
    dict
        Frames, measurement errors [m, m/s], positioning errors per filter [m], wall times [s].
    """
    from ..navigation.paper import eq25_text

    count = cfg.frame_count()
    sigma_r, sigma_v = rms(errs["range_error_m"]), rms(errs["v_r_error_mps"])
    janus = cfg.waveform == "janus"  # a JANUS packet's 8 bytes stand for a frame's payload
    payloads = {f["index"] if janus else f["frame_index"]: f["packet_hex" if janus else "payload_hex"]
                for f in sidecar["frames"]}
    decoded = [r for r in records if r.crc_ok is not None]
    crc_ok = [r for r in decoded if r.crc_ok]
    correct = [r for r in crc_ok if (r.packet_hex if janus else r.payload_hex) == payloads.get(r.frame_index)]
    mission_end = cfg.mission_s()
    summary = {
        "created_by": f"seamodem {__version__}",
        "waveform": "JANUS base packets, parameter set 1" if janus else f"{cfg.preset} frames",
        "mission_s": mission_end,
        "distance_m": float(np.sum(np.hypot(*np.diff(vehicle.xy_m[vehicle.t_s <= mission_end], axis=0).T))),
        "frames_emitted": count,
        "frames_detected": len(records),
        "frames_decoded": len(decoded),
        "crc_ok": len(crc_ok),
        "payloads_correct": len(correct),
        "true_snr_db_range": [float(np.min(errs["true_snr_db"])), float(np.max(errs["true_snr_db"]))] if records else None,
        "range_rmse_m": sigma_r,
        "range_bias_m": float(np.mean(errs["range_error_m"])) if records else math.nan,
        "v_r_rmse_mps": sigma_v,
        "v_r_bias_mps": float(np.mean(errs["v_r_error_mps"])) if records else math.nan,
        "range_crlb_median_m": float(np.median([r.sigma_range_m for r in records])) if records else math.nan,
        "v_r_crlb_median_mps": float(np.median([r.sigma_v_r_mps for r in records])) if records else math.nan,
        "positioning": {
            source: {
                f: {"mean_error_m": float(np.mean(tracks[(source, f)]["error_m"])),
                    "rms_error_m": rms(tracks[(source, f)]["error_m"]),
                    "final_error_m": float(tracks[(source, f)]["error_m"][-1])}
                for f in FILTERS
            }
            for source in ("waveform", "emulated")
        },
        "emulated_noise": {"sigma_range_m": sigma_r, "sigma_v_r_mps": sigma_v,
                           "definition": "RMS of the receiver's errors against the channel truth, this run"},
        "filter": {"inertial": "inertial filter (navigation.inertial), R from each record's sigma with the "
                               "nav track floors; batch: its batch smoother",
                   "proposed": f"paper 000 6-state EKF, {eq25_text()}",
                   "start": "the true position and speed"},
        "wall_time_s": {
            "vehicle_beacon_channel": clock["channel"] - clock["start"],
            "receiver_decoder": clock["receiver"] - clock["channel"],
            "navigation": clock["navigation"] - clock["array"],
        },
    }
    if array_summary is not None:
        summary["array"] = array_summary
        summary["wall_time_s"]["array"] = clock["array"] - clock["receiver"]
    return summary


def format_summary(summary: dict) -> str:
    """The demo's printed summary.

    Parameters
    ----------
    summary : dict
        :func:`mission_summary` with the total wall time.

    Returns
    -------
    str
        Lines of text.
    """
    s = summary
    pos = s["positioning"]
    janus = s.get("waveform", "").startswith("JANUS")
    lines = [
        f"mission: {s['mission_s']:.0f} s, {s['distance_m']:.0f} m travelled, a frame every T_com",
        *([f"waveform: {s['waveform']} (a frame below is a packet, its payload the packet's 8 bytes)"] if janus else []),
        f"frames: {s['frames_emitted']} emitted, {s['frames_detected']} detected, {s['frames_decoded']} decoded, "
        f"{s['crc_ok']} pass the CRC, {s['payloads_correct']} payloads equal to those sent",
    ]
    if s["true_snr_db_range"]:
        lines.append(f"in-band SNR per frame (truth): {s['true_snr_db_range'][0]:.1f} to {s['true_snr_db_range'][1]:.1f} dB")
    lines += [
        f"range vs truth: RMSE {100 * s['range_rmse_m']:.2f} cm (bias {100 * s['range_bias_m']:+.2f} cm; "
        f"median σ {100 * s['range_crlb_median_m']:.2f} cm)",
        f"v_r vs truth:   RMSE {100 * s['v_r_rmse_mps']:.2f} cm/s (bias {100 * s['v_r_bias_mps']:+.2f} cm/s; "
        f"median σ {100 * s['v_r_crlb_median_mps']:.3f} cm/s)",
        "positioning error (mean / RMS / final, m):",
        f"  {'':34}" + "".join(f" {FILTER_LABELS[f]:>20}" for f in FILTERS),
    ]
    labels = {"waveform": "from the decoded frames", "emulated": "emulated (geometry + same noise)"}
    for source in ("waveform", "emulated"):
        cells = [pos[source][f] for f in FILTERS]
        lines.append(f"  {labels[source]:34}" + "".join(
            f" {c['mean_error_m']:>8.2f} / {c['rms_error_m']:.2f} / {c['final_error_m']:.2f}" for c in cells))
    if "array" in s:
        a = s["array"]
        lines += [
            f"hydrophone array {a['spec']} ({a['n_elements']} elements, {100 * a['aperture_m']:.0f} cm), same SNR per "
            "element, beside one of its hydrophones:",
            f"  frames detected {a['one_hydrophone']['frames_detected']} -> {a['array']['frames_detected']}, payloads "
            f"correct {a['one_hydrophone']['payloads_correct']} -> {a['array']['payloads_correct']} (FER "
            f"{a['one_hydrophone']['fer']:.2f} -> {a['array']['fer']:.2f}), range RMSE "
            f"{100 * a['one_hydrophone']['range_rmse_m']:.2f} -> {100 * a['array']['range_rmse_m']:.2f} cm",
            f"  beacon body azimuth vs truth: RMSE {a['azimuth_rmse_deg']:.2f} deg (median sigma "
            f"{a['azimuth_sigma_median_deg']:.2f} deg, {100 * a['azimuth_within_3_sigma']:.0f} % within 3 sigma)",
            f"  one-frame fix (range + azimuth + AHRS heading + depth, no filter): median error "
            f"{a['one_frame_fix_median_error_m']:.2f} m, RMS {a['one_frame_fix_rms_error_m']:.2f} m",
        ]
    w = s["wall_time_s"]
    lines.append(f"wall time: {w.get('total', math.nan):.1f} s (beacon + channel {w['vehicle_beacon_channel']:.1f} s, "
                 f"receiver + decoder {w['receiver_decoder']:.1f} s, "
                 + (f"array {w['array']:.1f} s, " if "array" in w else "")
                 + f"filters {w['navigation']:.1f} s)")
    return "\n".join(lines)
