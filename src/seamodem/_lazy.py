"""Package facades that import a name's module on first use (PEP 562).

``import seamodem`` (and the command line) must not wait for scipy, numba or
matplotlib; a package re-exports its public names flat all the same.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable


def exports(groups: dict[str, Iterable[str]]) -> dict[str, str]:
    """{module: names} → {name: module}, refusing a name exported twice."""
    table: dict[str, str] = {}
    for module, names in groups.items():
        for name in names:
            if name in table:
                raise ValueError(f"{name!r} is exported by both {table[name]!r} and {module!r}")
            table[name] = module
    return table


def lazy_module(package: str, table: dict[str, str], namespace: dict) -> tuple[Callable, Callable]:
    """``__getattr__`` and ``__dir__`` for ``package`` whose names are in ``table`` (name → submodule)."""

    def __getattr__(name: str):
        try:
            module = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(f".{module}", package), name)
        namespace[name] = value  # later look-ups do not come back here
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
