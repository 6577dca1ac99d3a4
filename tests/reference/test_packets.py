"""Reference packets as they are sent at sea (issue 25 item 4): chirp trains before and after the data.

Signals are built independently of seamodem (scipy.signal.chirp, each arrival compressed by its own 1 + v/c;
tests/reference/independent.py); the truth is the closed form of a receiver closing on a fixed source.
"""

from __future__ import annotations

import math
import warnings
from functools import partial

import numpy as np
import pytest

from seamodem.receive.reference import ReferenceReceiver, pair_up, to_record
from seamodem.receive.reference.packets import PacketWarning, group_packets
from seamodem.receive.settings import Emissions, ReferenceSettings
from seamodem.transmit.reference import ReferenceWaveform

from independent import add_noise, chirp_ping, received

C = 1500.0
FS = 256000.0
PACKET = ReferenceWaveform(kind="lfm", f_low_hz=19e3, f_high_hz=29e3, duration_s=0.05, window="rect",
                           train_count=4, train_spacing_s=0.25, postamble_s=8.27, postamble_count=3)


def _receive(x, fs=FS, v_max=3.0):
    rx = ReferenceReceiver([PACKET], fs, settings=ReferenceSettings(sound_speed_mps=C, v_max_mps=v_max))
    blocks = [x[i : i + (1 << 17)].reshape(-1, 1) for i in range(0, len(x), 1 << 17)]
    return list(rx.run(blocks))


def _packet_signal(rng, *, t_emit0, r0, v, snr_db=10.0, echo_delay_s=3e-4, echo_gain=-0.6, drop=()):
    """The packet's chirps received on a receiver closing at v from r0 (fixed source), plus a surface echo."""
    ping = partial(chirp_ping, f0=19e3, f1=29e3, duration_s=0.05, method="linear", taper=0.0)
    offsets = np.array([o for o, _, _ in PACKET.packet()])
    emit = t_emit0 + offsets
    arrivals = (emit + r0 / C) / (1 + v / C)  # t − T = (r0 − v t)/c
    keep = np.array([j not in drop for j in range(len(emit))])
    duration = arrivals[-1] + 0.5
    x = received(ping, fs=FS, duration_s=duration, arrivals_s=arrivals[keep], v_mps=v, ping_duration_s=0.05)
    x += echo_gain * received(ping, fs=FS, duration_s=duration, arrivals_s=arrivals[keep] + echo_delay_s,
                              v_mps=0.97 * v, ping_duration_s=0.05)
    x = add_noise(x, fs=FS, ping=ping, band_hz=(19e3, 29e3), ping_duration_s=0.05, snr_db=snr_db, rng=rng)
    return x, emit, arrivals


@pytest.mark.parametrize("seed, v, echo_delay_s", [(1, 1.0, 2e-4), (2, 0.9, 5e-4), (3, 1.1, 3.5e-4)])
def test_a_research_packet_forms_one_packet_at_its_scale(seed, v, echo_delay_s):
    """4 untapered 19–29 kHz 50 ms up-chirps 0.25 s apart, 3 more 8.27 s later, 256 kHz, closing at ≈ 1 m/s,
    a surface echo 0.2–0.5 ms behind, 10 dB: every chirp in one packet (4 preambles, 3 postambles), the scale
    within 1e-6 of the truth, every arrival within 5 µs (the issue's goal), each within 3σ."""
    rng = np.random.default_rng(seed)
    x, emit, arrivals = _packet_signal(rng, t_emit0=0.3, r0=120.0, v=v, echo_delay_s=echo_delay_s)
    found = _receive(x)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PacketWarning)  # a complete packet: no warning
        pair_up(found, eps_max=3.0 / C, sound_speed_mps=C)
    found.sort(key=lambda f: f.fit.t_arrival_s)
    assert [f.role for f in found] == ["preamble"] * 4 + ["postamble"] * 3
    assert [f.train_position for f in found] == [0, 1, 2, 3, 0, 1, 2]
    assert abs(found[0].eps_pair - v / C) < 1e-6  # the packet's scale
    eps = np.array([f.eps_chirp for f in found])  # at each chirp, the acceleration left free (|a| ≤ 0.3 m/s²)
    assert np.all(np.abs(eps - v / C) < 3 * np.array([f.sigma_eps_chirp for f in found]))
    recs = [to_record(f, Emissions(times_s=np.array([0.3])), sound_speed_mps=C) for f in found]
    t = np.array([r.t_arrival_s for r in recs])
    sigma_t = np.array([r.sigma_range_m / C for r in recs])
    assert np.all(np.abs(t - arrivals) < 5e-6), (t - arrivals) * 1e6
    assert np.all(np.abs(t - arrivals) < 3 * sigma_t)
    assert [r.frame_index for r in recs] == [0] * 7
    np.testing.assert_allclose([r.t_emit_s for r in recs], emit, atol=1e-12)
    assert {r.v_r_source for r in recs} == {"packet"}
    assert np.all(np.abs(np.array([r.v_r_mps for r in recs]) - v) < 3 * np.array([r.sigma_v_r_mps for r in recs]))


