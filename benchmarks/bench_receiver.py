"""Receiver benchmark (issue 4): accuracy against the CRLBs, multipath, detection, speed, memory.

Run: ``python benchmarks/bench_receiver.py`` (about 4 min on one core here);
``--quick`` uses fewer frames and skips the 1-hour memory run.

Signals are independent of the project's channel code: each received frame is
the analytic jmse2024 frame evaluated at warped times
(``tests/receive/analytic.py``), so the delay and the Doppler are known
exactly. SNR is in-band (SPEC §1: data-band signal power over the noise power
in B = 8.96 kHz); white Gaussian noise.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import soundfile

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "receive"))

from analytic import awgn_sigma, received_frame  # noqa: E402

from seamodem import BeaconSchedule, build_frame, get_preset, write_beacon  # noqa: E402
from seamodem.receive import (  # noqa: E402
    Emissions,
    Receiver,
    delay_crlb_s,
    pilot_velocity_crlb_mps,
    receive_file,
    tone_c_n0_hz,
    tone_velocity_crlb_mps,
)

CFG = get_preset("jmse2024")
FS = CFG.sample_rate_hz
C = 1500.0
PERIOD = 0.5  # frames every 0.5 s in the accuracy recordings


def _frames(n, *, v, snr_db, seed, accel=0.0, paths=((0.0, 1.0, 1.0),)):
    """n frames, one per PERIOD, random sub-sample arrivals; paths = (delay, gain, Doppler factor)."""
    rng = np.random.default_rng(seed)
    frame = build_frame(CFG, b"benchmark")
    arrivals = np.arange(n) * PERIOD + 0.05 + rng.uniform(0, 0.02, n)
    total = int((n * PERIOD + 0.2) * FS)
    x = np.zeros(total)
    for ta in arrivals:
        for delay, gain, factor in paths:
            lo, hi = int((ta + delay - 0.006) * FS), min(total, int((ta + delay + CFG.frame_duration_s + 0.01) * FS))
            t = np.arange(lo, hi) / FS
            x[lo:hi] += received_frame(
                frame, t, t_arrival_s=ta + delay, v_mps=v * factor, accel_mps2=accel * factor, gain=gain
            )
    x += awgn_sigma(CFG, snr_db) * rng.standard_normal(total)
    return x, arrivals


def _run(x):
    rx = Receiver(CFG, emissions=Emissions(start_s=0.0, period_s=PERIOD))
    return list(rx.run((x[i : i + (1 << 19)] for i in range(0, len(x), 1 << 19)), fs=FS))


def _rms(e):
    return float(np.sqrt(np.mean(np.square(e))))


def accuracy(n):
    print(f"\n## Accuracy, AWGN, jmse2024, v_r = ±3 m/s, {n} frames per row (RMSE; bound = CRLB of SPEC §6)\n")
    print("| SNR dB | v m/s | found | range RMSE mm | CRLB mm | ratio | v tone-ML mm/s | CRLB | ratio "
          "| v eq 9 mm/s | ratio | v bank mm/s | CRLB | ratio | SNR est. dB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for snr in (0.0, 10.0, 20.0):
        for v in (3.0, -3.0) if snr == 10.0 else (3.0,):
            x, arrivals = _frames(n, v=v, snr_db=snr, seed=int(snr) + (v < 0))
            recs = _run(x)
            got = {r.frame_index: r for r in recs}
            idx = [k for k in range(n) if k in got]
            rec = [got[k] for k in idx]
            er = C * (np.array([r.t_arrival_s for r in rec]) - arrivals[idx])
            ev = {m: np.array([getattr(r, m) for r in rec]) - v for m in ("v_r_mps", "v_r_tone_eq9_mps", "v_r_bank_mps")}
            b_r = C * float(delay_crlb_s(CFG, snr))
            b_t = float(tone_velocity_crlb_mps(CFG, tone_c_n0_hz(CFG, snr), sound_speed_mps=C))
            b_p = float(pilot_velocity_crlb_mps(CFG, snr, sound_speed_mps=C))
            r_r, r_t, r_e, r_b = _rms(er), _rms(ev["v_r_mps"]), _rms(ev["v_r_tone_eq9_mps"]), _rms(ev["v_r_bank_mps"])
            snr_est = np.median([r.snr_db for r in rec])
            print(
                f"| {snr:.0f} | {v:+.0f} | {len(rec)}/{n} | {1e3 * r_r:.2f} | {1e3 * b_r:.2f} | {r_r / b_r:.2f} "
                f"| {1e3 * r_t:.3f} | {1e3 * b_t:.3f} | {r_t / b_t:.2f} | {1e3 * r_e:.3f} | {r_e / b_t:.2f} "
                f"| {1e3 * r_b:.1f} | {1e3 * b_p:.1f} | {r_b / b_p:.2f} | {snr_est:.2f} |"
            )
            bias = np.mean(ev["v_r_mps"])
            if abs(bias) > 3 * r_t / np.sqrt(len(rec)):
                print(f"|   | note: tone-ML bias {1e3 * bias:+.3f} mm/s |")


def multipath(n):
    print(f"\n## Multipath and acceleration, 10 dB, {n} frames per row (direct-path truth; errors: mean ± std)\n")
    print("Paths: (extra delay ms, gain, Doppler factor). Truth v_r = direct path's mean over the frame.\n")
    print("| case | found | range bias mm | range std mm | v tone-ML bias mm/s | std | v eq 9 bias | v bank bias mm/s "
          "| std |")
    print("|---|---|---|---|---|---|---|---|---|")
    # shallow water, 30 m deep, both ends 10 m deep, 450 m apart: the surface image adds
    # 0.44 m (0.29 ms) at 2.5°, the bottom image 1.8 m (1.2 ms) at 5.1° (Doppler × cos)
    geometry = ((0.0, 1.0, 1.0), (0.29e-3, -0.9, 0.999), (1.2e-3, 0.5, 0.996))
    cases = [
        ("direct only, a = 0.1 m/s²", 0.1, ((0.0, 1.0, 1.0),)),
        ("geometry: surface −0.9 @0.29 ms, bottom 0.5 @1.2 ms", 0.0, geometry),
        ("geometry + a = 0.1 m/s²", 0.1, geometry),
        ("geometry, surface STRONGER (−1.4), a = 0.1", 0.1,
         ((0.0, 1.0, 1.0), (0.29e-3, -1.4, 0.999), (1.2e-3, 0.5, 0.996))),
        ("resolved, steep: surface −1.4 @1.5 ms (×0.98), bottom 0.5 @4 ms (×0.95), a = 0.1", 0.1,
         ((0.0, 1.0, 1.0), (1.5e-3, -1.4, 0.98), (4e-3, 0.5, 0.95))),
    ]
    v = 3.0
    for i, (name, accel, paths) in enumerate(cases):
        x, arrivals = _frames(n, v=v, snr_db=10.0, seed=100 + i, accel=accel, paths=paths)
        recs = _run(x)
        got = {r.frame_index: r for r in recs}
        idx = [k for k in range(n) if k in got]
        rec = [got[k] for k in idx]
        truth_v = v + accel * CFG.frame_duration_s / 2  # mean over the frame of v + a·t
        er = 1e3 * C * (np.array([r.t_arrival_s for r in rec]) - arrivals[idx])
        et = 1e3 * (np.array([r.v_r_mps for r in rec]) - truth_v)
        ee = 1e3 * (np.array([r.v_r_tone_eq9_mps for r in rec]) - truth_v)
        eb = 1e3 * (np.array([r.v_r_bank_mps for r in rec]) - v)  # the pilot sees the frame's start
        print(
            f"| {name} | {len(rec)}/{n} | {er.mean():+.2f} | {er.std():.2f} | {et.mean():+.2f} | {et.std():.2f} "
            f"| {ee.mean():+.2f} | {eb.mean():+.1f} | {eb.std():.1f} |"
        )


def detection(minutes, n_pd):
    print(f"\n## False alarms on {minutes:g} min of noise (default threshold: 0.01 per hour design rate)\n")
    rng = np.random.default_rng(7)
    n = int(minutes * 60 * FS)
    rx = Receiver(CFG, emissions=Emissions(start_s=0.0, period_s=3.0))
    block = 1 << 20
    white = (rng.standard_normal(min(block, n - i)) for i in range(0, n, block))
    fa_white = len(list(rx.run(white, fs=FS)))

    def impulsive():
        for i in range(0, n, block):
            m = min(block, n - i)
            x = 0.01 * rng.standard_normal(m)
            hits = rng.random(m) < 20 / FS  # 20 clicks a second, 40–60 dB above the background
            x[hits] += rng.choice([-1, 1], hits.sum()) * 10 ** rng.uniform(0, 1, hits.sum())
            yield x

    fa_imp = len(list(rx.run(impulsive(), fs=FS)))
    print("| noise | detections | design rate (per hour) |")
    print("|---|---|---|")
    print(f"| white Gaussian | {fa_white} | 0.01 |")
    print(f"| impulsive (20 clicks/s, +40…60 dB) | {fa_imp} | — |")
    print(f"\n## Detection probability against in-band SNR ({n_pd} frames per row, v = 1 m/s)\n")
    print("| SNR dB | detected | P_d | range RMSE mm (detected) |")
    print("|---|---|---|---|")
    for snr in (-12.0, -10.0, -8.0, -6.0, -4.0, 0.0):
        x, arrivals = _frames(n_pd, v=1.0, snr_db=snr, seed=300 + int(snr))
        recs = [r for r in _run(x) if 0 <= r.frame_index < n_pd]
        good = [r for r in recs if abs(r.t_arrival_s - arrivals[r.frame_index]) < 1e-3]
        er = [C * (r.t_arrival_s - arrivals[r.frame_index]) for r in good]
        rmse = f"{1e3 * _rms(er):.1f}" if er else "—"
        extra = len(recs) - len(good)
        note = f" (+{extra} wrong)" if extra else ""
        print(f"| {snr:.0f} | {len(good)}/{n_pd}{note} | {len(good) / n_pd:.2f} | {rmse} |")


def channel_crosscheck(count):
    """tx → the project's channel simulator (issue 3, straight_line scenario) → rx, against its truth."""
    import json

    from seamodem.cli import main as cli
    from seamodem.receive import read_measurements

    scenario = Path(__file__).resolve().parents[1] / "examples" / "scenarios" / "straight_line.toml"
    print(f"\n## Cross-check through the channel simulator ({scenario.name}, {count} frames)\n")
    print("Direct + surface (−1.0) + bottom (0.5) images, 15 dB white noise, vehicle at 1.5 m/s; truth from")
    print("the channel's sidecar (direct path). Errors: mean ± std.\n")
    with tempfile.TemporaryDirectory() as d:
        tx, rx, meas = Path(d) / "tx.wav", Path(d) / "rx.wav", Path(d) / "m.csv"
        assert cli(["tx", "--count", str(count), "--period", "3", "-o", str(tx), "-q"]) == 0
        assert cli(["channel", str(tx), "--scenario", str(scenario), "-o", str(rx), "-q"]) == 0
        assert cli(["rx", str(rx), "-o", str(meas), "-q"]) == 0
        truth = {t["frame_index"]: t for t in json.loads(rx.with_suffix(".json").read_text())["truth"]}
        recs, _ = read_measurements(meas)
    er = np.array([1e3 * (r.range_m - truth[r.frame_index]["range_true_m"]) for r in recs])
    ev = {m: np.array([1e3 * (getattr(r, m) - truth[r.frame_index]["v_r_true_mps"]) for r in recs])
          for m in ("v_r_mps", "v_r_tone_eq9_mps", "v_r_bank_mps")}
    es = np.array([r.snr_db - truth[r.frame_index]["snr_db"] for r in recs])
    print("| found | range mm | v tone-ML mm/s | v eq 9 mm/s | v bank mm/s | SNR est. − true dB |")
    print("|---|---|---|---|---|---|")
    print(
        f"| {len(recs)}/{count} | {er.mean():+.2f} ± {er.std():.2f} | {ev['v_r_mps'].mean():+.1f} ± {ev['v_r_mps'].std():.1f} "
        f"| {ev['v_r_tone_eq9_mps'].mean():+.1f} ± {ev['v_r_tone_eq9_mps'].std():.1f} "
        f"| {ev['v_r_bank_mps'].mean():+.1f} ± {ev['v_r_bank_mps'].std():.1f} | {es.mean():+.2f} ± {es.std():.2f} |"
    )


