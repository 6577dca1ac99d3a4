"""Use 1: write test waveforms — a beacon recording per preset, its sidecar, a figure, an editable configuration.

    python examples/write_waveforms.py [OUTDIR]        (default: waveforms_out/)

The same as ``seamodem tx`` / ``seamodem plot`` / ``seamodem config``, from Python.
The sidecar (JSON beside each WAV) holds everything needed to rebuild the
recording sample for sample; the script checks that it does.
"""

import sys
from pathlib import Path

import numpy as np
import soundfile

from seamodem import BeaconSchedule, get_preset, payloads_from_text, rebuild_from_sidecar, save_config, write_beacon
from seamodem.plots import plot_recording


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    # The paper's frame (jmse2024: 28 kHz BPSK, 20 kHz tone, 300 ms) and a QPSK variant of the pool preset.
    configs = {
        "jmse2024": get_preset("jmse2024"),
        "oceans2021_qpsk": get_preset("oceans2021").replace(modulation="qpsk"),
    }
    for name, config in configs.items():
        schedule = BeaconSchedule(count=3, period_s=1.0)
        payloads = payloads_from_text(f"{name} test frame {{index}}", schedule.count)
        wav = out / f"{name}.wav"
        sidecar = write_beacon(wav, config, schedule, payloads, command="examples/write_waveforms.py")
        x, fs = soundfile.read(wav, dtype="float64")
        # a float WAV stores the rebuilt samples to float32 precision
        assert np.max(np.abs(x - rebuild_from_sidecar(sidecar))) < 1e-6
        plot_recording(x, fs, out / f"{name}.png", config=config, title=name, duration_s=1.5)
        save_config(config, out / f"{name}.toml")  # edit it, then: seamodem tx --config NAME.toml
        print(f"{name}: {schedule.count} frames of {config.frame_duration_s * 1e3:.1f} ms at {fs} Hz, "
              f"{config.capacity_bytes} payload bytes each -> {wav}, {wav.with_suffix('.json')}, "
              f"{name}.png, {name}.toml")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "waveforms_out"))
