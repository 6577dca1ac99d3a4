import json
import os
import subprocess
import sys

import numpy as np
import pytest
import soundfile

from seamodem.cli import main


def run(args, capsys):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_tx_writes_wav_and_sidecar(tmp_path, capsys):
    out = tmp_path / "beacon.wav"
    code, stdout, _ = run(["tx", "--preset", "jmse2024", "--count", 3, "--period", 0.5, "--start", 0.2,
                           "--payload-text", "hello {index}", "-o", out], capsys)
    assert code == 0 and "wrote" in stdout
    side = json.loads((tmp_path / "beacon.json").read_text())
    assert [f["t_emit_s"] for f in side["frames"]] == pytest.approx([0.2, 0.7, 1.2])
    assert bytes.fromhex(side["frames"][2]["payload_hex"]) == b"hello 2"
    assert side["config"]["name"] == "jmse2024" and side["command"].startswith("seamodem")
    x, fs = soundfile.read(out)
    assert fs == 96153 and x.size == side["recording"]["n_samples"]
    assert np.all(x[: int(0.2 * fs) - 1] == 0) and np.any(x[int(0.2 * fs) : int(0.25 * fs)] != 0)


def test_tx_payload_file_and_pcm24(tmp_path, capsys):
    data = tmp_path / "data.bin"
    data.write_bytes(bytes(range(256)))
    out = tmp_path / "f.wav"
    code, _, _ = run(["tx", "--preset", "oceans2021", "--payload-file", data, "--format", "pcm24",
                      "--period", 1, "-o", out], capsys)
    assert code == 0
    side = json.loads(out.with_suffix(".json").read_text())
    assert b"".join(bytes.fromhex(f["payload_hex"]) for f in side["frames"]) == bytes(range(256))
    assert len(side["frames"]) == 2  # 256 bytes at 152 bytes/frame
    assert soundfile.info(out).subtype == "PCM_24"


BAD = [
    (["--set", "tone_hz=28000"], "tone_hz"),
    (["--set", "tone_hz=48100"], "tone_hz"),
    (["--set", "carrier_hz=47000"], "carrier_hz"),
    (["--set", "rolloff=1.5"], "rolloff"),
    (["--set", "rolloff=-0.2"], "rolloff"),
    (["--payload-text", "x" * 102], "payload"),
    (["--preset", "atlantis"], "preset"),
    (["--set", "colour=blue"], "colour"),
    (["--count", "0"], "count"),
    (["--period", "0.1", "--count", "2"], "period_s"),
    (["--payload-file", "/nonexistent/file.bin"], "payload file not found"),
    (["--peak", "1.5"], "peak"),
]


@pytest.mark.parametrize("extra,named", BAD)
def test_tx_bad_input_one_line_exit_2_no_file(tmp_path, capsys, extra, named):
    out = tmp_path / "o.wav"
    code, stdout, err = run(["tx", *extra, "-o", out], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("seamodem tx: error:") and named in lines[0]
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_tx_bad_config_file(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("rolloff = [1, 2\n")
    code, _, err = run(["tx", "--config", bad, "-o", tmp_path / "o.wav"], capsys)
    assert code == 2 and "not valid TOML" in err and len(err.strip().splitlines()) == 1
    missing = tmp_path / "nope.toml"
    code, _, err = run(["tx", "--config", missing, "-o", tmp_path / "o.wav"], capsys)
    assert code == 2 and "config file not found" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_tx_unwritable_output(tmp_path, capsys):
    code, _, err = run(["tx", "-o", tmp_path / "no" / "such" / "dir" / "o.wav"], capsys)
    assert code == 2 and "output" in err and "does not exist" in err
    code, _, err = run(["tx", "-o", tmp_path / "o.flac"], capsys)
    assert code == 2 and "output: must be a .wav path" in err
    if os.geteuid() != 0:  # root can write anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        code, _, err = run(["tx", "-o", ro / "o.wav"], capsys)
        assert code == 2 and "not writable" in err


def test_console_script_exit_code_and_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "seamodem", "tx", "--set", "rolloff=2", "-o", str(tmp_path / "o.wav")],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "seamodem tx: error: rolloff: must be in [0, 1], got 2.0"


def test_plot_writes_png(tmp_path, capsys):
    out = tmp_path / "b.wav"
    assert run(["tx", "--count", 2, "--period", 0.5, "-o", out, "-q"], capsys)[0] == 0
    code, stdout, _ = run(["plot", out], capsys)
    png = tmp_path / "b.png"
    assert code == 0 and png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_bad_inputs(tmp_path, capsys):
    code, _, err = run(["plot", tmp_path / "missing.wav"], capsys)
    assert code == 2 and "not found" in err
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    code, _, err = run(["plot", empty], capsys)
    assert code == 2 and "empty" in err
    junk = tmp_path / "junk.wav"
    junk.write_bytes(b"RIFF" + bytes(100))
    code, _, err = run(["plot", junk], capsys)
    assert code == 2 and "not a readable audio file" in err
    nan = tmp_path / "nan.wav"
    soundfile.write(nan, np.array([0.0, np.nan, 0.1]), 48000, subtype="FLOAT")
    code, _, err = run(["plot", nan], capsys)
    assert code == 2 and "NaN" in err
    assert not (tmp_path / "nan.png").exists()


def test_config_command(tmp_path, capsys):
    code, out, _ = run(["config", "--preset", "oceans2021"], capsys)
    assert code == 0 and 'name = "oceans2021"' in out and "capacity 152 bytes" in out
    code, out, _ = run(["config", "--list"], capsys)
    assert "jmse2024" in out and "oceans2021" in out
    target = tmp_path / "c.toml"
    code, _, _ = run(["config", "--set", "rolloff=0.3", "-o", target], capsys)
    assert code == 0 and "rolloff = 0.3" in target.read_text()


def test_plot_truncated_wav(tmp_path, capsys):
    """A file cut mid-recording is read as far as it goes, with one warning line (issue 14); one cut
    inside its header is refused in one line."""
    whole = tmp_path / "whole.wav"
    soundfile.write(whole, np.zeros(10000), 48000, subtype="FLOAT")
    cut = tmp_path / "cut.wav"
    cut.write_bytes(whole.read_bytes()[:20000])
    code, _, err = run(["plot", cut, "-o", tmp_path / "cut.png"], capsys)
    assert code == 0 and (tmp_path / "cut.png").stat().st_size > 0
    assert "warning" in err and "4980 samples" in err and len(err.strip().splitlines()) == 1
    headless = tmp_path / "headless.wav"
    headless.write_bytes(whole.read_bytes()[:44])
    code, _, err = run(["plot", headless, "-o", tmp_path / "headless.png"], capsys)
    assert code == 2 and "not a readable audio file" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "headless.png").exists()
