"""The package's import graph has no cycles between modules, counting imports made inside
functions too; docs/design.md's layer table is the layers contract that `lint-imports` checks
(pyproject.toml)."""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_checking_only(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.If)
        and isinstance(node.test, ast.Name)
        and node.test.id == "TYPE_CHECKING"
    )


def import_graph() -> dict[str, set[str]]:
    """dentdemo module -> the dentdemo modules it imports at run time (anywhere in its body, not
    under `if TYPE_CHECKING`)."""
    modules = {_module_name(p): p for p in (SRC / "dentdemo").rglob("*.py")}
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if _type_checking_only(node):
                node.body = []  # annotations only: not imported at run time
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                    base = f"{base}.{node.module}" if node.module else base
                # `from package import module` imports the module; else the package itself.
                targets = [
                    f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                    for alias in node.names
                ]
            for target in targets:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target and target != name and target.startswith("dentdemo"):
                    graph[name].add(target)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
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
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_cycle_finder_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_module_import_cycles():
    assert cycles(import_graph()) == []


def _contract_layers() -> list[list[str]]:
    """The layers contract of pyproject.toml (lint-imports checks the code against it), top
    first, each layer as its independent modules."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    (layers,) = [c for c in config["contracts"] if c["type"] == "layers"]
    return [[name.strip() for name in re.split(r"[|:]", layer)] for layer in layers["layers"]]


def _design_table() -> list[tuple[str, list[str]]]:
    """docs/design.md's layer table: (layer, the layers it may import), top first."""
    text = (ROOT / "docs" / "design.md").read_text()
    section = text[text.index("## Layers") :]
    section = section[: section.index("\n## ", 1)]
    rows = []
    for line in section.splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        match = re.fullmatch(r"`(\w+)(?:/|\.py)`", cells[0]) if line.startswith("|") else None
        if match:
            rows.append((match.group(1), re.findall(r"\w+", cells[-1])))
    return rows


def test_the_layer_table_is_the_layers_contract():
    """The table's layers are the contract's, in the same order; what a row may import lies
    below it in the contract; the modules the contract adds are named below the table."""
    layers = _contract_layers()
    flat = [name for layer in layers for name in layer]
    table = _design_table()
    assert [name for name, _ in table] == [name for name in flat if name in dict(table)]
    depth = {name: i for i, layer in enumerate(layers) for name in layer}
    for name, may_import in table:
        if may_import == ["all", "below"]:
            continue
        for below in may_import:
            assert depth[below] > depth[name], f"{name} may import {below}, above it"
    section = (ROOT / "docs" / "design.md").read_text().split("## Layers")[1]
    for name in flat:
        if name not in dict(table) and name != "__main__":
            assert f"`{name}.py`" in section, f"docs/design.md does not name {name}.py"
