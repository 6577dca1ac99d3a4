"""Reference packets as sent at sea (issue 25 item 4), on randomized draws: grouping, scale, arrivals, σ.

Run: ``python benchmarks/bench_packets.py`` (a fresh seed, printed; ``--seed`` for a given one,
``--draws N``, ``--out FILE``). About 0.5 s per draw on one core here.

Each draw is the issue's packet: 4 untapered 19–29 kHz 50 ms LFM up-chirps 0.25 s apart and 3 more
8.27 s after the first, 256 kHz, a receiver closing on a fixed source at v ~ U(0.8, 1.2) m/s from r0 ~
U(50, 500) m, a surface echo U(0.2, 0.5) ms behind with gain U(−0.8, −0.4) and 0.97 of the direct path's
speed, white noise at an in-band SNR of 10 dB. The signals are built independently of seamodem
(``scipy.signal.chirp`` at analytic, time-scaled instants: ``tests/reference/independent.py``); the truth
is the closed form t_a = (t_e + r0/c)/(1 + v/c). Goals: every packet formed (4 preambles, 3
postambles), its scale within 1e-6 of v/c, every arrival within 5 µs. The σ's are scored as the
corpus scores them: within 3σ, worst |error|/σ, RMS(error/σ) (1 when calibrated).
"""

from __future__ import annotations

import argparse
import math
import secrets
import sys
import time
import warnings
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "reference"))

C = 1500.0
FS = 256000.0
T_EMIT0 = 0.3


