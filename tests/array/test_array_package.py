"""The array receiver's package shape (issue 24): its old import path, modules of one job each, no private imports."""

import ast
from pathlib import Path

import seamodem.receive.array as array_package

PACKAGE = Path(array_package.__file__).parent

#: every public name ``seamodem.receive.array`` (one module of 1,375 lines until issue 24) defined
NAMES = [
    "ArrayCorrelation", "ArrayDetector", "ArrayGeometry", "BLANKER_BLOCK", "COMBINE_PAD_S", "COMBINE_RAMP_S",
    "DETECTION_CHUNK_S", "DoaEstimate", "ECHO_FRACTION", "ECHO_SEARCH_S", "LAG_TOLERANCE_S", "MAX_ECHOES",
    "MAX_ITERATIONS", "MAX_SNR", "MIN_AXIS_COMPONENT", "NOISE_GAP_S", "NOISE_SEGMENT_S", "POSITION_PRIOR_M",
    "WINDOW_MARGIN_S", "array_correlation", "array_geometry", "baseband_correlation", "blank_like_reference",
    "calibrate_array", "combine_channels", "estimate_doa", "front_end_array", "fs_of", "receive_array",
    "receive_array_file", "unit_vector",
]


def test_every_name_of_the_old_module_imports_from_the_package():
    missing = [name for name in NAMES if not hasattr(array_package, name)]
    assert missing == []
    assert set(array_package.__all__) <= set(NAMES)


def test_no_module_of_the_package_is_over_600_lines():
    long = {p.name: n for p in PACKAGE.glob("*.py") if (n := len(p.read_text(encoding="utf-8").splitlines())) > 600}
    assert long == {}


def test_the_package_imports_no_private_name_of_another_module():
    private = []
    for path in PACKAGE.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                private += [f"{path.name}: {node.module}.{a.name}" for a in node.names
                            if a.name.startswith("_") and not a.name.startswith("__")]
    assert private == []
