"""BER and frame-error rate on AWGN through the whole waveform chain, beside the theory.

Run: python benchmarks/bench_ber.py [--frames 60] [--plot benchmarks/results/ber_awgn.png]

Each frame is built in passband (jmse2024, tone included), white noise is added at
a stated in-band SNR (SPEC §1: data power / noise power in [f0 − B/2, f0 + B/2]),
then pb2bb → matched filter at the known symbol times (timing and Doppler are the
receiver's job, benchmarked elsewhere) → hard decisions (uncoded) or soft demapping
+ Viterbi + CRC (coded). Eb/N0 = SNR·(1 + α)/log2(M).

Target (issue 5): uncoded BPSK and QPSK within 0.5 dB of Q(√(2Eb/N0)) at BER 1e-3.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.interpolate import interp1d
from scipy.special import erfc, erfcinv

from seamodem import build_frame, frame_symbol_times, frame_waveform, get_preset, pb2bb, srrc_matrix
from seamodem.decode import decode_payload
from seamodem.transmit.modulation import symbols_to_bits


def q(x):
    return 0.5 * erfc(x / np.sqrt(2))


class Chain:
    def __init__(self, cfg):
        self.cfg = cfg
        n = len(frame_waveform(build_frame(cfg, b"")))
        self.G = srrc_matrix(np.arange(n) / cfg.sample_rate_hz, frame_symbol_times(cfg),
                             symbol_period_s=cfg.symbol_period_s, rolloff=cfg.rolloff,
                             span_symbols=cfg.srrc_span_symbols).conj().T.tocsr()
        self.p_data = 1 - cfg.tone_power_share

    def symbols(self, frame, snr_db, rng):
        cfg = self.cfg
        s = frame_waveform(frame)
        n0 = self.p_data / (10 ** (snr_db / 10) * cfg.bandwidth_hz)  # one-sided N0 so that N0·B = P_d/SNR
        r = s + rng.normal(0, np.sqrt(n0 * cfg.sample_rate_hz / 2), s.size)
        x = pb2bb(r, cfg.sample_rate_hz, cfg.carrier_hz, passband_hz=cfg.bandwidth_hz / 2,
                  stopband_hz=abs(cfg.tone_hz - cfg.carrier_hz) - 200)
        return (self.G @ x) / cfg.samples_per_symbol / np.sqrt(2 * self.p_data)


def uncoded_curve(mod, ebn0_db, frames, rng):
    cfg = get_preset("jmse2024").replace(modulation=mod, fec="none")
    chain = Chain(cfg)
    bps = cfg.bits_per_symbol
    out = []
    for e in ebn0_db:
        snr_db = e + 10 * np.log10(bps / (1 + cfg.rolloff))
        errors = bits = 0
        for _ in range(frames):
            fr = build_frame(cfg, bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8)))
            z = chain.symbols(fr, snr_db, rng)[cfg.n_pilot :]
            errors += np.count_nonzero(symbols_to_bits(z, mod) != symbols_to_bits(fr.data_symbols, mod))
            bits += fr.data_symbols.size * bps
        out.append(errors / bits)
    return np.array(out)


def coded_curve(ebn0_db, frames, rng):
    cfg = get_preset("jmse2024")
    chain = Chain(cfg)
    rate = cfg.n_info_bits / cfg.n_coded_bits
    out = []
    for e in ebn0_db:
        snr_db = e + 10 * np.log10(rate * cfg.bits_per_symbol / (1 + cfg.rolloff))
        failures = 0
        for _ in range(frames):
            payload = bytes(rng.integers(0, 256, cfg.capacity_bytes, dtype=np.uint8))
            z = chain.symbols(build_frame(cfg, payload), snr_db, rng)[cfg.n_pilot :]
            noise_var = 1 / (10 ** (snr_db / 10) * (1 + cfg.rolloff))  # Es/N0 known here (genie)
            res = decode_payload(z, noise_var, cfg)
            failures += not (res.crc_ok and res.payload == payload)
        out.append(failures / frames)
    return np.array(out)


def ebn0_at(ber_target, ebn0_db, ber):
    good = ber > 0
    f = interp1d(np.log10(ber[good]), ebn0_db[good])
    return float(f(np.log10(ber_target)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames per point (BPSK: 1706 bits each)")
    parser.add_argument("--plot", default="benchmarks/results/ber_awgn.png")
    parser.add_argument("--seed", type=int, default=2026)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    ebn0 = np.array([4.0, 5.0, 6.0, 7.0, 8.0])
    theory = q(np.sqrt(2 * 10 ** (ebn0 / 10)))
    theory_1e3 = 20 * np.log10(erfcinv(2e-3))  # Eb/N0 where Q(√(2x)) = ½erfc(√x) = 1e-3: 6.79 dB
    results = {m: uncoded_curve(m, ebn0, args.frames, rng) for m in ("bpsk", "qpsk")}
    print("Uncoded BER, jmse2024 waveform, AWGN (in-band SNR = Eb/N0 + 10log10(log2M/(1+alpha)))")
    print(f"{'Eb/N0 [dB]':>10} {'theory':>10} {'BPSK':>10} {'QPSK':>10}")
    for i, e in enumerate(ebn0):
        print(f"{e:>10.1f} {theory[i]:>10.2e} {results['bpsk'][i]:>10.2e} {results['qpsk'][i]:>10.2e}")
    print(f"\nEb/N0 at BER 1e-3: theory {theory_1e3:.2f} dB")
    for m, ber in results.items():
        at = ebn0_at(1e-3, ebn0, ber)
        print(f"  {m}: {at:.2f} dB, loss {at - theory_1e3:+.2f} dB (target within 0.5 dB)")

    coded_ebn0 = np.array([1.0, 2.0, 3.0, 4.0])
    fer = coded_curve(coded_ebn0, max(20, args.frames // 2), rng)
    print("\nCoded frame-error rate (K7 r1/2 + CRC-16, soft Viterbi, BPSK)")
    print(f"{'Eb/N0 [dB]':>10} {'FER':>10}")
    for e, f in zip(coded_ebn0, fer):
        print(f"{e:>10.1f} {f:>10.3f}")

    if args.plot:
        from seamodem.plots import pyplot, save_figure

        plt = pyplot()

        fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
        fine = np.linspace(0, 10, 200)
        ax.semilogy(fine, q(np.sqrt(2 * 10 ** (fine / 10))), "k-", lw=1, label="Q(√(2Eb/N0))")
        ax.semilogy(ebn0, results["bpsk"], "o", label="BPSK, measured")
        ax.semilogy(ebn0, results["qpsk"], "s", mfc="none", label="QPSK, measured")
        ax.semilogy(coded_ebn0, np.maximum(fer, 1e-5), "^-", label="coded FER (K7 r1/2, CRC-16)")
        ax.set(xlabel="Eb/N0 [dB]", ylabel="BER / FER", ylim=(1e-5, 1), title="jmse2024 frame on AWGN")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
        save_figure(fig, args.plot)
        print(f"\nwrote {args.plot}")


if __name__ == "__main__":
    main()