def one_draw(rng: np.random.Generator) -> dict:
    """One packet received, grouped and measured: its truth and the receiver's figures."""
    from independent import add_noise, chirp_ping, received

    from seamodem.receive.reference import ReferenceReceiver, pair_up, to_record
    from seamodem.receive.reference.packets import PacketWarning
    from seamodem.receive.settings import Emissions, ReferenceSettings
    from seamodem.transmit.reference import ReferenceWaveform

    packet = ReferenceWaveform(kind="lfm", f_low_hz=19e3, f_high_hz=29e3, duration_s=0.05, window="rect",
                               train_count=4, train_spacing_s=0.25, postamble_s=8.27, postamble_count=3)
    v, r0 = rng.uniform(0.8, 1.2), rng.uniform(50.0, 500.0)
    echo_delay, echo_gain = rng.uniform(2e-4, 5e-4), rng.uniform(-0.8, -0.4)
    ping = partial(chirp_ping, f0=19e3, f1=29e3, duration_s=0.05, method="linear", taper=0.0)
    emit = T_EMIT0 + np.array([o for o, _, _ in packet.packet()])
    arrivals = (emit + r0 / C) / (1 + v / C)
    duration = arrivals[-1] + 0.5
    x = received(ping, fs=FS, duration_s=duration, arrivals_s=arrivals, v_mps=v, ping_duration_s=0.05)
    x += echo_gain * received(ping, fs=FS, duration_s=duration, arrivals_s=arrivals + echo_delay,
                              v_mps=0.97 * v, ping_duration_s=0.05)
    x = add_noise(x, fs=FS, ping=ping, band_hz=(19e3, 29e3), ping_duration_s=0.05, snr_db=10.0, rng=rng)
    rx = ReferenceReceiver([packet], FS, settings=ReferenceSettings(sound_speed_mps=C, v_max_mps=3.0))
    found = list(rx.run([x[i : i + (1 << 17)].reshape(-1, 1) for i in range(0, len(x), 1 << 17)]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PacketWarning)
        pair_up(found, eps_max=3.0 / C, sound_speed_mps=C)
    found.sort(key=lambda f: f.fit.t_arrival_s)
    formed = ([f.role for f in found] == ["preamble"] * 4 + ["postamble"] * 3
              and [f.train_position for f in found] == [0, 1, 2, 3, 0, 1, 2]
              and not any(issubclass(w.category, PacketWarning) for w in caught))
    out = {"v": v, "r0": r0, "echo_delay_ms": echo_delay * 1e3, "echo_gain": echo_gain, "formed": formed,
           "detected": len(found)}
    if not formed:
        return out
    recs = [to_record(f, Emissions(times_s=np.array([T_EMIT0])), sound_speed_mps=C) for f in found]
    t = np.array([r.t_arrival_s for r in recs])
    out.update(scale_err=abs(found[0].eps_pair - v / C),
               t_err=t - arrivals, sigma_t=np.array([r.sigma_range_m / C for r in recs]),
               v_err=np.array([r.v_r_mps for r in recs]) - v, sigma_v=np.array([r.sigma_v_r_mps for r in recs]))
    return out


def report(draws: list[dict], seed: int, seconds: float) -> str:
    formed = [d for d in draws if d["formed"]]
    lines = [f"# bench_packets: {len(draws)} draws, seed {seed} ({seconds:.0f} s)", "",
             "The issue's packet (4 + 3 untapered 19-29 kHz 50 ms LFM chirps, 8.27 s, 256 kHz), closing at "
             "U(0.8, 1.2) m/s from U(50, 500) m, a surface echo U(0.2, 0.5) ms behind with gain U(-0.8, -0.4), "
             "10 dB; signals built independently of seamodem (tests/reference/independent.py).", ""]
    scale = np.array([d["scale_err"] for d in formed])
    t_err = np.concatenate([d["t_err"] for d in formed]) if formed else np.zeros(0)
    z_t = np.concatenate([d["t_err"] / d["sigma_t"] for d in formed]) if formed else np.zeros(0)
    z_v = np.concatenate([d["v_err"] / d["sigma_v"] for d in formed]) if formed else np.zeros(0)

    def met(ok: bool) -> str:
        return "met" if ok else "NOT met"

    n_ok = len(formed) == len(draws)
    worst_scale = float(scale.max()) if scale.size else math.nan
    worst_t = float(np.abs(t_err).max() * 1e6) if t_err.size else math.nan
    lines += ["| figure | measured | goal | |", "|---|---|---|---|",
              f"| packets formed (4 preambles, 3 postambles, no warning) | {len(formed)} of {len(draws)} | all "
              f"| {met(n_ok)} |",
              f"| scale error abs(eps - v/c), median / worst | {np.median(scale):.2e} / {worst_scale:.2e} | 1e-6 "
              f"| {met(worst_scale < 1e-6)} |",
              f"| arrival error, RMS / worst [us] | {np.sqrt(np.mean(t_err**2)) * 1e6:.2f} / {worst_t:.2f} | 5 "
              f"| {met(worst_t < 5)} |"]
    for name, z in (("arrival", z_t), ("v_r", z_v)):
        if z.size:
            lines.append(f"| {name} sigma: within 3 sigma / worst abs(err)/sigma / RMS(err/sigma) | "
                         f"{np.mean(np.abs(z) <= 3):.3f} / {np.abs(z).max():.1f} / {np.sqrt(np.mean(z**2)):.2f} "
                         f"| >= 0.97 / <= 6 / 0.67-1.43 | "
                         f"{met(np.mean(np.abs(z) <= 3) >= 0.97 and np.abs(z).max() <= 6)} |")
    missed = [d for d in draws if not d["formed"]]
    if missed:
        lines += ["", "Draws whose packet was not formed (v, r0, echo delay, gain, chirps detected):"]
        lines += [f"- {d['v']:.3f} m/s, {d['r0']:.0f} m, {d['echo_delay_ms']:.2f} ms, {d['echo_gain']:.2f}, "
                  f"{d['detected']}" for d in missed]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=30)
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--out", type=Path, default=None, help="also write the report here")
    args = ap.parse_args(argv)
    if args.draws < 1:
        ap.error("--draws: at least 1")
    seed = secrets.randbelow(10**7) if args.seed is None else args.seed
    rng = np.random.default_rng(seed)
    from seamodem._progress import progress_bar

    start = time.perf_counter()
    draws = []
    with progress_bar(total=args.draws, desc="packets") as bar:
        for _ in range(args.draws):
            draws.append(one_draw(rng))
            bar.update()
    text = report(draws, seed, time.perf_counter() - start)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
