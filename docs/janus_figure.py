"""Draw docs/images/janus_packet.png: the spectrogram of a JANUS packet with its hops.

    python docs/janus_figure.py            # writes docs/images/janus_packet.png

The packet is ``seamodem tx --janus --packet-cargo "Hello JANUS"`` at 48 kHz (the reference's
pset1_48k_cargo_hello.wav sample for sample); one spectrum per 6.25 ms chip over its preamble and
the start of its base packet; the dots are the tones the hopping pattern and the chips' bits
predict.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "images" / "janus_packet.png"


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import spectrogram

    from seamodem.transmit.janus import JanusPacket, get_parameter_set, janus_waveform, packet_tones

    fs = 48000
    pset = get_parameter_set(1)
    packet = JanusPacket.class16_app0(cargo=b"Hello JANUS")
    w = janus_waveform(packet, pset, fs)
    n_chip = int(round(pset.chip_s * fs))
    first = w.preamble_start - 2 * n_chip
    shown_chips = 72  # the preamble and the first 40 chips of the base packet
    seg = w.x_pb[first : w.preamble_start + shown_chips * n_chip]
    # one spectrum per chip, windows on the chips' bounds: each chip is one column
    f, t, s = spectrogram(seg, fs=fs, window="boxcar", nperseg=n_chip, noverlap=0, nfft=8 * n_chip)
    t = t + first / fs
    band = (f > 9000) & (f < 14000)
    level = 10 * np.log10(s[band] / s[band].max() + 1e-12)
    fig, ax = plt.subplots(figsize=(10, 4), constrained_layout=True)
    ax.pcolormesh(t, f[band] / 1e3, level, shading="nearest", cmap="magma", vmin=-40, vmax=0)
    tones = packet_tones(packet, pset)[:shown_chips]
    offsets = np.asarray(pset.tone_offsets_hz())
    t_chip = w.preamble_start / fs + (np.arange(tones.size) + 0.5) * pset.chip_s
    ax.plot(t_chip, (pset.fc_hz + offsets[tones]) / 1e3, "c.", ms=4, label="tone of each chip (hop + bit)")
    t0 = w.preamble_start / fs
    ax.axvline(t0 + 32 * pset.chip_s, color="w", lw=0.8)
    ax.text(t0 + 0.003, 13.75, "preamble: 32 chips, 0xAEC7CD20", color="w", fontsize=8)
    ax.text(t0 + 32 * pset.chip_s + 0.003, 13.75, "base packet (first 40 of 144 chips)", color="w", fontsize=8)
    ax.legend(loc="lower right", fontsize=8)
    ax.set(xlabel="time [s]", ylabel="frequency [kHz]",
           title="JANUS packet, parameter set 1 (9.44-13.44 kHz, 160 Hz spacing, 6.25 ms chips), 48 kHz")
    OUT.parent.mkdir(exist_ok=True)
    fig.savefig(OUT, dpi=110)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