def test_a_missing_chirp_and_another_packet_in_between_do_not_break_it():
    """Two packets 4 s apart (so the second's preamble lies between the first's trains), the first's second
    chirp lost: both grouped right; the incomplete one is reported naming the reference."""
    rng = np.random.default_rng(7)
    x1, _, arr1 = _packet_signal(rng, t_emit0=0.3, r0=120.0, v=1.0, drop=(1,))
    x2, _, arr2 = _packet_signal(rng, t_emit0=4.3, r0=120.0, v=1.0)
    x = np.zeros(max(len(x1), len(x2)))
    x[: len(x1)] += x1
    x[: len(x2)] += x2
    found = _receive(x)
    assert len(found) == 13
    with pytest.warns(PacketWarning, match=PACKET.name):
        pair_up(found, eps_max=3.0 / C, sound_speed_mps=C)
    packets = group_packets(found, eps_max=3.0 / C)
    assert sorted(len(p) for p in packets) == [6, 7]
    for f in found:
        truth = arr1 if abs(f.fit.t_arrival_s - arr1).min() < 1e-4 else arr2
        j = int(np.argmin(abs(f.fit.t_arrival_s - truth)))
        assert (f.role, f.train_position) == [(r, p) for _, r, p in PACKET.packet()][j]
        assert abs(f.eps_pair - 1.0 / C) < 1e-6


def test_the_two_ping_reproduction_pairs():
    """Issue 25's reproduction: a single-chirp pre/postamble 8 s apart sent twice, 1 s apart: the second
    preamble lies between the first pair's pings; both pairs form (they did not: 4 lone pings)."""
    ref = ReferenceWaveform(kind="lfm", f_low_hz=19e3, f_high_hz=29e3, duration_s=0.05, postamble_s=8.0)
    ping = partial(chirp_ping, f0=19e3, f1=29e3, duration_s=0.05, method="linear")
    emit = np.array([0.3, 1.3, 8.3, 9.3])
    arrivals = (emit + 50.0 / C) / (1 + 0.5 / C)
    rng = np.random.default_rng(3)
    x = received(ping, fs=96000.0, duration_s=10.0, arrivals_s=arrivals, v_mps=0.5, ping_duration_s=0.05)
    x = add_noise(x, fs=96000.0, ping=ping, band_hz=(19e3, 29e3), ping_duration_s=0.05, snr_db=15, rng=rng)
    rx = ReferenceReceiver([ref], 96000.0, settings=ReferenceSettings(sound_speed_mps=C))
    found = sorted(rx.run([x.reshape(-1, 1)]), key=lambda f: f.fit.t_arrival_s)
    pair_up(found, eps_max=5.0 / C, sound_speed_mps=C)
    assert [f.role for f in found] == ["preamble", "preamble", "postamble", "postamble"]
    recs = [to_record(f, Emissions(times_s=np.array([0.3, 1.3])), sound_speed_mps=C) for f in found]
    assert [r.frame_index for r in recs] == [0, 1, 0, 1]
    assert all(math.isfinite(r.v_r_pair_mps) for r in recs)
    np.testing.assert_allclose([r.t_arrival_s for r in recs], arrivals, atol=5e-6)


# --- the command line: issue 25's reproductions ------------------------------------------------------------------

def _cli(*argv):
    from seamodem.cli import main

    return main([str(a) for a in argv])


def test_reference_ranging_takes_the_recordings_sound_speed(tmp_path, capsys):
    """tx --reference → channel at c = 1496.99 m/s → rx --reference: the sidecar's c is used (it used 1500:
    +15 cm of range bias, 0 of 20 within 3σ); outside 1400–1600 m/s is refused in one line unless forced."""
    from pathlib import Path

    import pandas as pd

    scenario = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "doppler_profile.toml"
    (tmp_path / "c.toml").write_text(scenario.read_text().replace("sound_speed_mps = 1500.0", "sound_speed_mps = 1496.99"))
    assert _cli("tx", "--reference", "lfm:18000-30000:0.08", "--count", 6, "--period", 3, "--start", 0.2,
                "-o", tmp_path / "c.wav", "-q") == 0
    assert _cli("channel", tmp_path / "c.wav", "--scenario", tmp_path / "c.toml", "-o", tmp_path / "c_rx.wav", "-q") == 0
    assert _cli("rx", tmp_path / "c_rx.wav", "--reference", tmp_path / "c_rx.json", "-o", tmp_path / "c.csv") == 0
    assert "c = 1496.99 m/s from the sidecar" in capsys.readouterr().out
    table = pd.read_csv(tmp_path / "c.csv")
    import json

    truth = {t["frame_index"]: t for t in json.loads((tmp_path / "c_rx.json").read_text())["truth"]}
    err = table["range_m"] - [truth[k]["range_true_m"] for k in table["frame_index"]]
    assert (abs(err) < 3 * table["sigma_range_m"]).all() and abs(err.mean()) < 0.01
    capsys.readouterr()
    assert _cli("rx", tmp_path / "c_rx.wav", "--reference", tmp_path / "c_rx.json", "--sound-speed", 1300,
                "-o", tmp_path / "x.csv") == 2
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and "1400" in err_lines[0] and not (tmp_path / "x.csv").exists()
    assert _cli("rx", tmp_path / "c_rx.wav", "--reference", tmp_path / "c_rx.json", "--sound-speed", 1300,
                "--force-sound-speed", "-o", tmp_path / "x.csv", "-q") == 0


