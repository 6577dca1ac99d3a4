import importlib.util
import json
from pathlib import Path

import numpy as np
import soundfile

ROOT = Path(__file__).resolve().parents[1]


def _regenerate_module():
    spec = importlib.util.spec_from_file_location("regenerate", ROOT / "waveforms" / "regenerate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_regenerating_reference_waveforms_gives_identical_samples(tmp_path):
    module = _regenerate_module()
    written = module.regenerate(tmp_path)
    assert {p.stem for p in written} == set(module.REFERENCES) == {"jmse2024", "oceans2021"}
    for new in written:
        ref = ROOT / "waveforms" / new.name
        a, fs_a = soundfile.read(ref, dtype="float32")
        b, fs_b = soundfile.read(new, dtype="float32")
        assert fs_a == fs_b and a.shape == b.shape
        np.testing.assert_array_equal(a, b)
        ref_side = json.loads(ref.with_suffix(".json").read_text())
        new_side = json.loads(new.with_suffix(".json").read_text())
        for key in ("config", "pilot", "schedule", "frames"):
            assert ref_side[key] == new_side[key]
        assert ref_side["recording"]["scale"] == new_side["recording"]["scale"]
