"""JANUS (issue 26): sensitivity against the reference receiver, false packets in noise, range and v_r
accuracy against the Cramér–Rao bound with the σ's calibration, and decoding speed.

Run: ``python benchmarks/bench_janus.py [--trials N] [--seed S]`` (N packets per SNR and time scale,
default 20; the seed makes fresh draws: the default is the time of day).

SNR definition: the reference's (``tests/data/janus/README.md``): white noise over 0..fs/2 at
fs = 48 kHz, signal power averaged over the packet's chips; in-band SNR over B = 4160 Hz is 7.6 dB more.

Tables:

1. Sensitivity: the 48 kHz default packet (the reference's test signal) with 0.5 s of noise before
   and after, time scales 1, 1.001 and 0.999 (v_r = 0, +1.5, −1.5 m/s), N packets of each: packets
   decoded with the right bytes, beside the reference janus-rx's own figures (8/8 to −9 dB, 4/8 at
   −12, 0/8 at −15). Wrong packets with a valid CRC are counted.
2. False packets: white noise only. (a) The receiver as run: packets returned from an hour of
   noise. (b) The protection beyond the CRC, per decoding attempt: base packets decoded at random
   starts and time scales in noise; the share that passes the CRC (1/256 expected) and the share
   that also passes the decoded path's margin test (the false-accept rate once a candidate is decoded).
3. Range and v_r: random delay and v_r ∈ U(−3, 3) m/s, band-limited time scaling
   (channel.resample.interpolate), 4 SNRs: RMSE of range (c = 1500 m/s) and v_r beside the CRB of
   the whole packet (known signal, unknown phase and amplitude: Fisher information of (θ, τ, ε)
   computed here from the passband waveform's derivatives), median reported σ, share of
   |error| ≤ 3σ and RMS of error/σ.
4. Harder channels, −6 dB over 0..fs/2, v_r ~ U(−2, 2) m/s: clicks (40 per 2 s, 30× the signal's
   rms, 1 ms each), and one echo at −6 dB with 5 cm/s more closing speed, 0.2 ms (unresolved, the
   shallow-water case), 1 ms and 5 ms late. Truth is the direct path. Decoded share, RMSE, median σ
   and share within 3σ of range and v_r.
6. Through the project's channel simulator (``seamodem tx --janus`` → ``seamodem channel`` →
   ``seamodem rx --janus``), each of examples/scenarios/*.toml with its seed drawn: straight_line
   (30 m of water, surface echo ~0.3 ms after the direct path with the opposite sign),
   shallow_water_fading (12 m, four paths, Rician fading echoes, ambient noise, clock offset and
   2 ppm rate error), doppler_profile, decode_multipath. Truth from the simulator's sidecar: the
   direct path as measured on the receiver's clock.
5. Speed: one core (OPENBLAS_NUM_THREADS=1), CPU time of ``receive_janus`` on 60 s at 48 kHz: a
   packet every 3 s at −6 dB, and noise alone; the best of 3 runs (the machine is shared: the
   others are printed too).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import re  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.fft import irfft, rfft, rfftfreq  # noqa: E402

from seamodem.channel.resample import interpolate  # noqa: E402
from seamodem.receive.janus import (  # noqa: E402
    MIN_MARGIN,
    JanusSettings,
    decode_block,
    receive_janus,
    to_baseband,
)
from seamodem.transmit.janus import JanusPacket, crc8, get_parameter_set, janus_waveform  # noqa: E402

FS = 48000
C = 1500.0
PSET = get_parameter_set(1)


def packet_power(w) -> float:
    """Mean power of the packet over its chips (the padding excluded)."""
    n = int(round(w.n_chips * PSET.chip_s * FS))
    return float(np.mean(w.x_pb[w.preamble_start : w.preamble_start + n] ** 2))


def received(w, rng, snr_db: float, eps: float, lead_s: float = 0.5) -> tuple[np.ndarray, float]:
    """Noise, then the packet scaled by 1 + ε and delayed by a random fraction of a sample, then noise."""
    delay = lead_s + rng.uniform(0, 1 / FS)
    n_out = int((delay + len(w.x_pb) / FS / (1 + eps) + 0.5) * FS)
    pos = (1 + eps) * (np.arange(n_out) / FS - delay) * FS
    y = interpolate(w.x_pb, pos)
    sigma = np.sqrt(packet_power(w) / 10 ** (snr_db / 10))
    y += rng.normal(0.0, sigma, y.size)
    t_true = delay + w.preamble_start / FS / (1 + eps)
    return y, t_true


def sensitivity(rng, trials: int) -> None:
    w = janus_waveform(JanusPacket(), PSET, FS)
    sent = w.packet.to_bytes().hex()
    ref = {-9: "8/8", -12: "4/8", -15: "0/8", -18: "-"}
    print("\n1. Sensitivity: 48 kHz default packet, SNR over 0..fs/2, time scales 1, 1.001, 0.999")
    print(f"{'SNR dB':>7} {'in-band dB':>10} {'decoded':>12} {'share':>7} {'wrong+CRC':>9} {'reference janus-rx':>19}")
    for snr in (-9, -12, -15, -18):
        ok = wrong = total = 0
        for eps in (0.0, 1e-3, -1e-3):
            for _ in range(trials):
                y, _ = received(w, rng, snr, eps)
                recs = receive_janus(y, FS, JanusSettings(sound_speed_mps=C))
                total += 1
                ok += any(r.packet_hex == sent for r in recs)
                wrong += sum(r.packet_hex != sent for r in recs)
        print(f"{snr:>7} {snr + 7.6:>10.1f} {ok:>5}/{total:<6} {ok / total:>7.1%} {wrong:>9} {ref[snr]:>19}")


def false_packets(rng, seconds: float, attempts: int) -> None:
    print("\n2. False packets in white noise")
    chunk = 60.0
    n_chunks = max(int(seconds / chunk), 1)
    returned = 0
    settings = JanusSettings(sound_speed_mps=C)
    for _ in range(n_chunks):
        returned += len(receive_janus(rng.normal(size=int(chunk * FS)), FS, settings))
    print(f"(a) receiver as run: {returned} packets with a valid CRC in {n_chunks * chunk / 3600:.2f} h of noise")
    x_bb, fs_bb = to_baseband(rng.normal(size=int(chunk * FS)), FS, PSET)
    crc_pass = both = 0
    margins = []
    eps_max = 5 / C
    for _ in range(attempts):
        start = rng.uniform(0, len(x_bb) - 200 * 40)
        d = decode_block(x_bb, fs_bb, PSET, start, rng.uniform(-eps_max, eps_max), 32, 8)
        margins.append(d.margin)
        if crc8(d.data[:7]) == d.data[7]:
            crc_pass += 1
            both += d.margin >= MIN_MARGIN
    q = np.quantile(margins, [0.5, 0.999, 1.0])
    print(f"(b) {attempts} base-packet decodings at random starts and scales in noise: CRC passes {crc_pass} "
          f"({crc_pass / attempts:.2%}; 1/256 = 0.39 %); CRC and margin ≥ {MIN_MARGIN}: {both} "
          f"(false-accept rate per decoding {both / attempts:.2e}, < {3 / attempts:.1e} at 95 % when 0)")
    print(f"    decoded-path margin on noise: median {q[0]:.3f}, 99.9 % {q[1]:.3f}, max {q[2]:.3f}")


def fisher_crb(w, snr_db: float) -> tuple[float, float]:
    """CRB of τ [s] and ε for the whole packet in white noise at ``snr_db`` over 0..fs/2 (θ, A nuisance)."""
    x = w.x_pb
    n = x.size
    f = rfftfreq(n, 1 / FS)
    spec = rfft(x)
    dx = irfft(2j * np.pi * f * spec, n)  # ds/dt
    hx = irfft(-1j * np.sign(f) * spec, n)  # Hilbert transform: ∂/∂θ of the carrier phase
    t = (np.arange(n) - w.preamble_start) / FS
    sigma2 = packet_power(w) / 10 ** (snr_db / 10)
    d = np.vstack([hx, -dx, t * dx])
    fim = d @ d.T / sigma2
    crb = np.linalg.inv(fim)
    return float(np.sqrt(crb[1, 1])), float(np.sqrt(crb[2, 2]))


def accuracy(rng, trials: int) -> None:
    print("\n3. Range and v_r against the whole-packet CRB (v_r ~ U(-3, 3) m/s; c = 1500 m/s)")
    print(f"{'SNR dB':>7} {'n':>4} {'range RMSE mm':>13} {'CRB mm':>7} {'med σ mm':>8} {'≤3σ':>6} {'rms e/σ':>7}"
          f" | {'v_r RMSE mm/s':>13} {'CRB':>6} {'med σ':>6} {'≤3σ':>6} {'rms e/σ':>7}")
    w = janus_waveform(JanusPacket.class16_app0(station_id=3), PSET, FS)
    for snr in (-12, -6, 0, 10):
        er, ev, sr, sv = [], [], [], []
        missed = 0
        for _ in range(trials):
            v = rng.uniform(-3, 3)
            y, t_true = received(w, rng, snr, v / C, lead_s=rng.uniform(0.2, 0.4))
            recs = receive_janus(y, FS, JanusSettings(sound_speed_mps=C))
            if len(recs) != 1:
                missed += 1
                continue
            r = recs[0]
            er.append(C * (r.t_arrival_s - t_true))
            sr.append(r.sigma_range_m)
            ev.append(r.v_r_mps - v)
            sv.append(r.sigma_v_r_mps)
        er, ev, sr, sv = map(np.asarray, (er, ev, sr, sv))
        crb_t, crb_e = fisher_crb(w, snr)
        print(f"{snr:>7} {er.size:>4} {1e3 * np.sqrt(np.mean(er**2)):>13.3f} {1e3 * C * crb_t:>7.3f} "
              f"{1e3 * np.median(sr):>8.3f} {np.mean(np.abs(er) <= 3 * sr):>6.1%} {np.sqrt(np.mean((er / sr) ** 2)):>7.2f}"
              f" | {1e3 * np.sqrt(np.mean(ev**2)):>13.3f} {1e3 * C * crb_e:>6.3f} {1e3 * np.median(sv):>6.3f} "
              f"{np.mean(np.abs(ev) <= 3 * sv):>6.1%} {np.sqrt(np.mean((ev / sv) ** 2)):>7.2f}"
              + (f"  ({missed} missed)" if missed else ""))


def channels(rng, trials: int) -> None:
    print("\n4. Harder channels at -6 dB (truth: the direct path)")
    print(f"{'channel':<18} {'decoded':>9} {'range RMSE mm':>13} {'med σ':>7} {'≤3σ':>6} | {'v_r RMSE mm/s':>13} "
          f"{'med σ':>6} {'≤3σ':>6}")
    w = janus_waveform(JanusPacket.class16_app0(station_id=3), PSET, FS)
    p = packet_power(w)

    def scaled(eps, delay, n_out):
        return interpolate(w.x_pb, (1 + eps) * (np.arange(n_out) / FS - delay) * FS)

    for case, echo_s in (("clicks", None), ("echo 0.2 ms", 0.2e-3), ("echo 1 ms", 1e-3), ("echo 5 ms", 5e-3)):
        rows = []
        for _ in range(trials):
            v = rng.uniform(-2, 2)
            delay = 0.3 + rng.uniform(0, 1 / FS)
            n_out = int(2.0 * FS)
            y = scaled(v / C, delay, n_out)
            if echo_s is not None:
                y += 0.5 * scaled((v + 0.05) / C, delay + echo_s, n_out)
            y += rng.normal(0, np.sqrt(p / 10 ** (-6 / 10)), n_out)
            if echo_s is None:
                for k in (rng.uniform(0, 2.0, 40) * FS).astype(int):
                    click = 30 * np.sqrt(p) * rng.choice([-1, 1]) * np.exp(-np.arange(48) / 10)
                    y[k : k + 48] += click[: y[k : k + 48].size]
            t_true = delay + w.preamble_start / FS / (1 + v / C)
            recs = [r for r in receive_janus(y, FS) if r.station_id == 3]
            if len(recs) == 1:
                r = recs[0]
                rows.append((C * (r.t_arrival_s - t_true), r.sigma_range_m, r.v_r_mps - v, r.sigma_v_r_mps))
        a = np.asarray(rows)
        print(f"{case:<18} {len(rows):>4}/{trials:<4} {1e3 * np.sqrt(np.mean(a[:, 0] ** 2)):>13.2f} "
              f"{1e3 * np.median(a[:, 1]):>7.2f} {np.mean(np.abs(a[:, 0]) <= 3 * a[:, 1]):>6.1%} | "
              f"{1e3 * np.sqrt(np.mean(a[:, 2] ** 2)):>13.2f} {1e3 * np.median(a[:, 3]):>6.2f} "
              f"{np.mean(np.abs(a[:, 2]) <= 3 * a[:, 3]):>6.1%}")


def simulated(runs: int, rng) -> None:
    import json
    import tempfile
    from pathlib import Path

    import pandas as pd

    from seamodem.cli import main as cli

    print(f"\n6. Through the channel simulator: each example scenario, {runs} run(s) of 20 packets (seeds drawn)")
    print(f"{'scenario':<22} {'decoded':>8} {'range RMSE mm':>13} {'med σ':>7} {'≤3σ':>6} | {'v_r RMSE mm/s':>13} "
          f"{'med σ':>6} {'≤3σ':>6} {'incoherent':>10}")
    folder = Path(__file__).resolve().parents[1] / "examples" / "scenarios"
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        cli(["tx", "--janus", "--sample-rate", "96000", "--count", "20", "--period", "3", "--start", "0.5",
             "--packet-app-fields", "StationIdentifier=7", "-q", "-o", str(d / "jb.wav")])
        for name in ("straight_line", "shallow_water_fading", "doppler_profile", "decode_multipath"):
            text = (folder / f"{name}.toml").read_text()
            rows = []
            for _ in range(runs):
                seed = int(rng.integers(1 << 30))
                (d / "s.toml").write_text(re.sub(r"(?m)^seed = \d+", f"seed = {seed}", text))
                cli(["channel", str(d / "jb.wav"), "--scenario", str(d / "s.toml"), "-q", "-o", str(d / "jr.wav")])
                cli(["rx", "--janus", str(d / "jr.wav"), "-q", "-o", str(d / "jr.csv")])
                # truth on the receiver's clock (its clock offset and rate error included), direct path
                truth = pd.DataFrame(json.loads((d / "jr.json").read_text())["truth"])
                rows.append(pd.read_csv(d / "jr.csv").merge(
                    truth[["frame_index", "range_m", "v_r_mps"]], on="frame_index", suffixes=("", "_truth")))
            m = pd.concat(rows)
            er, ev = m.range_m - m.range_m_truth, m.v_r_mps - m.v_r_mps_truth
            print(f"{name:<22} {len(m):>4}/{20 * runs:<3} {1e3 * np.sqrt(np.mean(er**2)):>13.1f} "
                  f"{1e3 * np.median(m.sigma_range_m):>7.1f} {np.mean(np.abs(er) <= 3 * m.sigma_range_m):>6.1%} | "
                  f"{1e3 * np.sqrt(np.mean(ev**2)):>13.2f} {1e3 * np.median(m.sigma_v_r_mps):>6.2f} "
                  f"{np.mean(np.abs(ev) <= 3 * m.sigma_v_r_mps):>6.1%} "
                  f"{np.sum(m.v_r_source == 'whole_packet_incoherent'):>10}")


def speed(rng) -> None:
    print("\n5. Speed, one core, CPU time of receive_janus on 60 s at 48 kHz")
    w = janus_waveform(JanusPacket(), PSET, FS)
    period = 3 * FS
    x = np.zeros(60 * FS)
    for k in range(20):
        x[k * period : k * period + w.x_pb.size] = w.x_pb
    sigma = np.sqrt(packet_power(w) / 10 ** (-6 / 10))
    receive_janus(x[: 3 * FS], FS)  # compile the Viterbi kernel, warm the caches
    for label, y in (("a packet every 3 s, -6 dB", x + rng.normal(0, sigma, x.size)),
                     ("noise alone", rng.normal(0, sigma, x.size))):
        cpus = []
        for _ in range(3):
            t0 = time.process_time()
            recs = receive_janus(y, FS)
            cpus.append(time.process_time() - t0)
        cpu = min(cpus)
        print(f"{label:<28} {len(recs):>3} packets  {cpu:6.3f} s CPU  {60 / cpu:7.0f}x real time "
              f"(best of 3; the others {60 / sorted(cpus)[1]:.0f}x, {60 / max(cpus):.0f}x)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--noise-seconds", type=float, default=3600.0)
    ap.add_argument("--attempts", type=int, default=20000)
    args = ap.parse_args()
    seed = args.seed if args.seed is not None else int(time.time())
    print(f"bench_janus: seed {seed}, {args.trials} trials per SNR and time scale")
    rng = np.random.default_rng(seed)
    speed(rng)
    sensitivity(rng, args.trials)
    accuracy(rng, 3 * args.trials)
    channels(rng, 2 * args.trials)
    simulated(max(args.trials // 20, 1), rng)
    false_packets(rng, args.noise_seconds, args.attempts)


if __name__ == "__main__":
    main()
