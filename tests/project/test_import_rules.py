"""The house rules of addon/, read from the source (no imports run): dependencies point one
way, blender/ -> gl/ -> core/, and no two modules import each other, directly or round a
loop, not even through an import inside a function (a lazy import hides a circle, it does not
remove it). Imports are parsed with ast and relative imports resolved against the package."""
from __future__ import annotations

import ast
import pathlib

from testing.paths import REPO

ROOT = REPO
ADDON = ROOT / "addon"


def _module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _sources() -> dict[str, pathlib.Path]:
    return {_module_name(p): p for p in sorted(ADDON.rglob("*.py"))}


SOURCES = _sources()


def _package(name: str) -> str:
    return name if SOURCES[name].name == "__init__.py" else name.rpartition(".")[0]


def _resolve(name: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = _package(name).split(".")
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(name: str) -> set[str]:
    """Every module `name` imports, anywhere in the file: addon modules by their dotted
    name (a `from pkg import sub` counts as importing pkg.sub when sub is a module), others
    by their top-level name (bpy, moderngl, numpy)."""
    found = set()
    for node in ast.walk(ast.parse(SOURCES[name].read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.add(alias.name if alias.name.startswith("addon") else alias.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(name, node)
            if not target.startswith("addon"):
                found.add(target.split(".")[0])
                continue
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in SOURCES]
            found.update(subs)
            if len(subs) < len(node.names):  # some names are attributes of target itself
                found.add(target)
    return found


GRAPH = {name: imports(name) for name in SOURCES}


def _inside(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def test_every_relative_import_resolves():
    for name, targets in GRAPH.items():
        for target in targets:
            if target.startswith("addon"):
                assert target in SOURCES, f"{name} imports {target}, which is no module"


def test_core_imports_neither_bpy_nor_moderngl_nor_the_layers_above():
    for name, targets in GRAPH.items():
        if not _inside(name, "addon.core"):
            continue
        bad = {t for t in targets if t in {"bpy", "bpy_extras", "mathutils", "gpu", "moderngl",
                                             "glcontext"}
               or any(_inside(t, up) for up in ("addon.gl", "addon.blender", "addon.cli"))}
        assert not bad, f"{name} imports {sorted(bad)}"


def test_gl_imports_no_bpy_nor_the_blender_layer():
    for name, targets in GRAPH.items():
        if not _inside(name, "addon.gl"):
            continue
        bad = {t for t in targets if t in {"bpy", "bpy_extras", "mathutils", "gpu"}
               or any(_inside(t, up) for up in ("addon.blender", "addon.cli"))}
        assert not bad, f"{name} imports {sorted(bad)}"


def test_blender_layer_never_reaches_the_cli():
    for name, targets in GRAPH.items():
        if _inside(name, "addon.blender"):
            bad = {t for t in targets if _inside(t, "addon.cli")}
            assert not bad, f"{name} imports {sorted(bad)}"


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (or a self-import): Tarjan."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):  # recursion depth is bounded by the module count (~150)
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
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
            if len(component) > 1 or v in graph[v]:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_cycle_finder_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert sorted(cycles(graph)) == [["a", "b", "c"], ["e"]]


def test_no_import_cycles_in_addon():
    assert cycles(GRAPH) == []


# The rooms of addon/blender/, lowest first: a module may import its own room and rooms below
# it, never one above or beside it (ops/ and ui/ share a floor and do not read each other).
ROOMS = {"data": 0, "props": 1, "evaluate": 2, "viewport": 3, "render": 4, "ops": 5, "ui": 5,
         "demo": 6}


def _room(name: str):
    parts = name.split(".")
    return parts[2] if len(parts) > 3 and parts[:2] == ["addon", "blender"] else None


def test_blender_rooms_import_downwards_only():
    assert {_room(n) for n in SOURCES} - {None} == set(ROOMS), "a room without a floor"
    for name, targets in GRAPH.items():
        room = _room(name)
        if room is None:
            continue
        for target in targets:
            other = _room(target)
            if other is not None and other != room:
                assert ROOMS[other] < ROOMS[room], f"{name} ({room}) imports {target} ({other})"


def test_cli_and_demo_never_import_the_operators():
    """Operators are for Blender's UI: what the command line and the demo share with them
    (presets, effect presets) lives in data/, so neither reaches into ops/."""
    users = [n for n in GRAPH if _inside(n, "addon.cli") or _inside(n, "addon.blender.demo")]
    assert any(_inside(n, "addon.blender.demo") for n in users), "the demo moved: update the rule"
    for name in users:
        bad = {t for t in GRAPH[name] if _inside(t, "addon.blender.ops")}
        assert not bad, f"{name} imports {sorted(bad)}"


def test_the_product_never_imports_test_support():
    """testing/, tests/ and bench/ stay out of the extension zip and pip installs, so nothing
    in addon/ may need them."""
    for name, targets in GRAPH.items():
        bad = {t for t in targets if t in {"testing", "tests", "bench", "conftest"}}
        assert not bad, f"{name} imports {sorted(bad)}"
