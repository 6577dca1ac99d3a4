"""The reference receiver's package (issue 24): its import paths, its seams and its settings.

``seamodem.receive.reference`` was one 1,135-line module; it is a package with
one module per seam. Every public name of the old module is importable from the
package as before, no module is over 600 lines, none imports another module's
private names, and the receiver takes the receiver settings (validated once).
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

import seamodem.receive.reference as reference
from seamodem.errors import ConfigError
from seamodem.receive.settings import ReceiverSettings, ReferenceSettings
from seamodem.transmit.reference import parse_reference, reference_replica, reference_waveform

PACKAGE = Path(reference.__file__).parent

#: the public names of the module before it became a package
OLD_NAMES = (
    "BandPlan", "plan_band", "BandDecimator", "ReferenceDetector", "ReferenceDetection", "ReferenceFit",
    "fit_reference", "ReferenceRecord", "REFERENCE_FIELDS", "pair_doppler", "ReferenceReceiver",
    "best_per_detection", "keep_matching_reference", "pair_up", "to_record", "DOPPLER_THRESHOLD",
    "MISFIT_LIMIT", "MIN_RHO", "ECHO_WINDOW_S", "EARLY_WINDOW_S", "FIRST_PATH_FRACTION", "MAX_ECHOES",
    "ECHO_Z", "SCAN_POINTS", "SCAN_STEPS", "EARLY_Z", "MAX_ACCEL_MPS2",
)


def test_every_old_name_is_importable_from_the_package():
    missing = [name for name in OLD_NAMES if not hasattr(reference, name)]
    assert not missing
    assert set(OLD_NAMES) <= set(reference.__all__)
    assert all(hasattr(reference, name) for name in reference.__all__)


def test_modules_are_small_and_import_no_private_names():
    for path in PACKAGE.glob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert len(text.splitlines()) <= 600, path.name
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom):
                private = [a.name for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
                assert not private, f"{path.name} imports {private} from {node.module}"


def test_reference_settings_extend_the_receiver_settings_and_are_validated_once():
    s = ReferenceSettings(sound_speed_mps=1480.0, v_max_mps=4.0)
    assert isinstance(s, ReceiverSettings) and s.min_rho == reference.MIN_RHO
    assert s.max_accel_mps2 == reference.MAX_ACCEL_MPS2 and s.eps_max == 4.0 / 1480.0
    assert s.to_dict()["max_accel_mps2"] == reference.MAX_ACCEL_MPS2
    plain = ReceiverSettings(sound_speed_mps=1490.0, v_max_mps=2.0, false_alarms_per_hour=1.0)
    promoted = ReferenceSettings.from_settings(plain, min_rho=0.0)
    assert (promoted.sound_speed_mps, promoted.v_max_mps, promoted.false_alarms_per_hour, promoted.min_rho) == (
        1490.0, 2.0, 1.0, 0.0)
    assert ReferenceSettings.from_settings(s) is s
    for field, value in [("v_max_mps", 100.0), ("v_max_mps", math.inf), ("max_accel_mps2", -0.1),
                         ("max_accel_mps2", math.nan), ("min_rho", 1.5), ("turnaround_s", 0.5), ("decode", True),
                         ("sound_speed_mps", 0.0)]:
        with pytest.raises(ConfigError) as err:
            ReferenceSettings(**{field: value})
        assert str(err.value).startswith(field.removesuffix("_mps").removesuffix("_mps2").removesuffix("_s"))
    with pytest.raises(ConfigError, match="v_max"):
        reference.ReferenceReceiver([parse_reference("lfm:19000-29000:0.05")], 96000.0,
                                    settings=ReceiverSettings(v_max_mps=150.0))


def test_the_receiver_takes_plain_receiver_settings():
    """A ReceiverSettings is taken as the ReferenceSettings with the same fields: the same detections."""
    ref = parse_reference("lfm:19000-29000:0.05")
    fs = 96000.0
    rng = np.random.default_rng(3)
    x = rng.normal(0, 0.05, int(1.5 * fs))
    ping = reference_waveform(reference_replica(ref), fs)
    x[int(0.4 * fs) : int(0.4 * fs) + len(ping)] += ping
    runs = []
    for settings in (ReceiverSettings(sound_speed_mps=1500.0, v_max_mps=3.0),
                     ReferenceSettings(sound_speed_mps=1500.0, v_max_mps=3.0)):
        rx = reference.ReferenceReceiver([ref], fs, settings=settings)
        assert isinstance(rx.settings, ReferenceSettings) and rx.settings.v_max_mps == 3.0
        runs.append([(f.fit.t_arrival_s, f.fit.eps) for f in rx.run([x.reshape(-1, 1)])])
    assert len(runs[0]) == 1 and runs[0] == runs[1]
    assert abs(runs[0][0][0] - 0.4) < 1e-5
