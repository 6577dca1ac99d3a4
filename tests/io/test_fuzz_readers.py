"""Readers that never crash (issue 25 item 5): property-based fuzzing of every file seamodem reads.

Each reader gets a valid file of its kind, damaged by hypothesis: truncated, bytes flipped, a size field made to
lie, NaN/inf written over samples, a value replaced by one of the wrong type. The property: the reader either
reads it (warnings allowed) or raises a :class:`~seamodem.errors.SeamodemError` whose message is one line and
names the file. Anything else (a bare OSError, KeyError, TypeError, a traceback from h5py...) is a defect.

Examples per reader: ``SEAMODEM_FUZZ_EXAMPLES`` (default 120; ``benchmarks/bench_fuzz.py`` runs thousands).
"""

from __future__ import annotations

import json
import math
import os
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
import soundfile
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from seamodem.errors import SeamodemError

EXAMPLES = int(os.environ.get("SEAMODEM_FUZZ_EXAMPLES", "120"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=not os.environ.get("SEAMODEM_FUZZ_RANDOM"),
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
FS = 48000


# --- valid files of every kind ---------------------------------------------------------------------------------

def _samples(n=3000, channels=2):
    rng = np.random.default_rng(0)
    return 0.3 * rng.standard_normal((n, channels))


def make_wav(path: Path, subtype="FLOAT", fmt="WAV"):
    soundfile.write(str(path), _samples(), FS, subtype=subtype, format=fmt)


def make_mat5(path: Path):
    from scipy.io import savemat

    savemat(str(path), {"x": _samples(), "fs": float(FS)})


def make_mat73(path: Path):
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        f["x"] = _samples().T
        f["fs"] = np.array([[float(FS)]])
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 12:00:00 2026 HDF5 schema 1.00 .".ljust(128))


def make_measurements(path: Path):
    from seamodem.receive.records import MeasurementRecord, write_measurements

    recs = [MeasurementRecord(frame_index=k, t_emit_s=3.0 * k, t_arrival_s=3.0 * k + 0.2, tof_s=0.2, range_m=300.0,
                              v_r_mps=-1.25, snr_db=11.0, v_r_tone_eq9_mps=-1.2, v_r_bank_mps=-1.3, detection_z=500.0,
                              detection_rho=0.6, sigma_range_m=0.002, sigma_v_r_mps=6e-4, sigma_v_r_bank_mps=0.02,
                              tone_c_n0_dbhz=50.0, crc_ok=bool(k % 2), payload_text="hi", payload_hex="6869")
            for k in range(4)]
    write_measurements(path, recs, {"sound_speed_mps": 1500.0})


SCENARIO = """mode = "geometry"
seed = 2
[environment]
sound_speed_mps = 1500.0
water_depth_m = 30.0
[beacon]
position_m = [0.0, 0.0, -5.0]
[vehicle]
start_m = [100.0, 0.0, -10.0]
velocity_mps = [-1.0, 0.0, 0.0]
[multipath]
max_bounces = 1
[noise]
kind = "white"
snr_db = 10.0
"""

REFERENCE = """[[reference]]
kind = "lfm"
f_low_hz = 19000.0
f_high_hz = 29000.0
duration_s = 0.05
"""


def make_text(content: str):
    return lambda path: path.write_text(content, encoding="utf-8")


def make_sidecar(path: Path):
    from seamodem import BeaconSchedule, get_preset, write_beacon

    wav = path.with_suffix(".wav")
    write_beacon(wav, get_preset("jmse2024"), BeaconSchedule(count=1, period_s=1.0, start_s=0.1))
    path.write_bytes(wav.with_suffix(".json").read_bytes())


# --- the readers ------------------------------------------------------------------------------------------------

def read_audio(path: Path):
    from seamodem.io.mat import open_recording

    src = open_recording(path, sample_rate_hz=None if path.suffix != ".mat" else None)
    for ch in range(src.n_channels):
        for _ in src.blocks([ch]):
            pass


def read_meas(path: Path):
    from seamodem.receive.records import read_measurements

    read_measurements(path)


def read_side(path: Path):
    from seamodem.io.sidecar import read_sidecar, sidecar_payloads, sidecar_pilot_bits

    data = read_sidecar(path)
    sidecar_payloads(data)
    sidecar_pilot_bits(data)


def read_scn(path: Path):
    from seamodem.channel.scenario import load_scenario

    load_scenario(path)


def read_ref(path: Path):
    from seamodem.transmit.reference import load_references

    load_references(str(path))


READERS = {
    "wav_float": ("x.wav", lambda p: make_wav(p), read_audio),
    "wav_pcm16": ("x.wav", lambda p: make_wav(p, "PCM_16"), read_audio),
    "rf64": ("x.wav", lambda p: make_wav(p, "FLOAT", "RF64"), read_audio),
    "flac": ("x.flac", lambda p: make_wav(p, "PCM_24", "FLAC"), read_audio),
    "mat_v5": ("x.mat", make_mat5, read_audio),
    "mat_v73": ("x.mat", make_mat73, read_audio),
    "measurements_csv": ("m.csv", make_measurements, read_meas),
    "measurements_jsonl": ("m.jsonl", make_measurements, read_meas),
    "sidecar": ("s.json", make_sidecar, read_side),
    "scenario_toml": ("scn.toml", make_text(SCENARIO), read_scn),
    "reference_toml": ("ref.toml", make_text(REFERENCE), read_ref),
}

# --- damage -----------------------------------------------------------------------------------------------------

WRONG = [b'"abc"', b"[]", b"-1", b"nan", b"inf", b"1e400", b"{}", b"true", b"", b"0", b'"', b"\x00\xff"]
SIZES = [0, 1, 7, 0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, 12345]

op = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0, 1)),
    st.tuples(st.just("flip"), st.floats(0, 1), st.integers(1, 255)),
    st.tuples(st.just("u32"), st.integers(0, 80), st.sampled_from(SIZES)),
    st.tuples(st.just("float"), st.floats(0, 1), st.sampled_from([math.nan, math.inf, -math.inf, 1e30, 2.0])),
    st.tuples(st.just("token"), st.floats(0, 1), st.sampled_from(WRONG)),
    st.tuples(st.just("drop_line"), st.floats(0, 1)),
)


