"""One corpus recording, frame by frame: what the channel was, what the receiver fitted, and how far off.

Run: ``python benchmarks/diagnose_corpus.py FAMILY SEED`` (a recording's seed, as in the
``seed`` column of ``results/bench_corpus_frames.csv``), ``--frames N``, ``--single-path``,
``--depths`` (then also the surface image the receiver took out), ``--preset`` (the frame, as
``bench_corpus.py --preset``), ``--paths D,S,B`` (those of the paths D, S, B, SB, BS alone, with the
geometry, gains and Doppler of the full recording and its nominal SNR: which path makes a row's error or
σ). Prints, per frame: the record's
``v_r_source``, SNR, range and v_r errors against the corpus's direct-path truth with their σ and
error/σ, and the whole-frame fit's paths (delay after the first [µs], |gain| relative to it); then the
true paths of the first frame (name, delay after the direct path [µs], closing speed [m/s], gain). A
diagnosis aid for the rows the corpus report flags, not a benchmark: it times nothing and asserts
nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("family", choices=("steep", "far", "fading", "impulsive"))
    ap.add_argument("seed", type=int)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--single-path", action="store_true", help="the same recording with its echoes removed")
    ap.add_argument("--depths", action="store_true", help="give the receiver the ends' depths")
    ap.add_argument("--preset", default="jmse2024", help="the beacon's frame (as bench_corpus.py --preset)")
    ap.add_argument("--paths", help="comma-separated paths to keep, among D,S,B,SB,BS (D included), with the "
                                    "geometry, gains and Doppler of the full recording")
    args = ap.parse_args(argv)
    paths = None
    if args.paths is not None:
        import corpus

        paths = tuple(p.strip() for p in args.paths.split(",") if p.strip())
        if not set(paths) <= set(corpus.PATHS) or "D" not in paths:
            ap.error(f"--paths: among {','.join(corpus.PATHS)} with D included, got {args.paths!r}")
        if args.single_path:
            ap.error("--paths and --single-path: give one")

    import bench_corpus
    import corpus
    import seamodem.receive.frame as frame

    # the receiver's whole-frame fits, as it makes them (several per frame when a fit on decisions is
    # redone after a second decoding pass, and the two refits of frame.decisions_follow's tilt on a fit on
    # decisions): wrap the name frame.py calls
    fits: list = []
    fit_whole_frame = frame.fit_whole_frame

    def recording_fit(*a, **k):
        fit = fit_whole_frame(*a, **k)
        fits.append(fit)
        return fit

    truths: list = []
    synthesize = bench_corpus.synthesize

    def recording_synthesis(*a, **k):
        rec = synthesize(*a, **k)
        truths.append(rec.truth)
        return rec

    frame.fit_whole_frame = recording_fit
    bench_corpus.synthesize = recording_synthesis
    try:
        rows = bench_corpus.run_recording(args.family, args.seed, args.frames, echoes=not args.single_path,
                                          depths=args.depths, preset=args.preset, paths=paths)
    finally:
        frame.fit_whole_frame = fit_whole_frame
        bench_corpus.synthesize = synthesize
    sc = corpus.draw_scenario(args.family, args.seed)
    print(f"{args.family} {args.seed}: nominal in-band SNR {sc.snr_db:.1f} dB, noise {sc.noise}, "
          f"{len(fits)} whole-frame fits")
    for r in rows:
        if not r["detected"]:
            print(f"frame {r['frame']}: not detected")
            continue
        er, ev = r["range_m"] - r["range_true_m"], r["v_r_mps"] - r["v_r_true_mps"]
        print(f"frame {r['frame']} {r['v_r_source']:22s} SNR {r['snr_db']:5.1f} dB | range {er * 1e3:8.2f} mm "
              f"σ {r['sigma_range_m'] * 1e3:7.2f} ({er / r['sigma_range_m']:6.1f}σ) | v_r {ev * 1e3:8.2f} mm/s "
              f"σ {r['sigma_v_r_mps'] * 1e3:7.2f} ({ev / r['sigma_v_r_mps']:5.1f}σ) | paths {r.get('rec_n_paths')}")
    if args.depths:
        # what the receiver made of the surface image from the ends' depths, at the first detected frame's range
        from seamodem import get_preset

        first = next((r for r in rows if r["detected"]), None)
        if first is not None:
            cfg = get_preset(args.preset)
            zb, zv = float(-sc.beacon[2]), float(-sc.track["z"])
            delta = frame.merged_image_delay_s(first["range_m"], zb, zv, config=cfg, sound_speed_mps=corpus.C)
            image = frame.merged_image_bias_s(first["range_m"], zb, zv, config=cfg, sound_speed_mps=corpus.C)
            print(f"surface image from the depths ({zb:.2f} m, {zv:.2f} m): δ {delta * 1e6:.1f} µs "
                  f"(f₀δ {cfg.carrier_hz * delta:.2f} cycles), bias taken out {image.bias_s * corpus.C * 1e3:.2f} mm "
                  f"σ {image.sigma_s * corpus.C * 1e3:.2f} mm, |Re w| {image.re_w:.2f} |Im w| {image.im_w:.2f} "
                  f"(0 when resolved); the corpus's waves {sc.wave_amp_m:.2f} m / {sc.wave_period_s:.1f} s")
    print("whole-frame fits (delay after the first [µs], |gain| relative to it):")
    for fit in fits:
        d = np.asarray(fit.delays_s)
        a = np.abs(np.asarray(fit.amplitudes))
        print("  ", np.round((d - d[0]) * 1e6, 1).tolist(), np.round(a / a[0], 2).tolist())
    if truths and truths[0]:
        print("true paths of frame 0 (name, delay [µs], closing speed [m/s], gain):")
        for name, delay, v, gain in truths[0][0]["paths"]:
            print(f"   {name:3s} {delay * 1e6:9.1f} {v:7.3f} {gain:7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
