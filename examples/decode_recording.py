"""Use 3: decode a recording — measurements and payloads of every frame, compared with the channel's truth.

    python examples/decode_recording.py [OUTDIR]                  (default: decode_out/)
    python examples/decode_recording.py OUTDIR RECORDING.wav      (your own recording, with its sidecar beside it)

Without a recording, the script first makes one: 6 jmse2024 frames (``seamodem tx``)
through ``examples/scenarios/straight_line.toml`` (``seamodem channel``: a vehicle
passing a beacon at 1.5 m/s in 30 m of water, surface and bottom echoes, 15 dB).
Then, as ``seamodem rx RECORDING.wav -o OUTDIR/measurements.csv`` does, it measures
and decodes every frame and writes the measurement records.
"""

import sys
from pathlib import Path

import numpy as np

from seamodem import BeaconSchedule, Emissions, FrameConfig, ReceiverSettings, get_preset, load_scenario
from seamodem import receive_file, write_beacon
from seamodem import read_measurements, simulate_file, write_measurements
from seamodem.errors import InputFileError, SeamodemError
from seamodem.io.sidecar import read_sidecar, sidecar_path, sidecar_payloads

SCENARIO = Path(__file__).resolve().parent / "scenarios" / "straight_line.toml"


def make_recording(out: Path) -> Path:
    write_beacon(out / "beacon.wav", get_preset("jmse2024"), BeaconSchedule(count=6, period_s=2.0),
                 command="examples/decode_recording.py")
    simulate_file(out / "beacon.wav", load_scenario(SCENARIO), out / "received.wav",
                  command="examples/decode_recording.py")
    return out / "received.wav"


def main(out: Path, recording: Path | None) -> None:
    if recording is not None and not sidecar_path(recording).is_file():
        # checked before anything is written: a bad input leaves no partial output behind
        if not recording.is_file():
            raise InputFileError(f"recording not found: {recording}")
        raise InputFileError(f"{recording} has no sidecar {sidecar_path(recording).name} beside it (this script needs "
                             "the emission times and payloads a sidecar holds; for a recording without one: "
                             "seamodem rx REC.wav --emit-start T0 --emit-period T -o MEAS.csv)")
    out.mkdir(parents=True, exist_ok=True)
    recording = recording or make_recording(out)
    sidecar = read_sidecar(sidecar_path(recording))  # configuration, emission times, payloads sent, truth
    config = FrameConfig.from_dict(sidecar["config"])
    emissions = Emissions(times_s=np.array([f["t_emit_s"] for f in sidecar["frames"]]))
    sent = sidecar_payloads(sidecar)  # the payload of each frame, to count bit errors
    c = float(sidecar.get("channel", {}).get("sound_speed_mps", 1500.0))
    settings = ReceiverSettings(sound_speed_mps=c, decode=True)
    records = receive_file(recording, config, emissions=emissions, settings=settings, payloads=sent, progress=False)
    n = write_measurements(out / "measurements.csv", records,
                           {"created_by": "examples/decode_recording.py", "recording": str(recording),
                            "sound_speed_mps": c, "config": config.to_dict()})
    # read the file back, as an estimator would
    records, header = read_measurements(out / "measurements.csv")
    truth = {t["frame_index"]: t for t in sidecar.get("truth", [])}
    print(f"{recording}: {n} of {len(sent)} frames measured -> {out / 'measurements.csv'}")
    print(" k  range m    err mm  v_r m/s  err mm/s  SNR dB  CRC  payload")
    for r in records:
        t = truth.get(r.frame_index)
        err_r = f"{1e3 * (r.range_m - t['range_m']):+7.1f}" if t else "      -"
        err_v = f"{1e3 * (r.v_r_mps - t['v_r_mps']):+8.1f}" if t else "       -"
        print(f"{r.frame_index:2d} {r.range_m:8.3f} {err_r} {r.v_r_mps:+8.3f} {err_v} {r.snr_db:7.1f}  "
              f"{'ok ' if r.crc_ok else 'BAD'}  {r.payload_text!r}")


if __name__ == "__main__":
    try:
        main(Path(sys.argv[1] if len(sys.argv) > 1 else "decode_out"),
             Path(sys.argv[2]) if len(sys.argv) > 2 else None)
    except SeamodemError as exc:  # a missing, unreadable or inconsistent recording or sidecar: one line, exit 2
        print(f"decode_recording.py: error: {exc}", file=sys.stderr)
        sys.exit(2)
