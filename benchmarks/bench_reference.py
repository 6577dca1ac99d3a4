"""Reference ranging benchmark (issue 16): LFM/HFM/PN through the channel simulator, pairs, false alarms, speed.

Run: ``python benchmarks/bench_reference.py`` (about 5 min on one core here);
``--quick`` uses a shorter pass. Tables are printed and saved to
``benchmarks/results/bench_reference.txt``.

Channel: the project's simulator (geometry mode), a vehicle passing a beacon
at 3 m/s with its closest point 45 m away in 30 m of water: v_r sweeps from
+2.97 to −2.97 m/s, |dv_r/dt| reaches 0.2 m/s² at the closest point; direct
path, surface (−1) and bottom (0.5) echoes, spherical-ish spreading and
absorption; white noise at the stated in-band SNR (signal power in
[f_low, f_high] over the ping's reception, simulator's definition). Truth: the
simulator's direct path (``t_arrival_s``, ``v_r_mps`` = mean over the ping).
CRLB: the reference's joint CRLB (``reference_crlb``) at each ping's measured
E/N0 (direct path), RMS over the pings; ratio = RMSE / CRLB. Calibration: the
share of pings with |error| ≤ 3σ (the record's σ).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from seamodem.channel.scenario import parse_scenario
from seamodem.channel.simulate import simulate
from seamodem.receive.reference import MIN_RHO, ReferenceReceiver, pair_up
from seamodem.receive.settings import ReferenceSettings
from seamodem.transmit.reference import (
    ReferenceWaveform,
    emission_times,
    parse_reference,
    reference_crlb,
    reference_replica,
    reference_waveform,
)

FS = 96_000.0
C = 1500.0
RESULTS = Path(__file__).resolve().parent / "results" / "bench_reference.txt"


def scenario(snr_db: float, *, duration_s: float, seed: int, max_bounces: int = 1, radial: bool = False):
    """The pass (or, ``radial``, a vehicle opening at 1 m/s along a line through the beacon: constant v_r, a = 0)."""
    half = 1.5 * duration_s  # 3 m/s over the pass, centred on the closest point
    start, velocity = ([-100.0, 0.0, -10.0], [-1.0, 0.0, 0.0]) if radial else ([-half, 45.0, -5.0], [3.0, 0.0, 0.0])
    return parse_scenario(
        {
            "mode": "geometry",
            "seed": seed,
            "environment": {"sound_speed_mps": C, "water_depth_m": 30.0, "spreading_exponent": 1.5, "absorption": True},
            "beacon": {"position_m": [0.0, 0.0, -10.0]},
            "vehicle": {"start_m": start, "velocity_mps": velocity},
            "multipath": {"max_bounces": max_bounces, "surface_reflection": -1.0, "bottom_reflection": 0.5},
            "noise": {"kind": "white", "snr_db": snr_db},
        }
    )


def transmitted(refs, *, count: int, period_s: float) -> tuple[np.ndarray, list[dict]]:
    """The beacon's emissions, as ``seamodem tx --reference`` renders them."""
    reps = [reference_replica(r) for r in refs]
    waves = {rep.reference.name: reference_waveform(rep, FS) for rep in reps}
    em = emission_times(refs, count=count, period_s=period_s, start_s=0.2)
    x = np.zeros(int((em[-1]["t_emit_s"] + 1.0) * FS))
    for e in em:
        i0 = int(round(e["t_emit_s"] * FS))
        e["t_emit_s"] = i0 / FS
        w = waves[e["reference"]]
        x[i0 : i0 + len(w)] += w
    return x, em


def through_channel(ref: ReferenceWaveform, snr_db: float, *, count: int, period_s: float, seed: int):
    x, em = transmitted([ref], count=count, period_s=period_s)
    t_emit = [e["t_emit_s"] for e in em]
    sim = simulate(x, FS, scenario(snr_db, duration_s=count * period_s, seed=seed), t_emit_s=t_emit,
                   frame_duration_s=ref.duration_s, band_hz=(ref.f_low_hz, ref.f_high_hz))
    return sim.output, sim.truth, em


