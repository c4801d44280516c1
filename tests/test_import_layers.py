"""The package's import layers (declared in pyproject.toml, ``[[tool.trebuchet.layers]]``).

The import graph is read from the sources with :mod:`ast` (every ``import``, lazy ones inside
functions included), so a circle hidden behind a function-level import is found too.
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
PACKAGE_DIRS = {k: v for k, v in PYPROJECT["tool"]["setuptools"]["package-dir"].items()
                if k != "trebuchet.data_samples"}
CONTRACTS = PYPROJECT["tool"]["trebuchet"]["layers"]


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name, from the package-dir mapping."""
    out: dict[str, Path] = {}
    for pkg, folder in PACKAGE_DIRS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = list(path.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out.setdefault(".".join([pkg, *parts]), path)
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """The package's modules that ``name`` imports (``from a import b`` counts as ``a.b`` where
    that is a module, else as ``a``)."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                head = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*head, base] if base else head)
            found.update(f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base
                         for a in node.names)
    return {m for m in found if m in MODULES and m != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer_of(module: str, container: str, layers: list[list[str]]) -> tuple[int, str] | None:
    """(layer index, sibling) of ``module`` inside ``container``, None if it is in none."""
    if not module.startswith(container + "."):
        return None
    head = module[len(container) + 1:].split(".")[0]
    for i, siblings in enumerate(layers):
        if head in siblings:
            return i, head
    return None


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's components of more than one module (each an import circle)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return circles


def test_the_graph_is_read():
    """The walk sees the package: the simulator imports the force formulas."""
    assert len(MODULES) > 60
    assert "trebuchet.model.forces" in GRAPH["trebuchet.model.loads"]
    assert "trebuchet.ingest.smoothing.smooth" in MODULES


def test_no_import_circle():
    assert _strongly_connected(GRAPH) == []


def test_a_circle_would_be_found():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _strongly_connected(graph) == [["a", "b", "c"]]


def _against_layers(graph: dict[str, set[str]], container: str, layers: list[list[str]]
                    ) -> list[str]:
    """Every import in ``graph`` from a layer of ``container`` to one above it or to a sibling
    of its own layer, as ``"a -> b"``."""
    wrong = []
    for module, targets in graph.items():
        here = _layer_of(module, container, layers)
        if here is None:
            continue
        for target in targets:
            there = _layer_of(target, container, layers)
            if there is not None and there[1] != here[1] and there[0] <= here[0]:
                wrong.append(f"{module} -> {target}")
    return sorted(wrong)


def test_a_back_edge_and_a_sibling_edge_would_be_found():
    layers = [["top"], ["left", "right"], ["base"]]
    graph = {"p.top.a": {"p.left.b", "p.base"}, "p.left.b": {"p.right", "p.base"},
             "p.base": {"p.top.a"}, "p.right": set()}
    assert _against_layers(graph, "p", layers) == ["p.base -> p.top.a", "p.left.b -> p.right"]


@pytest.mark.parametrize("contract", CONTRACTS, ids=[c["container"] for c in CONTRACTS])
def test_layers_import_downward_only(contract):
    container = contract["container"]
    layers = [[s.strip() for s in layer.split("|")] for layer in contract["layers"]]
    children = {m[len(container) + 1:].split(".")[0] for m in MODULES
                if m.startswith(container + ".")}
    placed = {s for layer in layers for s in layer}
    assert children <= placed, f"{container}: not in any layer: {sorted(children - placed)}"
    assert _against_layers(GRAPH, container, layers) == []
