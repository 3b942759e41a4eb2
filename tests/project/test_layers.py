"""The package's layers, kept true: every module imports only from its own layer or the ones
below (function-level imports count: they are dependencies too), no module takes a private
name from another package, and the import graph has no circle.

The layers, bottom to top, are those docs/architecture.md draws; a module that belongs
nowhere fails the test, so a new module must be placed.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "lieint"

#: bottom to top: (layer, module prefixes); the longest matching prefix places a module
LAYERS = [
    (
        "foundations",
        [
            "lieint._version",
            "lieint._optional",
            "lieint.text",
            "lieint._plotting",
            "lieint.limits",
            "lieint.drift",
            "lieint.events",
            "lieint.dense",
        ],
    ),
    ("groups", ["lieint.groups", "lieint.ga._clifford", "lieint.ga.algebra", "lieint.ga.exponential"]),
    ("compiled engine", ["lieint.fast"]),
    ("validation", ["lieint._validation"]),
    ("systems", ["lieint.systems"]),
    ("geometric-algebra bodies", ["lieint.ga"]),
    ("methods", ["lieint.methods"]),
    (
        "driver",
        ["lieint.control", "lieint.observe", "lieint.loops", "lieint.driver", "lieint.solution", "lieint.rotations"],
    ),
    ("integrate", ["lieint.ivp", "lieint.warmup"]),
    ("scenes", ["lieint.scenes", "lieint.catalog"]),
    ("tangent flow", ["lieint.tangent"]),
    ("analysis", ["lieint.analysis"]),
    ("front ends", ["lieint.runs", "lieint.sweeps", "lieint.study"]),
    ("command line", ["lieint._arguments", "lieint.compare", "lieint.cli", "lieint.__main__", "lieint"]),
]


def _layer(module: str) -> int | None:
    best, where = -1, None
    for index, (_, prefixes) in enumerate(LAYERS):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, where = len(prefix), index
    return where


def _module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, root: Path = ROOT) -> list[tuple[str, list[str], int]]:
    """``(module imported, names taken, line)`` of every import in the file, relative ones
    resolved (function-level and ``TYPE_CHECKING`` imports included)."""
    name = _module_name(path, root)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [alias.name for alias in node.names]
            # `from . import x` and `from .pkg import mod` take modules: count them as such
            modules = [f"{target}.{n}" for n in names if (root.parent / f"{target}.{n}".replace(".", "/")).exists()
                       or (root.parent / (f"{target}.{n}".replace(".", "/") + ".py")).exists()]  # fmt: skip
            rest = [n for n in names if f"{target}.{n}" not in modules]
            if rest:
                out.append((target, rest, node.lineno))
            out += [(m, [], node.lineno) for m in modules]
    return [(target, names, line) for target, names, line in out if target.split(".")[0] == "lieint"]


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _graph() -> dict[str, set[str]]:
    """Who imports whom, ``TYPE_CHECKING`` imports included: a module that needs another's
    type for its annotations depends on it as much as one that calls it (a protocol in the lower
    module breaks such a circle)."""
    graph = {}
    for name, path in MODULES.items():
        targets = set()
        for target, _, _ in _imports(path):
            # the imported module itself, or the package it lives in
            while target not in MODULES and "." in target:
                target = target.rsplit(".", 1)[0]
            if target in MODULES and target != name:
                targets.add(target)
        graph[name] = targets
    return graph


def test_every_module_has_a_layer():
    assert [name for name in MODULES if _layer(name) is None] == []


def _upward(name: str, path: Path, root: Path = ROOT) -> list[str]:
    """The imports of module ``name`` that reach a higher layer."""
    mine, upward = _layer(name), []
    for target, _, line in _imports(path, root):
        theirs = _layer(target)
        if theirs is not None and mine is not None and theirs > mine:
            upward.append(f"line {line}: {target} ({LAYERS[theirs][0]} above {LAYERS[mine][0]})")
    return upward


@pytest.mark.parametrize("name", sorted(MODULES))
def test_a_module_imports_only_from_its_layer_or_below(name):
    assert _upward(name, MODULES[name]) == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_private_name_crosses_a_package(name):
    package = name.rsplit(".", 1)[0] if MODULES[name].name != "__init__.py" else name
    crossing = []
    for target, names, line in _imports(MODULES[name]):
        target_package = target if (ROOT.parent / target.replace(".", "/")).is_dir() else target.rsplit(".", 1)[0]
        private = [n for n in names if n.startswith("_") and not n.startswith("__")]
        if private and target_package != package and target != "lieint._validation":
            crossing.append(f"line {line}: {target} {private}")
    assert crossing == []


def test_the_import_graph_has_no_circle():
    graph = _graph()
    index, low, stack, on_stack, circles, counter = {}, {}, [], set(), [], [0]

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
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
                circles.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    assert circles == []


def test_the_rule_fails_on_an_upward_import(tmp_path):
    """The check itself: a module of the compiled engine that imports the driver, at the top or
    inside a function, is reported; one that imports the groups is not."""
    package = tmp_path / "lieint" / "fast"
    package.mkdir(parents=True)
    (tmp_path / "lieint" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    probe = package / "probe.py"
    probe.write_text("from ..groups import SO\n\ndef f():\n    from ..driver import Driver\n")
    found = _upward("lieint.fast.probe", probe, tmp_path / "lieint")
    assert found == ["line 4: lieint.driver (driver above compiled engine)"]
