"""Payload decoding through the whole chain (issue 5): success on the issue's channel, turbo gain, speed.

Run: python benchmarks/bench_decode.py [--frames 200] [--sweep-frames 30] [--skip-sweeps]

1. A 10-minute recording (200 jmse2024 frames, T_com 3 s) through
   examples/scenarios/decode_multipath.toml: closing 3 ± 0.3 m/s with ±0.2 m/s²
   in every frame, surface and bottom echoes at 1.2 and 3.4 ms, 15 dB in-band
   SNR. The receiver (``receive_file``) detects, measures, compensates and
   decodes every frame; frame success with the DFE alone (goal ≥ 99 %) and after
   the turbo passes, against the payloads in the sidecar.
2. Speed on that recording, one process: measuring only, then measuring and
   decoding; real-time factors (goal ≥ 20× with the DFE) and decoded symbols per
   second (median of --repeats runs).
3. FER against SNR on the same channel (``seamodem.studies.ber``): the SNR at
   FER 10 % with the DFE alone and with turbo passes, and the gain in dB.
4. AWGN through the whole receiver, BPSK and QPSK: raw BER of the DFE's
   decisions beside Q(√(2Eb/N0)) and the SNR loss at BER 1e-3 (goal ≤ 0.5 dB).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from seamodem import get_preset
from seamodem.studies.ber import AWGN_SCENARIO, ber_sweep, snr_at_fer, theory_ber
from seamodem.io.sidecar import read_sidecar, sidecar_payloads, sidecar_pilot_bits
from seamodem.receive import Emissions, ReceiverSettings, receive_file

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "examples" / "scenarios" / "decode_multipath.toml"


def make_recording(folder: Path, frames: int) -> Path:
    tx = folder / "tx.wav"
    rec = folder / "rec.wav"
    seamodem = [sys.executable, "-m", "seamodem"]
    subprocess.run([*seamodem, "tx", "--count", str(frames), "--period", "3", "-o", str(tx), "-q"], check=True)
    subprocess.run([*seamodem, "channel", str(tx), "--scenario", str(SCENARIO), "-o", str(rec), "-q"], check=True)
    return rec


def receive(rec: Path, decode: bool):
    side = read_sidecar(rec.with_suffix(".json"))
    cfg = get_preset("jmse2024")
    bits = sidecar_pilot_bits(side)
    payloads = sidecar_payloads(side)
    emissions = Emissions(times_s=np.array([f["t_emit_s"] for f in side["frames"]]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        recs = list(
            receive_file(
                rec, cfg, emissions=emissions, progress=False, pilot=1.0 - 2.0 * bits, payloads=payloads,
                settings=ReceiverSettings(sound_speed_mps=side["channel"]["sound_speed_mps"], decode=decode),
            )
        )
        wall = time.perf_counter() - t0
    return recs, wall, side


def success_table(recs, side, frames):
    truth = {t["frame_index"]: t for t in side["truth"]} if "frame_index" in side["truth"][0] else dict(enumerate(side["truth"]))
    by_k = {}
    for r in recs:
        by_k.setdefault(r.frame_index, r)
    dfe = sum(1 for r in by_k.values() if r.crc_ok and r.decode_passes == 1)
    turbo = sum(1 for r in by_k.values() if r.crc_ok)
    wrong = sum(1 for r in by_k.values() if r.crc_ok and r.ber > 0)
    raw = np.mean([r.raw_ber for r in by_k.values() if math.isfinite(r.raw_ber)])
    eq = np.median([r.eq_snr_db for r in by_k.values() if math.isfinite(r.eq_snr_db)])
    snr = np.median([r.snr_db for r in by_k.values()])
    rng_err = [r.range_m - truth[k]["range_m"] for k, r in by_k.items() if k in truth]
    v_err = [r.v_r_mps - truth[k]["v_r_mps"] for k, r in by_k.items() if k in truth]
    print(f"\n1. {frames} frames, 3 m/s ± 0.3, ±0.2 m/s², echoes 1.2 and 3.4 ms, 15 dB (decode_multipath.toml)")
    print(f"{'figure':<44} {'measured':>12} {'goal':>10}")
    print(f"{'frames detected':<44} {len(by_k):>12d} {frames:>10d}")
    print(f"{'frame success, DFE alone':<44} {100 * dfe / frames:>11.1f}% {'>= 99 %':>10}")
    print(f"{'frame success, DFE + turbo passes':<44} {100 * turbo / frames:>11.1f}%")
    print(f"{'frames with CRC passed but wrong bits':<44} {wrong:>12d} {0:>10d}")
    print(f"{'raw BER of the DFE decisions (mean)':<44} {raw:>12.2e}")
    print(f"{'median measured SNR / SNR after the DFE [dB]':<44} {snr:>6.1f} /{eq:>5.1f}")
    print(f"{'range RMSE / v_r RMSE against the truth':<44} {1e3 * np.sqrt(np.mean(np.square(rng_err))):>7.1f} mm / {1e3 * np.sqrt(np.mean(np.square(v_err))):.1f} mm/s")


def speed_table(rec, frames, repeats):
    duration = frames * 3.0
    walls = {False: [], True: []}
    for _ in range(repeats):
        for decode in (False, True):
            walls[decode].append(receive(rec, decode)[1])
    measure, both = np.median(walls[False]), np.median(walls[True])
    cfg = get_preset("jmse2024")
    symbols = frames * (cfg.n_pilot + cfg.n_data)
    print(f"\n2. speed on the {duration / 60:.0f}-minute recording, one process, median of {repeats}")
    print(f"{'stage':<36} {'wall s':>8} {'x real time':>12} {'goal':>6}")
    print(f"{'measure only':<36} {measure:>8.2f} {duration / measure:>12.1f}")
    print(f"{'measure + decode (DFE, turbo if CRC fails)':<36} {both:>8.2f} {duration / both:>12.1f} {'>= 20':>6}")
    print(f"{'decoding alone':<36} {both - measure:>8.2f} {duration / (both - measure):>12.1f}")
    print(f"decoded symbols per second (decoding alone): {symbols / (both - measure):,.0f}")


def turbo_table(frames, snrs):
    cfg = get_preset("jmse2024")
    scenario = tomllib.loads(SCENARIO.read_text())
    t0 = time.perf_counter()
    pts = ber_sweep(cfg, scenario, snrs, frames=frames, period_s=3.0, seed=7, passes=3, base_dir=SCENARIO.parent)
    wall = time.perf_counter() - t0
    print(f"\n3. FER against SNR on the same channel, {frames} frames per point ({wall:.0f} s)")
    print(f"{'SNR dB':>7} {'FER DFE':>8} {'FER turbo':>10} {'raw BER':>9} {'EQ SNR':>7}")
    for p in pts:
        print(f"{p.snr_db:>7.1f} {p.fer_dfe:>8.3f} {p.fer:>10.3f} {p.raw_ber:>9.2e} {p.mean_eq_snr_db:>7.1f}")
    a = snr_at_fer(snrs, [p.fer_dfe for p in pts])
    b = snr_at_fer(snrs, [p.fer for p in pts])
    print(f"SNR at FER 10 %: DFE {a:.2f} dB, DFE + turbo {b:.2f} dB: turbo gain {a - b:.2f} dB")


def awgn_table(frames, snrs_by_modulation):
    print(f"\n4. AWGN through the whole receiver (detection, timing, Doppler, DFE), {frames} frames per point")
    print(f"{'modulation':<10} {'SNR dB':>7} {'raw BER':>9} {'theory':>9} {'FER':>6}")
    for mod, snrs in snrs_by_modulation.items():
        cfg = get_preset("jmse2024")
        if mod != cfg.modulation:
            from seamodem.config import FrameConfig

            cfg = FrameConfig.from_dict({"modulation": mod}, base=cfg)
        pts = ber_sweep(cfg, AWGN_SCENARIO, snrs, frames=frames, seed=3, passes=1)
        for p in pts:
            print(f"{mod:<10} {p.snr_db:>7.1f} {p.raw_ber:>9.2e} {theory_ber(p.snr_db, cfg):>9.2e} {p.fer:>6.3f}")
        ber = np.array([p.raw_ber for p in pts])
        # SNR where measured (log-interpolated) and theory reach 1e-3
        measured = _level(snrs, ber, 1e-3)
        theory = brentq(lambda s: math.log10(theory_ber(s, cfg)) + 3, -5, 20)
        print(f"{mod:<10} BER 1e-3 at {measured:.2f} dB, theory {theory:.2f} dB: loss {measured - theory:.2f} dB (goal <= 0.5)")


def _level(snrs, ber, target):
    """SNR where log10(BER) crosses log10(target), linear in dB between points."""
    y = np.log10(np.maximum(ber, 1e-12))
    for i in range(len(y) - 1):
        if y[i] >= math.log10(target) > y[i + 1]:
            a = (y[i] - math.log10(target)) / (y[i] - y[i + 1])
            return snrs[i] + a * (snrs[i + 1] - snrs[i])
    return math.nan


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sweep-frames", type=int, default=30)
    parser.add_argument("--skip-sweeps", action="store_true")
    parser.add_argument("--only-awgn", action="store_true", help="run table 4 alone")
    args = parser.parse_args()
    if args.only_awgn:
        awgn_table(args.sweep_frames, {"bpsk": [4.0, 5.0, 6.0, 7.0, 8.0], "qpsk": [7.0, 8.0, 9.0, 10.0, 11.0]})
        return
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        rec = make_recording(Path(tmp), args.frames)
        print(f"recording made in {time.perf_counter() - t0:.0f} s (tx + channel)")
        receive(rec, True)  # compile the numba kernels once before timing
        recs, _, side = receive(rec, True)
        success_table(recs, side, args.frames)
        speed_table(rec, args.frames, args.repeats)
    if not args.skip_sweeps:
        turbo_table(args.sweep_frames, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        awgn_table(args.sweep_frames, {"bpsk": [4.0, 5.0, 6.0, 7.0, 8.0], "qpsk": [7.0, 8.0, 9.0, 10.0, 11.0]})


if __name__ == "__main__":
    main()
