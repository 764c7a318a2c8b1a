"""The import graph shows the data flow: no cycle, and no import from a lower layer up.

Every ``import`` counts, function-local ones included (a cycle held apart by a
deferred import is still a cycle). Layers, lowest first (README, "What is here"):
the planner; shared leaves of the bench (files, flags, actuators, controllers); the simulation;
the tables runs write and reports read; the batch machinery; the experiments that run
trials; the reports that read tables and write documents; the command line; the API.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"slopewalk": ROOT / "slopewalk", "slopewalk.planner": ROOT / "planner",
           "slopewalk.bench": ROOT / "bench"}  # fmt: skip
LAYERS = (  # (module prefix, layer): the longest matching prefix decides
    ("slopewalk.planner", 0),
    ("slopewalk.bench.actuators", 1),
    ("slopewalk.bench.digest", 1),
    ("slopewalk.bench.files", 1),
    ("slopewalk.bench.flags", 1),
    ("slopewalk.bench.controllers", 1),
    ("slopewalk.bench.sim", 2),
    ("slopewalk.bench.robot_import", 2),
    ("slopewalk.bench.tables", 3),
    ("slopewalk.bench.batch", 4),
    ("slopewalk.bench.experiments", 5),
    ("slopewalk.bench.report", 6),
    ("slopewalk.bench.commands", 7),
    ("slopewalk.bench.cli", 7),
    ("slopewalk.bench", 7),
    ("slopewalk", 8),
)


def _modules() -> dict[str, Path]:
    found = {}
    for package, folder in FOLDERS.items():
        for path in folder.rglob("*.py"):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[0] in ("planner", "bench") and package == "slopewalk":
                continue
            name = ".".join((package, *parts)).removesuffix(".__init__")
            found[name] = path
    return found


def _imports(path: Path, name: str, known: set[str]) -> set[str]:
    out = set()
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = name if is_package else name.rsplit(".", 1)[0]
                for _ in range(node.level - 1):
                    parent = parent.rsplit(".", 1)[0]
                base = f"{parent}.{base}" if base else parent
            targets = [f"{base}.{alias.name}" for alias in node.names] + [base]
        else:
            continue
        for target in targets:
            while target and target not in known:  # a name inside a module: the module
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    known = set(modules)
    return {name: _imports(path, name, known) for name, path in modules.items()}


def _layer(module: str) -> int:
    matches = [(len(p), rank) for p, rank in LAYERS if module == p or module.startswith(p + ".")]
    return max(matches)[1]


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
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
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_sees_every_module_and_its_imports():
    graph = _graph()
    assert "slopewalk.bench.sim.trial" in graph and "slopewalk.planner.kernel.run" in graph
    assert "slopewalk.bench.sim.trial_spec" in graph["slopewalk.bench.sim.trial"]
    assert "slopewalk.planner.plan" in graph["slopewalk"]  # TYPE_CHECKING imports count too


def test_the_package_import_graph_has_no_cycle():
    assert _cycles(_graph()) == []


def test_no_module_imports_from_a_higher_layer():
    upward = [
        f"{module} (layer {_layer(module)}) imports {target} (layer {_layer(target)})"
        for module, targets in sorted(_graph().items())
        for target in sorted(targets)
        if _layer(target) > _layer(module)
    ]
    assert upward == []


def test_the_planner_imports_nothing_of_the_bench():
    leaks = [
        (m, t)
        for m, targets in _graph().items()
        if m.startswith("slopewalk.planner")
        for t in targets
        if not t.startswith("slopewalk.planner")
    ]
    assert leaks == []


def test_the_cycle_finder_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
