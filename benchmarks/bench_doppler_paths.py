"""Direct-path Doppler among echoes and clicks, and the calibration of the record's σ (issue 15).

Run: ``python benchmarks/bench_doppler_paths.py [--frames N]`` (default 100 frames per row).

Every row goes transmitter → the project's channel simulator (geometry mode:
moving receiver, surface and bottom images) → ``Receiver`` with decoding, and
is scored against the simulator's per-frame truth of the direct path
(``v_r_true_mps``, ``tof_true_s``). SNR is in-band (SPEC §1). Rows:

- deep: beacon 20 m deep, receiver 10 m deep in 35 m of water, closing at
  1.8 m/s from 260 m to 115 m: surface echo 1.2–2.3 ms and bottom echo
  2.2–4.4 ms after the direct path, their Doppler 2–9 cm/s below it;
- the same at 12 dB with impulsive noise: Gaussian mixture (p = 2e-3, i.e.
  ≈ 190 impulse samples per second, 30 dB above the floor; the nominal SNR
  lowered so that the Gaussian floor is the no-click row's) and symmetric
  α-stable (α = 1.7, dispersion of the Gaussian floor);
- AWGN, a single path (no echoes).

Per row: v_r_mps (the record's, source stated) and the tone ML, RMSE, bias and
worst frame against truth beside the median CRLB; BER; and the calibration of
``sigma_v_r_mps`` and ``sigma_range_m``: fraction of frames within 1, 2, 3 σ,
median σ over the RMS error. Results in benchmarks/results/bench_doppler_paths.txt.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from seamodem import BeaconSchedule, get_preset
from seamodem.channel.scenario import parse_scenario
from seamodem.channel.simulate import simulate
from seamodem.receive import Emissions, Receiver, ReceiverSettings
from seamodem.receive.bounds import gabor_bandwidth_hz
from seamodem.receive.wholeframe import known_signal_velocity_crlb_mps
from seamodem.transmit.beacon import render_beacon

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
PERIOD = 0.8
RESULTS = Path(__file__).resolve().parent / "results" / "bench_doppler_paths.txt"


def _scenario(snr_db: float, *, noise: dict, echoes: bool):
    gm_floor = 0.0
    if noise.get("kind") == "gaussian_mixture":
        p, ratio = noise["impulse_probability"], noise["impulse_power_ratio"]
        gm_floor = 10 * math.log10((1 - p) + p * ratio)  # impulses' share of the nominal power
    table = {
        "mode": "geometry",
        "seed": 11,
        "environment": {"sound_speed_mps": C, "water_depth_m": 35.0},
        "beacon": {"position_m": [0.0, 0.0, -20.0]},
        "vehicle": {"start_m": [-260.0, 0.0, -10.0], "velocity_mps": [1.8, 0.0, 0.0]},
        "multipath": {"max_bounces": 1 if echoes else 0, "surface_reflection": -0.9, "bottom_reflection": 0.6},
        "noise": {**noise, "snr_db": snr_db - gm_floor},
    }
    return parse_scenario(table)


def _simulate(n: int, snr_db: float, *, noise: dict, echoes: bool = True, period_s: float = PERIOD):
    """n beacon frames through the simulator: (simulation, emission times, payloads)."""
    sched = BeaconSchedule(count=n, period_s=period_s, start_s=0.0)
    beacon = render_beacon(CFG, sched)
    x = np.zeros(beacon.n_samples + int(0.6 * FS))
    for k in range(n):
        s = beacon.frame_samples(k)
        x[beacon.first_samples[k] : beacon.first_samples[k] + len(s)] += s
    t_emit = sched.start_s + period_s * np.arange(n)
    band = (CFG.carrier_hz - CFG.bandwidth_hz / 2, CFG.carrier_hz + CFG.bandwidth_hz / 2)
    sim = simulate(x, FS, _scenario(snr_db, noise=noise, echoes=echoes), t_emit_s=t_emit,
                   frame_duration_s=CFG.frame_duration_s, band_hz=band)
    return sim, t_emit, [f.payload for f in beacon.frames]


def _row(n: int, snr_db: float, *, noise: dict, echoes: bool = True, settings: ReceiverSettings | None = None):
    sim, t_emit, payloads = _simulate(n, snr_db, noise=noise, echoes=echoes)
    settings = settings or ReceiverSettings(decode=True)
    rx = Receiver(CFG, emissions=Emissions(times_s=t_emit), settings=settings, payloads=payloads)
    t0 = time.perf_counter()
    recs = [r for r in rx.run([sim.output], fs=FS) if 0 <= r.frame_index < n]
    elapsed = time.perf_counter() - t0
    truth = sim.truth
    k = np.array([r.frame_index for r in recs])
    col = {name: np.array([getattr(r, name) for r in recs], dtype=float) for name in (
        "v_r_mps", "v_r_tone_mps", "sigma_v_r_mps", "range_m", "sigma_range_m", "ber", "raw_ber", "eq_snr_db",
        "snr_db", "blanked_fraction")}
    col["v_true"] = np.array([truth[i]["v_r_true_mps"] for i in k])
    col["r_true"] = np.array([C * truth[i]["tof_true_s"] for i in k])
    col["crc"] = np.array([bool(r.crc_ok) for r in recs])
    col["source"] = [r.v_r_source for r in recs]
    # the direct path's share of the signal power (the in-band SNR counts every path as signal, SPEC §1)
    col["share"] = np.array([truth[i]["paths"][0]["amplitude"] ** 2 / sum(p["amplitude"] ** 2 for p in truth[i]["paths"])
                             for i in k])
    col["spread"] = np.array([max(p["v_r_true_mps"] for p in truth[i]["paths"]) - min(
        p["v_r_true_mps"] for p in truth[i]["paths"]) for i in k])
    col["delay"] = np.array([max(p["tof_true_s"] for p in truth[i]["paths"]) - truth[i]["tof_true_s"] for i in k])
    col["rt"] = n * PERIOD / elapsed
    col["n"] = n
    return col


def _stats(err, sigma):
    rms = float(np.sqrt(np.mean(err**2)))
    within = [float(np.mean(np.abs(err) <= m * sigma)) for m in (1, 2, 3)]
    return rms, float(np.mean(err)), float(np.max(np.abs(err))), within, float(np.median(sigma)) / max(rms, 1e-12)


def _median_z(err, sigma):
    """Median |error|/σ: 0.67 for a calibrated Gaussian σ, however σ varies between frames; a σ inflated by a
    blanket factor k gives 0.67/k. One frame cannot move it (median σ / RMS error it can)."""
    return float(np.median(np.abs(err) / sigma))


def _write_results(lines: list[str], path: Path, default_name: str | None = None) -> int:
    """Print a table and write it to ``path``; ``default_name`` replaces the main table's file name when path is it."""
    text = "\n".join(lines) + "\n"
    print(text)
    if default_name is not None and path == RESULTS:
        path = RESULTS.with_name(default_name)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--only", default=None, help="run only the rows whose name contains this text")
    ap.add_argument("--out", type=Path, default=RESULTS, help=f"results file (default {RESULTS})")
    args = ap.parse_args(argv)
    n = args.frames
    white = {"kind": "white"}
    gm = {"kind": "gaussian_mixture", "impulse_probability": 2e-3, "impulse_power_ratio": 1000.0}
    alpha = {"kind": "alpha_stable", "alpha": 1.7}
    no_blank = ReceiverSettings(decode=True, blank_impulses=False)
    specs = [
        ("deep, white, 6 dB", dict(snr_db=6.0, noise=white)),
        ("deep, white, 12 dB", dict(snr_db=12.0, noise=white)),
        ("deep, white, 20 dB", dict(snr_db=20.0, noise=white)),
        ("deep, Gaussian mixture, 6 dB", dict(snr_db=6.0, noise=gm)),
        ("deep, Gaussian mixture, 12 dB", dict(snr_db=12.0, noise=gm)),
        ("deep, alpha-stable 1.7, 6 dB", dict(snr_db=6.0, noise=alpha)),
        ("deep, alpha-stable 1.7, 12 dB", dict(snr_db=12.0, noise=alpha)),
        ("deep, Gaussian mixture, 12 dB, no blanking", dict(snr_db=12.0, noise=gm, settings=no_blank)),
        ("single path, white, 12 dB", dict(snr_db=12.0, noise=white, echoes=False)),
        ("single path, white, 12 dB, no blanking", dict(snr_db=12.0, noise=white, echoes=False, settings=no_blank)),
    ]
    if args.only == "speed":
        return _speed(args.out)
    if args.only == "false_alarms":
        return _false_alarms(args.out)
    rows = [(name, _row(n, **kw)) for name, kw in specs if args.only is None or args.only in name]
    out = [f"# bench_doppler_paths: {n} frames per row, jmse2024, T_com {PERIOD} s, in-band SNR (SPEC §1), "
           "through the project's channel simulator (geometry mode); errors against its direct-path truth\n"]
    out.append("## Direct-path v_r (record's v_r_mps) and the tone ML, against truth\n")
    out.append("| row | echoes delay / Doppler spread | v_r source | RMSE mm/s | bias mm/s | worst mm/s | "
               "bound mm/s | RMSE/bound | tone RMSE mm/s | tone worst mm/s | range RMSE mm | range bound mm | "
               "range RMSE/bound | range bias mm | CRC ok | raw BER | BER | eq SNR dB | blanked | real time |")
    out.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    calib = []
    for name, c in rows:
        ev = c["v_r_mps"] - c["v_true"]
        et = c["v_r_tone_mps"] - c["v_true"]
        er = c["range_m"] - c["r_true"]
        # the bounds: a known signal over the frame (all symbols) on the direct path alone, at its share of the
        # measured in-band SNR; velocity (Rife & Boorstyn) and delay (1/(2πβ√(2 n Es/N0)), SPEC §6)
        n_sym = CFG.n_pilot + CFG.n_data
        es_n0 = 10 ** (c["snr_db"] / 10) * (1 + CFG.rolloff) * c["share"]
        bound = float(np.median(known_signal_velocity_crlb_mps(CFG, es_n0, n_sym, sound_speed_mps=C)))
        r_bound = float(np.median(C / (2 * np.pi * gabor_bandwidth_hz(CFG.symbol_rate_hz, CFG.rolloff)
                                       * np.sqrt(2 * n_sym * es_n0))))
        r_rmse = float(np.sqrt(np.mean(er**2)))
        rms, bias, worst, _, _ = _stats(ev, c["sigma_v_r_mps"])
        sources = ", ".join(f"{s} {c['source'].count(s)}" for s in sorted(set(c["source"])))
        out.append(
            f"| {name} | {1e3 * np.median(c['delay']):.1f} ms / {1e3 * np.median(c['spread']):.0f} mm/s | {sources} | "
            f"{1e3 * rms:.2f} | {1e3 * bias:+.2f} | {1e3 * worst:.2f} | {1e3 * bound:.2f} | {rms / bound:.2f} | "
            f"{1e3 * np.sqrt(np.mean(et**2)):.1f} | {1e3 * np.max(np.abs(et)):.1f} | "
            f"{1e3 * r_rmse:.2f} | {1e3 * r_bound:.2f} | {r_rmse / r_bound:.2f} | {1e3 * np.mean(er):+.2f} | "
            f"{np.mean(c['crc']):.2f} | {np.nanmean(c['raw_ber']):.1e} | "
            f"{np.nanmean(c['ber']):.1e} | {np.nanmedian(c['eq_snr_db']):.2f} | "
            f"{np.nanmean(c['blanked_fraction']):.1e} | {c['rt']:.1f}x |"
        )
        for what, err, sig in (("v_r", ev, c["sigma_v_r_mps"]), ("range", er, c["sigma_range_m"])):
            r_rms, _, _, within, ratio = _stats(err, sig)
            calib.append(f"| {name} | {what} | {len(err)} | {within[0]:.2f} | {within[1]:.2f} | {within[2]:.2f} | "
                         f"{ratio:.2f} | {_median_z(err, sig):.2f} |")
    out.append("\nbound: median over the frames of the CRLB of a known signal of all the frame's symbols on the direct "
               "path alone, at its share of the measured in-band SNR (the in-band SNR counts the echoes as signal). "
               "range: a decoded frame's is the direct path's data-aided timing over the whole frame. "
               "real time: recording duration over the wall time of `Receiver.run` with decoding, on the shared "
               "2-core machine (see `--only speed`).")
    out.append("\n## Calibration of the record's σ (goal: ≥ 0.95 within 2σ, ≥ 0.99 within 3σ, median σ / RMS in [0.5, 2])\n")
    out.append("| row | column | frames | within 1σ | within 2σ | within 3σ | median σ / RMS error | median abs(error)/σ |")
    out.append("|---|---|---|---|---|---|---|---|")
    out += calib
    out.append("\nmedian σ / RMS error compares the typical σ with an RMS that one frame can dominate: where 1–6 frames of "
               "100 fail to decode and fall back to the tone or a fit on decisions (tens to 180 mm/s off, with σ to "
               "match), it is far below 0.5 while those frames are within 3σ. median abs(error)/σ is 0.67 for a "
               "calibrated Gaussian σ however σ varies between frames (a blanket factor k makes it 0.67/k).")
    return _write_results(out, args.out)