def receive(refs, y, *, fs=FS, false_alarms_per_hour=0.01, min_rho=MIN_RHO):
    settings = ReferenceSettings(sound_speed_mps=C, v_max_mps=5.0, false_alarms_per_hour=false_alarms_per_hour,
                                 min_rho=min_rho)
    rx = ReferenceReceiver(refs, fs, settings=settings)
    blocks = (y[i : i + (1 << 18)].reshape(-1, 1) for i in range(0, len(y), 1 << 18))
    return rx, list(rx.run(blocks))


def match(found, truth, tol_s=2e-3):
    """(pairs of (found, truth row), false detections)."""
    t_true = np.array([row["t_arrival_s"] for row in truth])
    pairs, false = [], []
    for f in found:
        k = int(np.argmin(np.abs(t_true - f.fit.t_arrival_s)))
        if abs(t_true[k] - f.fit.t_arrival_s) < tol_s:
            pairs.append((f, truth[k]))
        else:
            false.append(f)
    return pairs, false


def multipath_crlb_t(rx, replica, bound, row, e_n0: float) -> float:
    """The arrival's CRLB with the truth's echoes as nuisance paths (each path's t_a, ε and complex gain unknown).

    The joint Fisher matrix of every path of the simulator's truth (its delays, Dopplers and amplitudes, not
    the receiver's fit) in white baseband noise (:meth:`~seamodem.receive.reference.PathFitter.echo_inflation`),
    over the direct path's own: the single-path bound at the measured E/N0 times that inflation.
    """
    from seamodem.receive.reference import PathFitter

    fs, paths = rx.plan.fs_bb, row["paths"]
    t0 = paths[0]["t_arrival_s"]
    t = t0 - 0.002 + np.arange(int((replica.duration_s + 0.01 + max(p["t_arrival_s"] for p in paths) - t0) * fs)) / fs
    fitter = PathFitter(replica, t, rx.plan.centre_hz, fs, bound.ridge_slope_s, 1.0)
    echoes = [(p["t_arrival_s"], p["v_r_true_mps"] / C, p["amplitude"]) for p in paths[1:]]
    k_e, k_ridge = fitter.echo_inflation(t0, paths[0]["v_r_true_mps"] / C, paths[0]["amplitude"], echoes)
    _, s_e, s_ridge = bound.at(e_n0)
    return math.hypot(k_ridge * s_ridge, bound.ridge_slope_s * k_e * s_e)


