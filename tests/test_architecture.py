"""Structure rules of the package, read from its source with :mod:`ast` (no import of gearrom).

* no import cycle between gearrom modules, counting imports inside functions too (a cycle broken by a
  deferred import is still a cycle in the design);
* no private name (leading underscore) imported from another gearrom module;
* no function longer than 150 lines, except the compiled explicit time loop, whose arrays come in
  named groups (:data:`ALLOWED_LONG`).
"""
from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "gearrom"
#: functions allowed over the length limit: (module, function)
ALLOWED_LONG = {("gearrom.fe.explicit.loop", "_run_loop")}
MAX_LINES = 150


def _modules() -> dict[str, tuple[Path, ast.Module]]:
    out = {}
    for p in ROOT.rglob("*.py"):
        parts = p.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = (p, ast.parse(p.read_text(encoding="utf-8")))
    return out


def _imports(tree: ast.Module, mods) -> set[str]:
    deps = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("gearrom"):
            deps.add(node.module)
            deps.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            deps.update(a.name for a in node.names if a.name.startswith("gearrom"))
    return deps & set(mods)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph)))

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_a_cycle():
    """The check itself: a known three-module cycle and a chain."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    mods = _modules()
    graph = {name: _imports(tree, mods) - {name} for name, (_, tree) in mods.items()}
    assert _cycles(graph) == []


def test_no_private_name_imported_across_modules():
    bad = []
    for path, tree in _modules().values():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("gearrom"):
                bad += [f"{path.name}:{node.lineno} {node.module}.{a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.startswith("__")]
    assert bad == []


def test_functions_fit_on_a_few_screens():
    long = []
    for name, (_, tree) in _modules().items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_LINES and (name, node.name) not in ALLOWED_LONG:
                    long.append(f"{name}.{node.name}: {n} lines")
    assert long == [], long