def _speed(path: Path, n: int = 30) -> int:
    """Real-time factors (recording duration / processing time), wall and CPU, after a warm-up run."""
    lines = [f"# bench_doppler_paths --only speed: {n} frames, jmse2024 at {FS:.0f} Hz, 12 dB, 65536-sample blocks, "
             "after a warm-up run (steady state); shared 2-core machine (load from other jobs: compare CPU)\n",
             "| recording | frame period s | receiver | real time (wall) | real time (CPU) | CPU ms per frame |",
             "|---|---|---|---|---|---|"]
    for echoes, label in ((False, "clean, single path"), (True, "deep, surface and bottom echoes")):
        for period in (3.0, PERIOD):
            sim, t_emit, _ = _simulate(n, 12.0, noise={"kind": "white"}, echoes=echoes, period_s=period)
            blocks = [sim.output[i : i + 65536] for i in range(0, len(sim.output), 65536)]
            for decode in (False, True):
                def run():
                    rx = Receiver(CFG, emissions=Emissions(times_s=t_emit), settings=ReceiverSettings(decode=decode))
                    w, c = time.perf_counter(), time.process_time()
                    list(rx.run(blocks, fs=FS))
                    return time.perf_counter() - w, time.process_time() - c
                run()
                wall, cpu = run()
                duration = len(sim.output) / FS
                what = "measurement and decoding" if decode else "measurement only"
                lines.append(f"| {label} | {period:g} | {what} | {duration / wall:.1f}x | {duration / cpu:.1f}x | "
                             f"{1e3 * cpu / n:.0f} |")
    return _write_results(lines, path, "bench_doppler_paths_speed.txt")