def accuracy_table(quick: bool) -> list[str]:
    count, period = (60, 1.0) if quick else (200, 1.0)
    refs = [parse_reference("lfm:19000-29000:0.05"), parse_reference("hfm:19000-29000:0.05"),
            parse_reference("pn:24000:5000:7")]
    lines = [
        f"## Through the channel simulator: {count} pings, one per {period:g} s, v_r ±3 m/s, |a| ≤ 0.2 m/s², "
        "surface + bottom echoes, white noise",
        "",
        "| reference | SNR | Pd | false /h | t RMSE [µs] | t CRLB [µs] | ratio | t CRLB, echoes [µs] | ratio | ≤3σ t "
        "| v RMSE [m/s] | v CRLB [m/s] | ratio | ≤3σ v | median σ_v [m/s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for ref in refs:
        replica = reference_replica(ref)
        bound = reference_crlb(replica)
        for snr in (0.0, 10.0, 20.0):
            y, truth, _ = through_channel(ref, snr, count=count, period_s=period, seed=int(snr) + 1)
            rx, found = receive([ref], y)
            pairs, false = match(found, truth)
            et = np.array([f.fit.t_arrival_s - row["t_arrival_s"] for f, row in pairs])
            ev = np.array([f.fit.eps * C - row["v_r_mps"] for f, row in pairs])
            st = np.array([f.fit.sigma_t_s for f, _ in pairs])
            sv = np.array([f.fit.sigma_eps * C for f, _ in pairs])
            crlb = np.array([bound.at(f.fit.e_n0)[:2] for f, _ in pairs])
            crlb_t, crlb_v = math.sqrt(np.mean(crlb[:, 0] ** 2)), C * math.sqrt(np.mean(crlb[:, 1] ** 2))
            rt, rv = math.sqrt(np.mean(et**2)), math.sqrt(np.mean(ev**2))
            crlb_mp = math.sqrt(np.mean([multipath_crlb_t(rx, replica, bound, row, f.fit.e_n0) ** 2 for f, row in pairs]))
            hours = len(y) / FS / 3600
            lines.append(
                f"| {ref.name} | {snr:g} dB | {len(pairs) / len(truth):.3f} | {len(false) / hours:.0f} | {rt * 1e6:.2f} "
                f"| {crlb_t * 1e6:.2f} | {rt / crlb_t:.2f} | {crlb_mp * 1e6:.2f} | {rt / crlb_mp:.2f} | {np.mean(np.abs(et) <= 3 * st):.3f} | {rv:.4f} | {crlb_v:.4f} "
                f"| {rv / crlb_v:.2f} | {np.mean(np.abs(ev) <= 3 * sv):.3f} | {np.median(sv):.4f} |"
            )
            print(lines[-1], flush=True)
    lines += [
        "",
        "Pd: pings found within 2 ms of the direct path's arrival; false /h: other detections per hour of recording "
        "(an echo or an HFM ping found twice counts here). CRLB: joint (t_a, ε) bound at the measured E/N0; "
        "CRLB, echoes: the same with the truth's surface and bottom echoes as nuisance paths (`multipath_crlb_t`): "
        "an echo within a few main lobes (an inverted surface echo 1.3–1.8 PN chips behind) leaves the direct "
        "path's arrival uncertain at any SNR.",
    ]
    return lines


def pair_bound(a, b, bound, *, spacing_s: float, max_accel_mps2: float) -> float:
    """σ_ε of one pair if each ping were measured at its CRLB (the estimator of :func:`pair_up`, no inflation).

    With the Doppler changing over the packet the arrivals' spacing is the ridge spacing less 2g·δ, and δ is
    known from the pings' own ε's (σ_ε,ping each, the joint CRLB) shrunk by the prior |a| ≤ ``max_accel_mps2``:
    σ_ε̄ = √(σ_r,1² + σ_r,2² + 4g²·var δ̃)/T_sp. With the change known to be 0 (``max_accel_mps2`` 0), var δ̃ = 0:
    the spacing alone, √2·σ_r/T_sp (σ_r the known-ε bound, ≈ 1 µs).
    """
    _, se_a, sr_a = bound.at(a.fit.e_n0)
    _, se_b, sr_b = bound.at(b.fit.e_n0)
    var_prior = (max_accel_mps2 * spacing_s / (2 * C)) ** 2 / 3
    var_own = (se_a**2 + se_b**2) / 4
    var_half = var_prior * var_own / (var_prior + var_own) if var_prior > 0 else 0.0
    return math.sqrt(sr_a**2 + sr_b**2 + 4 * bound.ridge_slope_s**2 * var_half) / spacing_s


#: pair scenarios: (label, reference, scenario changes, max_accel_mps2 given to pair_up)
PAIR_CASES = (
    ("passing, echoes", "lfm:19000-29000:0.05", {}, 0.3),
    ("passing, echoes", "hfm:19000-29000:0.05", {}, 0.3),
    ("passing, direct path only", "lfm:19000-29000:0.05", {"max_bounces": 0}, 0.3),
    ("radial 1 m/s, echoes, a = 0 stated", "lfm:19000-29000:0.05", {"radial": True}, 0.0),
)


def pair_table(quick: bool) -> list[str]:
    """Pre/postamble 8 s apart, 10 dB, through the simulator: ε from the spacing against the truth's mean scale."""
    count = 12 if quick else 30
    lines = ["", f"## Pre/postamble pairs 8 s apart, 10 dB, through the simulator ({count} packets, one per 10 s)", "",
             "| reference | channel | max_accel [m/s²] | pairs | ε RMSE | bound σ_ε (RMS) | ratio | mean σ_ε | ≤3σ "
             "| v RMSE [mm/s] | range RMSE, pair-corrected [mm] | range RMSE, own ε [mm] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, spec, change, max_accel in PAIR_CASES:
        base = parse_reference(spec)
        ref = ReferenceWaveform(**{**base.to_dict(), "postamble_s": 8.0})
        bound = reference_crlb(reference_replica(ref))
        x, em = transmitted([ref], count=count, period_s=10.0)
        sc = scenario(10.0, duration_s=count * 10.0, seed=5, **change)
        sim = simulate(x, FS, sc, t_emit_s=[e["t_emit_s"] for e in em],
                       frame_duration_s=ref.duration_s, band_hz=(ref.f_low_hz, ref.f_high_hz))
        _, found = receive([ref], sim.output)
        pairs, _ = match(found, sim.truth)
        found = [f for f, _ in pairs]
        truth = {id(f): row for f, row in pairs}
        pair_up(found, eps_max=5.0 / C, sound_speed_mps=C, max_accel_mps2=max_accel)
        errs, sig, bnd, e_own, e_pair = [], [], [], [], []
        for a, b in zip(found, found[1:]):
            if a.role == "preamble" and b.role == "postamble":
                ta, tb = truth[id(a)]["t_arrival_s"], truth[id(b)]["t_arrival_s"]
                eps_true = 8.0 / (tb - ta) - 1  # the packet's mean compression on the receiver's clock
                errs.append(a.eps_pair - eps_true)
                sig.append(a.sigma_eps_pair)
                bnd.append(pair_bound(a, b, bound, spacing_s=8.0, max_accel_mps2=max_accel))
        for f, row in pairs:
            if math.isfinite(f.t_pair_s):
                e_pair.append(f.t_pair_s - row["t_arrival_s"])
                e_own.append(f.fit.t_arrival_s - row["t_arrival_s"])
        errs, sig = np.array(errs), np.array(sig)
        rmse, rms_bound = math.sqrt(np.mean(errs**2)), math.sqrt(np.mean(np.square(bnd)))
        lines.append(
            f"| {ref.name} | {label} | {max_accel:g} | {len(errs)} | {rmse:.2e} | {rms_bound:.2e} | {rmse / rms_bound:.2f} "
            f"| {np.mean(sig):.2e} | {np.mean(np.abs(errs) <= 3 * sig):.3f} | {C * 1e3 * rmse:.2f} "
            f"| {C * 1e3 * math.sqrt(np.mean(np.square(e_pair))):.2f} | {C * 1e3 * math.sqrt(np.mean(np.square(e_own))):.2f} |"
        )
        print(lines[-1], flush=True)
    lines += [
        "",
        "Goal: ε RMSE ≤ 2e-6 (≈ 3 mm/s). Truth ε: 8 s over the direct path's measured spacing. Bound: each pair's σ_ε "
        "if both pings were measured at their CRLB at their measured E/N0 (`pair_bound`): with a Doppler change "
        "allowed, √(σ_r1² + σ_r2² + 4g²·var δ̃)/T_sp, dominated by the pings' own ε (g = −0.145 s for these chirps); "
        "with the change stated 0, the spacing alone (√2·σ_r/T_sp).",
    ]
    return lines


def false_alarm_table(quick: bool) -> list[str]:
    """Detections in white noise against the design rate (ρ test off: in noise it rejects everything)."""
    minutes = 3 if quick else 10
    rng = np.random.default_rng(0)
    ref = parse_reference("lfm:19000-29000:0.05")
    lines = ["", f"## False alarms in {minutes} min of white noise (LFM 19–29 kHz, 5 scale bins)", "",
             "| design rate [/h] | ρ test | detections | measured rate [/h] | measured / design |", "|---|---|---|---|---|"]
    y = rng.normal(0, 0.1, int(minutes * 60 * FS))
    for rate in (360.0, 3600.0, 36000.0):  # each detection is fitted: higher rates take minutes of fits
        for rho in (0.0, MIN_RHO):
            _, found = receive([ref], y, false_alarms_per_hour=rate, min_rho=rho)
            measured = len(found) / (minutes / 60)
            lines.append(f"| {rate:g} | {'on' if rho else 'off'} | {len(found)} | {measured:.0f} | {measured / rate:.3f} |")
            print(lines[-1], flush=True)
    lines += ["", "η = ln(n_tests/rate) counts every lag of every bin as independent (they are not): measured ≤ design."]
    return lines


def speed_table(quick: bool) -> list[str]:
    seconds = 60 if quick else 180
    lines = ["", f"## Speed, steady state: {seconds} s recordings, one LFM ping every 3 s at 10 dB, one reference, "
             "one core (shared with other jobs)", "",
             "| fs [kHz] | decimation | baseband [kHz] | wall [s] | × real time | CPU [s] | × real time (CPU) | load |",
             "|---|---|---|---|---|---|---|---|"]
    ref = parse_reference("lfm:19000-29000:0.05")
    rng = np.random.default_rng(1)
    for fs in (96_000.0, 256_000.0, 384_000.0):
        rep = reference_replica(ref)
        w = reference_waveform(rep, fs)
        y = rng.normal(0, 1.0, int(seconds * fs))
        # 10 dB in band: ping power (≈ 0.5·0.94) over N0·B with N0 = 2σ²/fs
        gain = math.sqrt(10 * 10e3 * 2 / fs / 0.47)
        for k in range(int(seconds / 3) - 1):
            i0 = int((0.5 + 3 * k + rng.uniform(0, 0.1)) * fs)
            y[i0 : i0 + len(w)] += gain * w
        # steady state: the receiver (replica bank, CRLB, filters) is built before the clock starts
        rx = ReferenceReceiver([ref], fs, settings=ReferenceSettings(sound_speed_mps=C, v_max_mps=5.0))
        t0, c0 = time.perf_counter(), time.process_time()
        found = list(rx.run(y[i : i + (1 << 18)].reshape(-1, 1) for i in range(0, len(y), 1 << 18)))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
        lines.append(f"| {fs / 1e3:g} | {rx.plan.decimation} | {rx.plan.fs_bb / 1e3:.2f} | {wall:.2f} | {seconds / wall:.0f} "
                     f"| {cpu:.2f} | {seconds / cpu:.0f} | {load:.1f} |")
        print(lines[-1], f"({len(found)} pings)", flush=True)
    return lines


def cli_speed_table(quick: bool) -> list[str]:
    """``seamodem rx --reference`` end to end on a long 96 kHz WAV (read, front end, detection, fits, records).

    Steady state: the command runs once on a 10 s file first (imports, compiled kernels), then on the long one
    in the same process; receiver construction (replica bank, CRLB) and writing the records are inside the clock.
    """
    import tempfile

    import soundfile

    from seamodem.cli import main

    seconds, fs = (120, 96_000.0) if quick else (600, 96_000.0)
    ref = parse_reference("lfm:19000-29000:0.05")
    w = reference_waveform(reference_replica(ref), fs)
    rng = np.random.default_rng(2)
    lines = ["", f"## `seamodem rx --reference` end to end: a {seconds} s WAV at 96 kHz (float32), one LFM ping every 3 s "
             "at 10 dB, after a warm-up run", "", "| recording [s] | pings | wall [s] | × real time | CPU [s] | × real time (CPU) | load |",
             "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name, dur in (("warm", 10), ("long", seconds)):
            wav = Path(tmp) / f"{name}.wav"
            gain = math.sqrt(10 * 10e3 * 2 / fs / 0.47)  # 10 dB in band (as speed_table)
            with soundfile.SoundFile(wav, "w", samplerate=int(fs), channels=1, subtype="FLOAT") as f:
                for _ in range(int(dur / 3)):  # 3 s at a time, one ping in each
                    y = rng.normal(0, 1.0, int(3 * fs))
                    i0 = int((0.5 + rng.uniform(0, 0.1)) * fs)
                    y[i0 : i0 + len(w)] += gain * w
                    f.write((0.05 * y).astype(np.float32))
            args = ["rx", str(wav), "--reference", "lfm:19000-29000:0.05", "--emit-start", "0.5", "--emit-period", "3",
                    "-o", str(Path(tmp) / f"{name}.csv"), "-q"]
            t0, c0 = time.perf_counter(), time.process_time()
            assert main(args) == 0
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rows = sum(1 for _ in open(Path(tmp) / "long.csv")) - 1
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    lines.append(f"| {seconds} | {rows} | {wall:.2f} | {seconds / wall:.0f} | {cpu:.2f} | {seconds / cpu:.0f} | {load:.1f} |")
    print(lines[-1], flush=True)
    return lines


TABLES = {"accuracy": accuracy_table, "pairs": pair_table, "false_alarms": false_alarm_table, "speed": speed_table,
          "cli_speed": cli_speed_table}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--only", nargs="+", choices=sorted(TABLES), help="run these tables only (results file not written)")
    args = p.parse_args(argv)
    lines = ["# bench_reference" + (" (--quick)" if args.quick else ""), ""]
    for name, table in TABLES.items():
        if not args.only or name in args.only:
            lines += table(args.quick)
    if args.only:
        print("\n".join(lines))
        return 0
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.with_name("bench_reference_quick.txt" if args.quick else RESULTS.name).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
