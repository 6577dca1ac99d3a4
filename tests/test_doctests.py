"""The examples in the package's docstrings run, and give what they show.

Every module of src/seamodem with a ``>>>`` line is collected (``__main__``
would run the command line). Navigation modules listed in NOT_RUN are left to
their owner's tests.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

import seamodem

ROOT = Path(seamodem.__file__).parent
#: modules whose examples are not run here, with the reason
NOT_RUN: dict[str, str] = {}


def _modules_with_examples() -> list[str]:
    names = []
    for path in sorted(ROOT.rglob("*.py")):
        if path.name == "__main__.py" or ">>>" not in path.read_text(encoding="utf-8"):
            continue
        parts = ["seamodem", *path.relative_to(ROOT).with_suffix("").parts]
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return [n for n in names if n not in NOT_RUN]


def test_examples_are_found():
    assert {"seamodem", "seamodem.receive.settings", "seamodem.receive.stream"} <= set(_modules_with_examples())


@pytest.mark.parametrize("name", _modules_with_examples())
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.attempted > 0 and result.failed == 0, f"{result.failed} of {result.attempted} examples failed (above)"
