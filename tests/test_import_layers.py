"""The package's modules import each other without circles, and the layers point one way
(cli, api -> worksheet -> tasks -> jobs -> filters / io -> core / params -> errors): a module never
imports, even inside a function, a module that imports it back."""

from __future__ import annotations

import ast
from pathlib import Path

import aldpat

PACKAGE = Path(aldpat.__file__).parent
#: The one exemption: discovery. These packages' ``__init__`` imports every module in them so that
#: each registers itself; importing the package means "load them all", not a dependency on a module.
#: The task registry imports ``aldpat.tasks`` so (``get_task``, a worker process about to run a
#: job) while every task module imports the registry: a circle by design (tasks/__init__ ->
#: tasks/thin -> jobs/registry -> tasks/__init__), which the graph leaves out by dropping these two
#: packages as import targets. Every other import, the modules inside them included, counts.
REGISTRIES = {"aldpat.tasks", "aldpat.filters"}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        targets: set[str] = set()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        # imports for type annotations only (``if TYPE_CHECKING:``) never run
        typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                       and getattr(block.test, "id", None) == "TYPE_CHECKING" for n in ast.walk(block)}
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("aldpat"):
                targets.add(node.module)
                targets.update(f"{node.module}.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                targets.update(a.name for a in node.names if a.name.startswith("aldpat"))
        graph[name] = {t for t in targets if t in modules and t != name and t not in REGISTRIES}
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_no_import_circles():
    graph = import_graph()
    assert len(graph) > 50
    # the task declaration is a leaf of jobs/: every module that runs tasks imports it plainly
    assert not {t for t in graph["aldpat.jobs.task"] if t.startswith("aldpat.jobs")}
    assert "aldpat.jobs.task" in graph["aldpat.jobs.run"]
    assert _cycle(graph) is None, " -> ".join(_cycle(graph) or [])


LAYERS = ["aldpat.cli", "aldpat.api", "aldpat.worksheet", "aldpat.tasks", "aldpat.jobs", "aldpat.filters", "aldpat.io", "aldpat.core"]


def test_lower_layers_never_import_upper_ones():
    rank = {layer: i for i, layer in enumerate(LAYERS)}

    def layer_of(module: str) -> int | None:
        return next((rank[layer] for layer in LAYERS if module == layer or module.startswith(layer + ".")), None)

    for module, targets in import_graph().items():
        mine = layer_of(module)
        for target in targets:
            theirs = layer_of(target)
            if mine is not None and theirs is not None:
                assert theirs >= mine, f"{module} imports {target}, a layer above it"