def test_the_two_ping_command_line_reproduction_pairs(tmp_path):
    """`seamodem tx --reference pa.toml --count 2 --period 1` with postamble_s = 8: two pairs (was 4 lone pings)."""
    import pandas as pd

    (tmp_path / "pa.toml").write_text('[[reference]]\nkind = "lfm"\nf_low_hz = 19000.0\nf_high_hz = 29000.0\n'
                                      'duration_s = 0.05\npostamble_s = 8.0\n')
    assert _cli("tx", "--reference", tmp_path / "pa.toml", "--count", 2, "--period", 1, "--start", 0.3,
                "--sample-rate", 96000, "-o", tmp_path / "two.wav", "-q") == 0
    assert _cli("rx", tmp_path / "two.wav", "--reference", tmp_path / "two.json", "-o", tmp_path / "two.csv", "-q") == 0
    table = pd.read_csv(tmp_path / "two.csv").sort_values("t_arrival_s")
    assert list(table["role"]) == ["preamble", "preamble", "postamble", "postamble"]
    assert list(table["frame_index"]) == [0, 1, 0, 1] and table["v_r_pair_mps"].notna().all()
    assert set(table["v_r_source"]) == {"packet"}


def test_a_train_packet_from_tx_to_rx(tmp_path):
    """The packet TOML (4 + 3 chirps) through tx and rx: each packet's 7 rows, their frame index and emission."""
    import pandas as pd

    (tmp_path / "p.toml").write_text(
        '[[reference]]\nkind = "lfm"\nf_low_hz = 19000.0\nf_high_hz = 29000.0\nduration_s = 0.05\nwindow = "rect"\n'
        'train_count = 4\ntrain_spacing_s = 0.25\npostamble_s = 8.27\npostamble_count = 3\n')
    assert _cli("tx", "--reference", tmp_path / "p.toml", "--count", 2, "--period", 12, "--start", 0.3,
                "--sample-rate", 96000, "-o", tmp_path / "p.wav", "-q") == 0
    assert _cli("rx", tmp_path / "p.wav", "--reference", tmp_path / "p.json", "-o", tmp_path / "p.csv", "-q") == 0
    table = pd.read_csv(tmp_path / "p.csv").sort_values("t_arrival_s")
    assert list(table["frame_index"]) == [0] * 7 + [1] * 7
    assert list(table["train_position"]) == [0, 1, 2, 3, 0, 1, 2] * 2
    offsets = [o for o, _, _ in PACKET.packet()]
    np.testing.assert_allclose(table["t_emit_s"], [0.3 + o for o in offsets] + [12.3 + o for o in offsets], atol=1e-9)
    assert (abs(table["tof_s"]) < 1e-5).all()  # no channel: arrival = emission


def test_a_mat_template_takes_sample_rate_and_variable_from_the_command_line(tmp_path):
    """A template cut from a .mat without a rate: --sample-rate and --mat-variable reach it (they were ignored,
    and the error then asked for --sample-rate)."""
    from scipy.io import savemat

    from seamodem.transmit.reference import ReferenceWaveform, reference_replica

    fs = 96000.0
    ping = partial(chirp_ping, f0=19e3, f1=29e3, duration_s=0.05, method="linear")
    savemat(tmp_path / "tpl.mat", {"ping": ping(np.arange(int(0.05 * fs)) / fs)[:, None]})
    emit = np.array([0.2, 1.2, 2.2])
    x = received(ping, fs=fs, duration_s=3.0, arrivals_s=emit + 0.1, v_mps=0.0, ping_duration_s=0.05)
    import soundfile

    soundfile.write(tmp_path / "rec.wav", 0.3 * x, int(fs), subtype="FLOAT")
    code = _cli("rx", tmp_path / "rec.wav", "--reference", f"template:{tmp_path / 'tpl.mat'}",
                "--sample-rate", 96000, "--mat-variable", "ping", "--emit-start", 0.2, "--emit-period", 1,
                "--sound-speed", 1500, "-o", tmp_path / "t.csv", "-q")
    assert code == 0
    import pandas as pd

    np.testing.assert_allclose(pd.read_csv(tmp_path / "t.csv")["tof_s"], 0.1, atol=2e-6)
    assert reference_replica(ReferenceWaveform(kind="template", file=str(tmp_path / "tpl.mat"), sample_rate_hz=fs,
                                               mat_variable="ping")) is not None
