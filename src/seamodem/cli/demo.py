"""``seamodem demo``: the mission demo — a vehicle positioned from the very frames it decodes."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import SeamodemError


def add_parser(sub) -> None:
    p = sub.add_parser(
        "demo",
        help="the whole chain in one command: beacon, channel, receiver, decoder, EKF (offline, < 1 min)",
        description=(
            "A beacon emits a jmse2024 frame every T_com; a vehicle runs a short survey; the channel simulator "
            "makes the hydrophone recording along its track (geometry-driven Doppler, surface and bottom echoes, "
            "white noise); the receiver measures and decodes every frame; the EKF of paper 000 (range + v_r) and "
            "its range-only baseline (ROSB) position the vehicle from those measurements and a simulated IMU. "
            "Then the same mission with emulated measurements (geometry + the noise the receiver showed). Prints "
            "a summary and writes DIR/summary.json, DIR/demo_config.json, DIR/measurements.csv, DIR/imu.csv, "
            "DIR/truth.csv, DIR/track_proposed.csv, DIR/track_rosb.csv and the figures DIR/map.png, "
            "DIR/errors.png, DIR/psd.png, DIR/constellation.png."
        ),
    )
    p.add_argument("-o", "--output", default="demo_out", metavar="DIR",
                   help="output folder, created if missing (default demo_out)")
    p.add_argument("--tcom", type=float, default=3.0, metavar="S", help="time between frames [s] (default 3)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="mission length [s] (default: the whole survey, 151 s)")
    p.add_argument("--snr", type=float, default=12.0, metavar="DB",
                   help="in-band SNR of the white noise, mean over frames [dB] (default 12)")
    p.add_argument("--seed", type=int, default=1, help="seed of the IMU, channel and emulation noise (default 1)")
    p.add_argument("--keep-audio", action="store_true",
                   help="keep beacon.wav, received.wav and their sidecars in DIR (about 90 MB)")
    p.add_argument("--array", metavar="SPEC", nargs="?", const="tetra:0.08",
                   help="also record the beacon with a hydrophone array on the vehicle (tetra[:APERTURE_M], circleN, "
                        "lineN or a TOML/JSON file, as seamodem channel --array; --array alone: tetra:0.08, the array of docs/array.md) and compare it with one hydrophone: "
                        "frames, FER, bearing error, one-frame fix (DIR/measurements_array.csv; docs/array.md)")
    p.add_argument("--waveform", choices=("frame", "janus"), default="frame",
                   help="what the beacon emits: jmse2024 frames (default) or JANUS packets, parameter set 1, "
                        "received by the JANUS receiver (docs/janus.md; no psd.png, constellation.png or --array)")
    p.add_argument("--no-plots", dest="plots", action="store_false", help="skip the figures")
    p.add_argument("--images", metavar="DIR", help=argparse.SUPPRESS)  # docs/images/demo_map.png for the README
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..demo import DemoConfig, format_summary, run_demo

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise SeamodemError(f"output: {out} exists and is not a folder")
    if args.seed < 0:
        raise SeamodemError(f"seed: must be >= 0, got {args.seed}")
    cfg = DemoConfig(tcom_s=args.tcom, duration_s=args.duration, snr_db=args.snr, seed=args.seed, array=args.array,
                     waveform=args.waveform)
    if not args.quiet:
        print(f"seamodem demo: {cfg.frame_count()} frames, one every {cfg.tcom_s:g} s, "
              f"{cfg.mission_s():.0f} s mission; writing {out}/ ...", flush=True)
    result = run_demo(cfg, out, keep_audio=args.keep_audio, plots=args.plots, images_dir=args.images,
                      progress=False if args.quiet else None)  # bars on a terminal only
    if not args.quiet:
        print(format_summary(result.summary))
        print(f"wrote {', '.join(result.files)} in {out}/")
    return 0
