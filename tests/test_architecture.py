"""The package's shape: no import cycle among seamodem's modules, and a command line that starts fast.

The cycle scan reads every module's *module-level* imports (imports inside
functions run later, when the command needs them, and cannot deadlock an
import). Importing ``seamodem.a.b`` first runs the package ``seamodem.a``, so
that package counts as imported too; the root package ``seamodem`` is left
out, being only the lazy facade over the others.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import seamodem

ROOT = Path(seamodem.__file__).parent


def _module_name(path: Path) -> str:
    parts = ["seamodem", *path.relative_to(ROOT).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _top_level_imports(tree: ast.Module, *, module_level: bool = True):
    """Import statements run when the module is imported (not in functions, not under TYPE_CHECKING).

    ``module_level=False``: every import statement, those in functions too.
    """
    if not module_level:
        yield from (n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom)))
        return
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, ast.If):
            test = ast.unparse(node.test)
            if "TYPE_CHECKING" not in test:
                stack.extend(node.body + node.orelse)
        elif isinstance(node, (ast.Try,)):
            stack.extend(node.body + node.orelse + node.finalbody + [s for h in node.handlers for s in h.body])
        elif isinstance(node, (ast.With,)):
            stack.extend(node.body)


def _absolute(node: ast.ImportFrom, package: str) -> str:
    """The module a ``from ... import`` statement in ``package`` reads from, made absolute."""
    base = node.module or ""
    if node.level:
        anchor = package.split(".")
        anchor = anchor[: len(anchor) - node.level + 1]
        base = ".".join(anchor + ([base] if base else []))
    return base


def import_graph(*, module_level: bool = True) -> dict[str, set[str]]:
    """seamodem module → seamodem modules it imports at module level (with the packages that implies)."""
    files = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in _top_level_imports(ast.parse(path.read_text(encoding="utf-8")), module_level=module_level):
            if isinstance(node, ast.Import):
                bases = [a.name for a in node.names]
            else:
                base = _absolute(node, package)
                bases = [base] + [f"{base}.{a.name}" for a in node.names]
            for target in bases:
                if target not in files:
                    continue
                parts = target.split(".")
                # importing seamodem.a.b runs seamodem.a first (the root facade excepted)
                targets.update(".".join(parts[:i]) for i in range(2, len(parts) + 1))
        # a module's own packages are already running when it is imported
        targets.difference_update(".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 2))
        graph[name] = {t for t in targets if t in files}
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def test_the_scan_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert import_cycles(graph) == [["a", "b", "c"]]


def test_no_import_cycle_among_seamodem_modules():
    assert import_cycles(import_graph()) == []


def test_no_cycle_through_function_level_imports_either():
    # a function-level import back up the chain (batch calling the CLI, decode calling the receiver)
    # is a cycle in the design even when it cannot deadlock; navigation is scanned by its own tests
    graph = import_graph(module_level=False)
    graph = {m: {t for t in ts if ".navigation" not in t} for m, ts in graph.items() if ".navigation" not in m}
    assert import_cycles(graph) == []


HEAVY = ("scipy", "numba", "matplotlib", "dask")


def _modules_after(code: str) -> dict:
    """The heavy modules (and seamodem's) a fresh interpreter holds after running ``code``."""
    probe = code + (
        "\nimport json, sys\n"
        f"print(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))"
    )
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_importing_the_cli_and_its_help_import_no_heavy_module():
    loaded = _modules_after("import seamodem.cli\nseamodem.cli._parser().format_help()")
    assert loaded == dict.fromkeys(HEAVY, False)


def test_a_one_line_user_error_imports_no_heavy_module(tmp_path):
    missing = tmp_path / "missing.wav"
    code = (
        "import contextlib, io\nfrom seamodem.cli import main\n"
        "with contextlib.redirect_stderr(io.StringIO()):\n"
        f"    assert main(['rx', {str(missing)!r}, '-o', {str(tmp_path / 'm.csv')!r}]) == 2\n"
    )
    assert _modules_after(code) == dict.fromkeys(HEAVY, False)


def test_import_seamodem_is_lazy_and_every_public_name_resolves():
    assert _modules_after("import seamodem") == dict.fromkeys(HEAVY, False)
    import seamodem.transmit

    assert set(seamodem.transmit.__all__) <= set(seamodem.__all__)
    for name in seamodem.__all__:
        assert getattr(seamodem, name) is not None, name
    namespace: dict = {}
    exec("from seamodem import *", namespace)
    assert set(seamodem.__all__) <= set(namespace)


def _imported_names(module_level: bool = False):
    """(importing module, imported module, name) for every ``from seamodem... import name``."""
    files = {_module_name(p): p for p in ROOT.rglob("*.py")}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in _top_level_imports(ast.parse(path.read_text(encoding="utf-8")), module_level=module_level):
            if isinstance(node, ast.ImportFrom):
                base = _absolute(node, package)
                for alias in node.names:
                    yield name, base, alias.name, files


def private_imports() -> list[tuple[str, str, str]]:
    """Underscored names (not modules, not dunders) that one seamodem module imports from another."""
    return sorted((src, base, n) for src, base, n, files in _imported_names()
                  if base.startswith("seamodem") and n.startswith("_") and not n.startswith("__")
                  and f"{base}.{n}" not in files)


#: the layers, lowest first: a package imports only from layers below its own (leaves among themselves)
LAYERS = [
    {"errors", "_version", "_lazy", "_progress", "config", "dsp", "io"},
    {"plots"},
    {"water"},
    {"transmit"},
    {"channel", "decode"},
    {"receive"},
    {"batch"},
    {"navigation", "studies"},
    {"demo"},
    {"cli"},
    {"__main__"},
]


def back_arrows() -> list[tuple[str, str]]:
    """Imports that climb the layers, or reach the root facade ``seamodem`` from inside the package."""
    rank = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}
    out = set()
    for src, base, _, _ in _imported_names():
        if not base.startswith("seamodem") or src == "seamodem":
            continue
        a, b = src.split(".")[1], (base.split(".") + [""])[1]
        if b == "":  # the root package itself
            out.add((src, base))
        elif a != b and not (rank[b] < rank[a] or rank[a] == rank[b] == 0):
            out.add((src, base))
    return sorted(out)


def test_the_private_name_scan_finds_one(tmp_path):
    # the scan's own check: the old receive/reference.py imported detect._cluster_crossings
    tree = ast.parse("from .detect import _cluster_crossings, first_distinct_peak\nfrom .. import __version__\n")
    names = [(n.module, a.name) for n in _top_level_imports(tree, module_level=False) for a in n.names]
    assert ("detect", "_cluster_crossings") in names


def test_no_private_name_is_imported_across_modules():
    assert private_imports() == []


def test_every_package_is_in_a_layer_and_no_import_climbs_them():
    packages = {p.name if p.is_dir() else p.stem for p in ROOT.iterdir()
                if (p.is_dir() and (p / "__init__.py").exists()) or (p.suffix == ".py" and p.stem != "__init__")}
    assert packages <= {pkg for layer in LAYERS for pkg in layer}, packages
    assert back_arrows() == []


if __name__ == "__main__":
    for level in (True, False):
        print("module-level imports:" if level else "all imports, those in functions too:")
        for cycle in import_cycles(import_graph(module_level=level)):
            print("   ", " <-> ".join(cycle))
    print("private names imported across modules:", private_imports() or "none")
    print("imports climbing the layers:", back_arrows() or "none")
