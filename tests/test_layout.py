"""The package's module import graph has no cycles and flows one way (STYLE.md: layout).

Imports are read with ``ast`` from every module of ``neurocog_gym``, wherever they stand (a
function-level import closes a circle as surely as a top-level one), relative imports resolved.
An edge goes to the module named: ``from a.b import c`` reaches ``a.b.c`` if that is a module,
else ``a.b``. Parent packages a submodule import runs implicitly are not edges, or every module
would reach ``neurocog_gym/__init__.py`` and back.

Stages, in the order the data flows (issue 25): the shared utilities (the package root, ``io``,
``paths``), then robot -> perception -> locomotion -> envs -> policies -> train / bench, then
the entry points (``cli``, ``demo``, ``video``). A module may import its own stage or a lower
one, never a higher one; train and bench, side by side at one stage, import neither the other.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "neurocog_gym"

# Cycles that are known and scheduled for removal, each as the sorted tuple of its modules.
# Any cycle not listed here fails the test, and so does a listed one that no longer exists.
KNOWN_CYCLES: set[tuple[str, ...]] = set()

# The stage of each top-level module or subpackage of the package ("" is the package root).
# A new one fails test_every_module_has_a_stage until it is placed here.
STAGES = {
    "": 0,
    "io": 0,
    "paths": 0,
    "robot": 1,
    "perception": 2,
    "locomotion": 3,
    "envs": 4,
    "policies": 5,
    "train": 6,
    "bench": 6,
    "cli": 7,
    "demo": 7,
    "video": 7,
}
TOP = max(STAGES.values())
"""The entry points' stage, whose modules may import each other (the CLI runs the demo)."""


def _modules() -> dict[str, Path]:
    mods = {}
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = path
    return mods


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    is_package = path.name == "__init__.py"
    # The package a relative import of level 1 starts from.
    here = name.split(".") if is_package else name.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                assert len(base) == len(here) - (node.level - 1), f"{name}: import above top"
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                for alias in node.names
            ]
        else:
            continue
        for target in targets:
            # ``import a.b.c`` where only ``a.b`` is ours (an attribute or a name) counts as a.b.
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


def import_graph() -> dict[str, set[str]]:
    """Module name -> the package modules it imports."""
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def strongly_connected(graph: dict[str, set[str]]) -> list[set[str]]:
    """Tarjan's strongly connected components with more than one module (iterative)."""
    index, low, on_stack, stack, comps = {}, {}, set(), [], []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = set()
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    comp.add(top)
                    if top == node:
                        break
                if len(comp) > 1:
                    comps.append(comp)
    return comps


def _cycle_in(graph: dict[str, set[str]], comp: set[str]) -> list[str]:
    """One concrete cycle through a component, for the failure message."""
    start = min(comp)
    prev, frontier = {start: None}, [start]
    while frontier:
        nxt = []
        for node in frontier:
            for child in sorted(graph[node] & comp):
                if child == start:
                    path = [node]
                    while prev[path[-1]] is not None:
                        path.append(prev[path[-1]])
                    return [*reversed(path), start]
                if child not in prev:
                    prev[child] = node
                    nxt.append(child)
        frontier = nxt
    raise AssertionError(f"no cycle through {start} in {sorted(comp)}")


def group(module: str) -> str:
    """The top-level module or subpackage ``module`` belongs to ("" for the package root)."""
    parts = module.split(".")
    assert parts[0] == PACKAGE, module
    return parts[1] if len(parts) > 1 else ""


def upward_imports(graph: dict[str, set[str]], stages: dict[str, int]) -> list[str]:
    """Every edge that goes against the data flow, as ``"a (stage i) -> b (stage j)"``.

    Against the flow: to a higher stage, or, below the entry points, to another group of the
    same stage (train <-> bench).
    """
    out = []
    for src in sorted(graph):
        s = stages[group(src)]
        for dst in sorted(graph[src]):
            d = stages[group(dst)]
            if d > s or (d == s < TOP and group(dst) != group(src)):
                out.append(f"{src} (stage {s}) -> {dst} (stage {d})")
    return out


def test_graph_sees_the_package():
    graph = import_graph()
    assert f"{PACKAGE}.bench.runner" in graph
    assert f"{PACKAGE}.bench.outcome" in graph[f"{PACKAGE}.bench.runner"]
    assert f"{PACKAGE}.bench.records" in graph[f"{PACKAGE}.bench.report"]


def test_cycle_finder_finds_long_cycles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    assert strongly_connected(graph) == [{"a", "b", "c"}]
    assert _cycle_in(graph, {"a", "b", "c"}) == ["a", "b", "c", "a"]


def test_upward_import_finder():
    graph = {
        f"{PACKAGE}.envs.base": {f"{PACKAGE}.paths", f"{PACKAGE}.policies.aef"},
        f"{PACKAGE}.policies.aef": {f"{PACKAGE}.envs.base", f"{PACKAGE}"},
        f"{PACKAGE}.bench.runner": {f"{PACKAGE}.train.aef", f"{PACKAGE}.bench.outcome"},
        f"{PACKAGE}.bench.outcome": set(),
        f"{PACKAGE}.train.aef": set(),
        f"{PACKAGE}.cli": {f"{PACKAGE}.demo"},
        f"{PACKAGE}.demo": {f"{PACKAGE}.bench.runner"},
        f"{PACKAGE}.paths": set(),
        f"{PACKAGE}": set(),
    }
    assert upward_imports(graph, STAGES) == [
        f"{PACKAGE}.bench.runner (stage 6) -> {PACKAGE}.train.aef (stage 6)",
        f"{PACKAGE}.envs.base (stage 4) -> {PACKAGE}.policies.aef (stage 5)",
    ]


def test_relative_imports_resolve(tmp_path):
    (tmp_path / "x.py").write_text("from . import z\nfrom .. import y\nfrom ..y import f\n")
    (tmp_path / "__init__.py").write_text("from .x import g\nimport p.y.f\n")
    modules = dict.fromkeys(["p", "p.sub", "p.sub.x", "p.y"])
    assert _imports("p.sub.x", tmp_path / "x.py", modules) == {"p.sub", "p.y"}
    assert _imports("p.sub", tmp_path / "__init__.py", modules) == {"p.sub.x", "p.y"}


def test_no_import_cycles():
    graph = import_graph()
    comps = {tuple(sorted(c)) for c in strongly_connected(graph)}
    new = [c for c in comps if c not in KNOWN_CYCLES]
    assert not new, "import cycles: " + "; ".join(
        " -> ".join(_cycle_in(graph, set(c))) for c in sorted(new)
    )
    gone = KNOWN_CYCLES - comps
    assert not gone, f"known cycles now gone, drop them from KNOWN_CYCLES: {sorted(gone)}"


def test_every_module_has_a_stage():
    missing = sorted({group(m) for m in import_graph()} - STAGES.keys())
    assert not missing, f"place these in STAGES (tests/test_layout.py): {missing}"


def test_no_import_against_the_data_flow():
    upward = upward_imports(import_graph(), STAGES)
    assert not upward, "a lower stage imports a higher one:\n" + "\n".join(upward)