def _false_alarms(path: Path, minutes: float = 10.0) -> int:
    """Frames reported in ``minutes`` of noise alone (white; Gaussian mixture), blanking on, the default FA rate."""
    from seamodem.channel.noise import GaussianMixtureNoise, WhiteNoise

    settings = ReceiverSettings()  # blanking on, 0.01 false alarms per hour
    lines = [f"# bench_doppler_paths --only false_alarms: {minutes:g} min of noise alone at {FS:.0f} Hz, "
             f"jmse2024, blanking on, design rate {settings.false_alarms_per_hour} per hour\n",
             "| noise | minutes | frames reported | blanked fraction | real time (wall) |", "|---|---|---|---|---|"]
    sources = (("white", lambda rng: WhiteNoise(FS, rng)),
               ("Gaussian mixture (p = 2e-3, 30 dB)",
                lambda rng: GaussianMixtureNoise(FS, rng, impulse_probability=2e-3, impulse_power_ratio=1000.0)))
    for label, make in sources:
        noise = make(np.random.default_rng(2024))
        n_blocks = int(minutes * 60)
        blocks = (noise.block(int(FS)) for _ in range(n_blocks))
        rx = Receiver(CFG, emissions=Emissions(start_s=0.0, period_s=PERIOD), settings=settings)
        t0 = time.perf_counter()
        found = list(rx.run(blocks, fs=FS))
        wall = time.perf_counter() - t0
        blanked = rx.blanker.n_blanked / (n_blocks * int(FS)) if rx.blanker is not None else math.nan
        lines.append(f"| {label} | {minutes:g} | {len(found)} | {blanked:.1e} | {n_blocks / wall:.1f}x |")
    return _write_results(lines, path, "bench_doppler_paths_false_alarms.txt")


if __name__ == "__main__":
    sys.exit(main())