def damage(data: bytes, ops) -> bytes:
    b = bytearray(data)
    for o in ops:
        kind = o[0]
        if not b:
            break
        if kind == "truncate":
            del b[int(o[1] * len(b)):]
        elif kind == "flip":
            i = min(int(o[1] * len(b)), len(b) - 1)
            b[i] ^= o[2]
        elif kind == "u32":
            if o[1] + 4 <= len(b):
                b[o[1]:o[1] + 4] = struct.pack("<I", o[2])
        elif kind == "float":
            i = (int(o[1] * len(b)) // 4) * 4
            if i + 4 <= len(b) and i >= 64:
                b[i:i + 4] = struct.pack("<f", o[2])
        elif kind == "token":
            # the value after a random '=' or ':' (TOML, JSON, CSV cell after ',') replaced
            text = bytes(b)
            seps = [i for i, c in enumerate(text) if c in b"=:,"]
            if seps:
                i = seps[min(int(o[1] * len(seps)), len(seps) - 1)] + 1
                j = i
                while j < len(text) and text[j] not in b",\n}]":
                    j += 1
                b[i:j] = b" " + o[2] if text[i - 1:i] == b"=" else o[2]
        elif kind == "drop_line":
            lines = bytes(b).split(b"\n")
            if len(lines) > 1:
                del lines[min(int(o[1] * len(lines)), len(lines) - 1)]
                b = bytearray(b"\n".join(lines))
    return bytes(b)


def damaged_copy(name: str, tmp: Path, ops) -> Path:
    """The reader's valid file (made once in ``tmp``) damaged by ``ops``; a sidecar beside it stays intact."""
    fname, make, _ = READERS[name]
    original = tmp / ("orig_" + fname)
    if not original.exists():
        make(original)
    target = tmp / fname
    target.write_bytes(damage(original.read_bytes(), ops))
    side = original.with_name(original.name + ".json")
    if side.exists():
        target.with_name(target.name + ".json").write_bytes(side.read_bytes())
    return target


def message_defect(msg: str, target: Path) -> str | None:
    """What is wrong with an error message about ``target``, or None: one line, naming the file, short."""
    if "\n" in msg:
        return f"message on several lines: {msg!r}"
    if target.name not in msg:
        return f"message does not name the file: {msg!r}"
    if len(msg) >= 400:
        return f"message too long ({len(msg)} chars): {msg[:200]!r}..."
    return None


def check_reader(name: str, tmp: Path, ops) -> None:
    """The property: read, or one SeamodemError line naming the file."""
    target = damaged_copy(name, tmp, ops)
    read = READERS[name][2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if not ops:
            read(target)  # the undamaged file reads
            return
        try:
            read(target)
        except SeamodemError as exc:
            problem = message_defect(str(exc), target)
            assert problem is None, f"{name}: {problem}"
        except Exception as exc:  # noqa: BLE001 - the defect this test looks for
            raise AssertionError(f"{name}: {type(exc).__name__} escaped the reader: {exc}") from exc


@pytest.mark.parametrize("name", sorted(READERS))
def test_reader_reads_its_valid_file(name, tmp_path):
    check_reader(name, tmp_path, [])


@pytest.mark.parametrize("name", sorted(READERS))
def test_reader_never_crashes_on_damaged_files(name, tmp_path_factory):
    tmp = tmp_path_factory.mktemp(name)

    @FUZZ
    @given(st.lists(op, min_size=1, max_size=3))
    def prop(ops):
        check_reader(name, tmp, ops)

    prop()


def test_damage_does_what_it_says():
    assert damage(b"abcdef", [("truncate", 0.5)]) == b"abc"
    assert damage(b"a = 1\nb = 2\n", [("token", 0.0, b'"x"')]) == b'a = "x"\nb = 2\n'
    assert damage(b"\x00" * 8, [("u32", 2, 7)]) == b"\x00\x00\x07\x00\x00\x00\x00\x00"
    assert json.loads(damage(b'{"a": 1, "b": 2}', [("token", 0.99, b"[]")])) == {"a": 1, "b": []}


@pytest.mark.parametrize("name", ["wav_float", "mat_v73", "scenario_toml"])
def test_the_command_line_exits_2_in_one_line_and_writes_nothing(name, tmp_path_factory, capsys):
    """The same damage through ``seamodem rx`` / ``seamodem channel``: exit 0 or 2, never a traceback; on exit
    2 one error line naming the file and no output left behind."""
    from seamodem.cli import main

    tmp = tmp_path_factory.mktemp("cli_" + name)
    fname, make, _ = READERS[name]
    original = tmp / ("orig_" + fname)
    make(original)
    beacon = tmp / "beacon.wav"
    if name == "scenario_toml":
        make_sidecar(tmp / "beacon.json")  # writes beacon.wav and its sidecar

    @settings(max_examples=max(10, EXAMPLES // 6), deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(st.lists(op, min_size=1, max_size=2))
    def prop(ops):
        target = tmp / fname
        target.write_bytes(damage(original.read_bytes(), ops))
        out = tmp / ("out.wav" if name == "scenario_toml" else "m.csv")
        for f in (out, out.with_name(out.name + ".json"), out.with_suffix(".json")):
            f.unlink(missing_ok=True)
        argv = (["channel", str(beacon), "--scenario", str(target), "-o", str(out), "-q"] if name == "scenario_toml"
                else ["rx", str(target), "--channel", "0", "--emit-start", "0", "--emit-period", "1",
                      "-o", str(out), "-q"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            code = main(argv)
        err = [line for line in capsys.readouterr().err.strip().splitlines() if " error: " in line]
        assert code in (0, 2)
        if code == 2:  # (warnings before it allowed: a WAV whose header lies is read, with one)
            assert len(err) == 1 and target.name in err[0], err
            assert not out.exists()

    prop()