def two_way_crosscheck(count):
    """Two-way ranging: tx → channel ([two_way]: polls on the vehicle's clock, replies) → rx --turnaround."""
    import json

    from seamodem.cli import main as cli
    from seamodem.receive import read_measurements

    base = (Path(__file__).resolve().parents[1] / "examples" / "scenarios" / "straight_line.toml").read_text()
    turnaround = 0.3
    print(f"\n## Two-way ranging through the channel simulator (straight_line.toml + [two_way], {count} polls)\n")
    print(f"Polls every 3 s on the vehicle's clock, turnaround {turnaround} s, vehicle clock offset as listed;")
    print("truth = (outbound range at the poll + return range at the reply)/2. Errors: mean ± std.\n")
    print("| clock offset s | found | two-way range error mm | max abs mm | mean outbound − return m |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        tx = Path(d) / "tx.wav"
        assert cli(["tx", "--count", str(count), "--period", "3", "-o", str(tx), "-q"]) == 0
        for offset, first in ((0.0, 0.1), (12.5, 12.6), (-4.0, 0.1)):
            scenario, rx, meas = Path(d) / "s.toml", Path(d) / "rx.wav", Path(d) / "m.csv"
            scenario.write_text(base + f"\n[clock]\noffset_s = {offset}\n[two_way]\nturnaround_s = {turnaround}\n"
                                       f"first_poll_s = {first}\npoll_period_s = 3.0\n")
            assert cli(["channel", str(tx), "--scenario", str(scenario), "-o", str(rx), "-q"]) == 0
            assert cli(["rx", str(rx), "--turnaround", str(turnaround), "-o", str(meas), "-q"]) == 0
            truth = {t["frame_index"]: t for t in json.loads(rx.with_suffix(".json").read_text())["truth"]}
            recs, _ = read_measurements(meas)
            er = np.array([1e3 * (r.range_m - (truth[r.frame_index]["range_poll_m"]
                                               + truth[r.frame_index]["range_reply_m"]) / 2) for r in recs])
            legs = np.mean([t["range_poll_m"] - t["range_reply_m"] for t in truth.values()])
            print(f"| {offset:+g} | {len(recs)}/{count} | {er.mean():+.2f} ± {er.std():.2f} | {np.max(np.abs(er)):.2f} "
                  f"| {legs:+.3f} |")


def _write_long(path, minutes, *, frames: bool):
    """A long recording in blocks: beacon frames every 3 s (or none) plus white noise at ~10 dB in-band."""
    fs = int(FS)
    n = int(minutes * 60 * fs)
    rng = np.random.default_rng(11)
    if frames:
        tmp = path.with_name("clean_" + path.name)
        side = write_beacon(tmp, CFG, BeaconSchedule(count=int(minutes * 20), period_s=3.0, start_s=0.5),
                            progress=False)
        sigma = awgn_sigma(CFG, 10.0, gain=side["recording"]["scale"])
        with soundfile.SoundFile(tmp) as src, soundfile.SoundFile(path, "w", fs, 1, "FLOAT") as dst:
            for block in src.blocks(blocksize=1 << 20):
                dst.write(block + sigma * rng.standard_normal(len(block)))
        tmp.unlink()
        tmp.with_suffix(".json").unlink()
    else:
        with soundfile.SoundFile(path, "w", fs, 1, "FLOAT") as dst:
            for i in range(0, n, 1 << 20):
                dst.write(0.1 * rng.standard_normal(min(1 << 20, n - i)))


def _measure_child(path):
    """Run in a subprocess: time receive_file on ``path``; print frames, seconds, peak RSS."""
    from seamodem.transmit.pilot import pilot_symbols

    # the pilot search of transmit.pilot (≈ 0.8 s, once per process; the CLI reads the
    # bits from the sidecar instead) is set-up, not throughput
    pilot = pilot_symbols(CFG.n_pilot, CFG.pilot_seed)
    t0, c0 = time.perf_counter(), time.process_time()
    recs = list(
        receive_file(path, CFG, emissions=Emissions(start_s=0.5, period_s=3.0), progress=False, pilot=pilot)
    )
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(len(recs), dt, cpu, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def speed(hour: bool):
    print("\n## Speed and memory (one process, `receive_file` on a FLOAT WAV, 2 cores shared)\n")
    print("Real-time factor = audio duration / time; CPU = process time (one thread), wall = elapsed;")
    print("the pilot is built before the clock starts (≈ 0.8 s once per process, or read from the sidecar).\n")
    print("| recording | frames found | wall s | CPU s | RT factor (wall) | RT factor (CPU) | peak RSS MB |")
    print("|---|---|---|---|---|---|---|")
    runs = [("2 min, frames every 3 s, 10 dB", 2, True), ("10 min, frames every 3 s, 10 dB", 10, True)]
    if hour:
        runs.append(("60 min, white noise only", 60, False))
    with tempfile.TemporaryDirectory() as d:
        for name, minutes, frames in runs:
            path = Path(d) / f"long_{minutes}.wav"
            _write_long(path, minutes, frames=frames)
            out = subprocess.run(
                [sys.executable, __file__, "--child", str(path)], capture_output=True, text=True, check=True
            ).stdout.split()
            n, dt, cpu, rss_kb = int(out[0]), float(out[1]), float(out[2]), int(out[3])
            print(
                f"| {name} | {n} | {dt:.1f} | {cpu:.1f} | {minutes * 60 / dt:.0f}× | {minutes * 60 / cpu:.0f}× "
                f"| {rss_kb / 1024:.0f} |"
            )
            path.unlink()


TABLES = ("accuracy", "multipath", "channel", "two_way", "detection", "speed")


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--only", nargs="+", choices=TABLES, metavar="TABLE",
                   help=f"run only these tables ({', '.join(TABLES)}); default all")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        _measure_child(args.child)
        return
    only = set(args.only or TABLES)
    n = 30 if args.quick else 100
    if "accuracy" in only:
        accuracy(n)
    if "multipath" in only:
        multipath(n // 2)
    if "channel" in only:
        channel_crosscheck(10 if args.quick else 30)
    if "two_way" in only:
        two_way_crosscheck(10 if args.quick else 30)
    if "detection" in only:
        detection(2.0 if args.quick else 10.0, 20 if args.quick else 50)
    if "speed" in only:
        speed(hour=not args.quick)


if __name__ == "__main__":
    main()
