"""Replay through a measured channel, on small synthetic files in the uwa-channels format."""

import json

import numpy as np
import pytest
import scipy.io
import scipy.signal

from seamodem.channel import read_replay_channel, replay
from seamodem.cli import main
from seamodem.errors import InputFileError

FS = 96_000.0
FC = 13_000.0
FS_DELAY = 8_000.0
FS_TIME = 20.0


def write_channel(path, h_time_rx_delay, theta=None, **extra):
    """Write a channel as MATLAB does: h_hat n_delay × n_rx × n_time, theta_hat n_rx × n_samples."""
    data = {
        "h_hat": np.transpose(h_time_rx_delay, (2, 1, 0)),
        "params": {"fs_delay": FS_DELAY, "fs_time": FS_TIME, "fc": FC},
        "version": 1.0,
        **extra,
    }
    if theta is not None:
        data["theta_hat"] = theta.T
    scipy.io.savemat(path, data)
    return path


def band_limited_signal(seconds, rng):
    """Noise in FC ± 2.5 kHz, zero at both ends."""
    n = int(seconds * FS)
    sos = scipy.signal.butter(10, [FC - 2500, FC + 2500], btype="bandpass", fs=FS, output="sos")
    x = scipy.signal.sosfiltfilt(sos, rng.standard_normal(n))
    x[: int(0.05 * FS)] = 0
    x[-int(0.05 * FS) :] = 0
    return x


def analytic_delay(x, delay_s):
    """x_a(t − delay) by an exact phase ramp (analytic signal: positive frequencies only)."""
    n = x.size
    X = np.fft.fft(x)
    f = np.fft.fftfreq(n, 1 / FS)
    X[f < 0] = 0
    X[f > 0] *= 2
    return np.fft.ifft(X * np.exp(-2j * np.pi * f * delay_s))


def test_static_two_tap_channel_with_phase(tmp_path):
    taps = {5: 0.8, 13: -0.3 + 0.4j}  # delay index (1/fs_delay) → complex baseband gain
    n_time = 80  # 4 s of snapshots
    h = np.zeros((n_time, 2, 20), dtype=complex)
    for l, g in taps.items():
        h[:, 1, l] = g  # receiver 1; receiver 0 left silent
    theta0 = 0.7
    theta = np.full((int(4 * FS_DELAY), 2), theta0)
    ch = read_replay_channel(write_channel(tmp_path / "c.mat", h, theta))
    assert ch.h_hat.shape == (n_time, 2, 20) and ch.theta_hat.shape == (32_000, 2)
    assert (ch.fs_delay, ch.fs_time, ch.fc) == (FS_DELAY, FS_TIME, FC)
    x = band_limited_signal(1.0, np.random.default_rng(4))
    y = replay(x, FS, ch, receiver=1, start_s=0.5)
    # independent answer: y = Re[e^{jθ} Σ_l g_l e^{j2π fc τ_l} x_a(t − τ_l)], τ_l = l / fs_delay
    expected = np.zeros(x.size, dtype=complex)
    for l, g in taps.items():
        tau = l / FS_DELAY
        expected += g * np.exp(2j * np.pi * FC * tau) * analytic_delay(x, tau)
    expected = np.real(np.exp(1j * theta0) * expected)
    core = slice(int(0.1 * FS), int(0.9 * FS))
    err = y[core] - expected[core]
    # two polyphase resamplings (scipy's default Kaiser filters) bound the accuracy near -45 dB
    assert 10 * np.log10(np.sum(err**2) / np.sum(expected[core] ** 2)) < -40


def test_time_varying_gain_follows_the_snapshots(tmp_path):
    n_time = 100
    h = np.zeros((n_time, 1, 4), dtype=complex)
    h[:, 0, 0] = np.linspace(1.0, 0.5, n_time)  # linear in time: the cubic spline reproduces it exactly
    ch = read_replay_channel(write_channel(tmp_path / "ramp.mat", h, np.zeros((int(5 * FS_DELAY), 1))))
    x = np.cos(2 * np.pi * FC * np.arange(int(2.0 * FS)) / FS)
    y = replay(x, FS, ch, start_s=1.0)
    t = np.arange(y.size) / FS
    gain = 1.0 - 0.5 * (1.0 + t) / ((n_time - 1) / FS_TIME)
    core = slice(int(0.1 * FS), int(1.9 * FS))
    env = np.abs(scipy.signal.hilbert(y))[core]
    assert env == pytest.approx(gain[core], abs=0.01)


def test_errors(tmp_path):
    with pytest.raises(InputFileError, match="not found"):
        read_replay_channel(tmp_path / "none.mat")
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all" * 10)
    with pytest.raises(InputFileError):
        read_replay_channel(tmp_path / "junk.mat")
    scipy.io.savemat(tmp_path / "partial.mat", {"h_hat": np.zeros((4, 1, 8)), "version": 1.0})
    with pytest.raises(InputFileError, match="params"):
        read_replay_channel(tmp_path / "partial.mat")
    h = np.zeros((10, 1, 4), dtype=complex)
    h[:, 0, 0] = 1.0
    ch = read_replay_channel(write_channel(tmp_path / "short.mat", h))  # 0.45 s of channel
    with pytest.raises(ValueError, match="replay.start_s"):
        replay(np.zeros(int(FS)), FS, ch)
    with pytest.raises(ValueError, match="replay.receiver"):
        replay(np.zeros(100), FS, ch, receiver=3)


def test_cli_replay_mode(tmp_path, capsys):
    wav = tmp_path / "in.wav"
    assert main(["tx", "--preset", "oceans2021", "--count", "1", "--period", "0.5", "-q", "-o", str(wav)]) == 0
    h = np.zeros((60, 1, 16), dtype=complex)
    h[:, 0, 2] = 1.0
    h[:, 0, 9] = 0.5j
    fs_delay = 24_000.0  # wide enough for the oceans2021 band 17-29 kHz around fc = 23 kHz
    scipy.io.savemat(tmp_path / "ch.mat", {"h_hat": np.transpose(h, (2, 1, 0)), "version": 1.0,
                                           "params": {"fs_delay": fs_delay, "fs_time": 20.0, "fc": 23_000.0}})
    scenario = tmp_path / "r.toml"
    scenario.write_text('mode = "replay"\n[replay]\nfile = "ch.mat"\n[noise]\nkind = "white"\nsnr_db = 30.0\n')
    out = tmp_path / "out.wav"
    assert main(["channel", str(wav), "--scenario", str(scenario), "-q", "-o", str(out)]) == 0
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["truth"] == [] and side["channel"]["replay"]["n_delay"] == 16
    assert side["channel"]["noise"]["snr_db"] == 30.0
