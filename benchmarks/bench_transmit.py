"""Transmitter benchmark: speed of a 10-minute beacon WAV, and the frame's signal quality.

Run: python benchmarks/bench_transmit.py [--repeats 3]

Prints one table: each figure, its target (or bound), and the ratio. Speed is the
median of the repeats, measured in this one run (the machine is shared).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from seamodem import BeaconSchedule, build_frame, frame_symbol_times, frame_waveform, get_preset, pb2bb, srrc_matrix
from seamodem.transmit.beacon import write_beacon
from seamodem.transmit.pulse import srrc_truncation_energy


def time_beacon(repeats: int) -> tuple[float, float]:
    cfg = get_preset("jmse2024")
    schedule = BeaconSchedule(count=200, period_s=3.0)
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            t0 = time.perf_counter()
            write_beacon(Path(tmp) / "b.wav", cfg, schedule, progress=False)
            times.append(time.perf_counter() - t0)
        tracemalloc.start()
        write_beacon(Path(tmp) / "b.wav", cfg, schedule, progress=False)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return statistics.median(times), peak / 2**20


def loopback_evm_db(name: str) -> float:
    cfg = get_preset(name)
    fr = build_frame(cfg, b"benchmark")
    s = frame_waveform(fr)
    fs = cfg.sample_rate_hz
    x_bb = pb2bb(s, fs, cfg.carrier_hz, passband_hz=cfg.bandwidth_hz / 2,
                 stopband_hz=abs(cfg.tone_hz - cfg.carrier_hz) - 200)
    G = srrc_matrix(np.arange(s.size) / fs, frame_symbol_times(cfg), symbol_period_s=cfg.symbol_period_s,
                    rolloff=cfg.rolloff, span_symbols=cfg.srrc_span_symbols)
    z = (G.conj().T @ x_bb) / cfg.samples_per_symbol / np.sqrt(2 * (1 - cfg.tone_power_share))
    return 10 * np.log10(np.mean(np.abs(z - fr.symbols) ** 2))


def spectrum_figures() -> tuple[float, float]:
    cfg = get_preset("jmse2024").replace(tone_power_share=0.0)
    s = frame_waveform(build_frame(cfg, b"spectrum"))
    n_fft = 1 << 22
    spec = np.abs(np.fft.rfft(s, n_fft)) ** 2
    f = np.fft.rfftfreq(n_fft, 1 / cfg.sample_rate_hz)
    lo, hi = cfg.data_band_hz
    band = (f >= lo) & (f <= hi)
    far = (f < lo - 1000) | (f > hi + 1000)
    return spec[band].sum() / spec.sum(), 10 * np.log10(spec[far].mean() / spec[band].mean())


def tone_error_hz() -> float:
    cfg = get_preset("jmse2024")
    s = frame_waveform(build_frame(cfg, b"tone"))
    n = np.arange(s.size)

    def neg_power(f):
        return -np.abs(np.sum(s * np.exp(-2j * np.pi * f * n / cfg.sample_rate_hz)))

    f_hat = minimize_scalar(neg_power, bounds=(cfg.tone_hz - 1, cfg.tone_hz + 1), method="bounded",
                            options={"xatol": 1e-7}).x
    return f_hat - cfg.tone_hz


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    wall, peak_mib = time_beacon(args.repeats)
    evm_j, evm_o = loopback_evm_db("jmse2024"), loopback_evm_db("oceans2021")
    in_band, oob = spectrum_figures()
    tone_err = tone_error_hz()
    e = srrc_truncation_energy(0.4, 16)
    isi_bound = 2 * np.sqrt(1 - e) / e

    rows = [
        ("10-min beacon WAV (200 frames, T_com 3 s), wall [s]", f"{wall:.2f}", "a few s", f"{600 / wall:.0f}x real time"),
        ("  peak traced memory [MiB]", f"{peak_mib:.0f}", "bounded (blocks)", ""),
        ("loopback EVM jmse2024, 15.02 samples/symbol [dB]", f"{evm_j:.1f}", "< -40", f"{evm_j + 40:+.1f} dB margin"),
        ("loopback EVM oceans2021, 12 samples/symbol [dB]", f"{evm_o:.1f}", "< -40", f"{evm_o + 40:+.1f} dB margin"),
        ("data power in [f0 - B/2, f0 + B/2] [%]", f"{100 * in_band:.4f}", ">= 99", ""),
        ("out-of-band level (>1 kHz outside band) [dB]", f"{oob:.1f}", "stated", ""),
        ("tone frequency error [mHz]", f"{1e3 * tone_err:.4f}", "< 10", f"{abs(tone_err) / 0.01:.1e} of target"),
        ("SRRC span 32, alpha 0.4: zero-ISI error bound", f"{isi_bound:.1e}", "stated", f"{20 * np.log10(isi_bound):.0f} dB"),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"{'figure':<{width}}  {'measured':>10}  {'target':>16}  ratio / margin")
    for name, value, target, ratio in rows:
        print(f"{name:<{width}}  {value:>10}  {target:>16}  {ratio}")


if __name__ == "__main__":
    main()
