"""The import graph of src/geocode (docs/design.md, Layers): no cycle, and each layer imports
only the layers below it. Built from the source's AST, so imports inside functions count, and
relative imports are resolved."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "geocode"
# The layers above the core, lowest first; every other module is the core (errors, config,
# recipe, points, ..., and the bpy side: nodes/, program, blender/; the networks: models/).
# The product's two halves: reconstruct/ (users' shapes -> programs; the evaluation step fits
# with it too) and steps/ (the workflow's stages).
LAYERS = ("reconstruct", "steps", "tools", "bench", "cli")
# The steps in the workflow's order: a step may import the steps before it, never one after.
STEPS = ("dataset", "train_data", "train", "evaluate", "tables", "real_shapes", "report")


def module_files() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package."""
    out = {}
    for path in sorted((SRC / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def owner(name: str, modules: dict[str, Path]) -> str | None:
    """The module that `name` (a module, or a name inside one) belongs to."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def imported(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that `module` imports anywhere in its file."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found.update(owner(alias.name, modules) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            # `from geocode import editing` imports the module geocode.tools.editing
            found.update(owner(f"{base}.{alias.name}", modules) if f"{base}.{alias.name}" in modules
                         else owner(base, modules) for alias in node.names)
    return found - {None, module}


def import_graph() -> dict[str, set[str]]:
    modules = module_files()
    return {m: imported(m, path, modules) for m, path in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as [a, b, ..., a], or None (depth-first, iterative)."""
    state: dict[str, int] = {}          # 1: on the current path, 2: finished
    for root in sorted(graph):
        if root in state:
            continue
        path, stack = [root], [iter(sorted(graph[root]))]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(graph[nxt])))
    return None


def layer(module: str) -> int:
    """0 for the core, else 1 + the position in LAYERS of the module's first name below geocode."""
    top = module.split(".")[1] if "." in module else ""
    return LAYERS.index(top) + 1 if top in LAYERS else 0


def test_the_import_graph_is_read_whole():
    graph = import_graph()
    assert "geocode.checkpoints" in graph["geocode.bench.fit"]           # a module-level import
    assert "geocode.program" in graph["geocode.cli"]                     # an import inside a function
    assert graph["geocode.models"] >= {"geocode.models.network"}         # a relative import


def test_no_import_cycle():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_find_cycle_names_the_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_each_layer_imports_only_the_layers_below():
    upward = sorted(f"{m} -> {d}" for m, deps in import_graph().items() for d in deps if layer(d) > layer(m))
    assert not upward, f"imports of a higher layer ({' < '.join(['core', *LAYERS])}): " + "; ".join(upward)


def test_a_step_imports_only_the_steps_before_it():
    position = {f"geocode.steps.{name}": i for i, name in enumerate(STEPS)}
    graph = import_graph()
    assert set(position) == {m for m in graph if m.startswith("geocode.steps.")}, "a step missing from STEPS"
    later = sorted(f"{m} -> {d}" for m in position for d in graph[m] if position.get(d, -1) > position[m])
    assert not later, "a step imports a later one: " + "; ".join(later)
