"""The layout's promises: no import cycle inside bwbench (lazy imports included), no module over 400 lines."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"bwbench": ROOT / "src" / "bwbench", "bwbench.optimizers": ROOT / "optimizers"}


def _modules() -> dict[str, Path]:
    out = {}
    for package, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([package, *parts])] = path
    return out


def _ancestors(name: str) -> set:
    return {".".join(name.split(".")[:k]) for k in range(1, name.count(".") + 1)}


def _imports(name: str, path: Path, known: set) -> set:
    """Every bwbench module ``name`` imports, at module level or inside functions. Importing ``a.b.c``
    also runs the packages ``a.b`` and ``a``: those count too, except the packages ``name`` itself
    lives in (they run before it whatever it imports); naming one of those explicitly does count."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                anchor = name.split(".") if is_package else name.split(".")[:-1]
                anchor = anchor[:len(anchor) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
        for target in targets:
            if target in known:
                found.add(target)
            found |= (_ancestors(target) & known) - _ancestors(name)
    found.discard(name)
    return found


def find_cycle(graph: dict) -> list | None:
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        state[node] = "done"
        stack.pop()
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_the_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_no_import_cycle_inside_bwbench():
    modules = _modules()
    assert "bwbench.report.build" in modules and "bwbench.optimizers.pso" in modules
    graph = {name: _imports(name, path, set(modules)) for name, path in modules.items()}
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


@pytest.mark.parametrize("name, path", sorted(_modules().items()))
def test_no_module_over_400_lines(name, path):
    assert len(path.read_text(encoding="utf-8").splitlines()) <= 400, name


# The layers the issue of models as plug-ins asked for: the report and the store read results and
# never the runner or the optimiser registry; models know nothing of problems, studies or reports.
LOWER_LAYERS = {
    "bwbench.report": ("bwbench.study", "bwbench.optimize"),
    "bwbench.store": ("bwbench.study", "bwbench.optimize", "bwbench.report"),
    "bwbench.models": ("bwbench.problems", "bwbench.study", "bwbench.optimize", "bwbench.report", "bwbench.store"),
}


@pytest.mark.parametrize("layer", sorted(LOWER_LAYERS))
def test_a_layer_does_not_import_the_layers_above_it(layer):
    modules = _modules()
    above = LOWER_LAYERS[layer]
    wrong = sorted(f"{name} -> {target}" for name, path in modules.items() if name.startswith(layer)
                   for target in _imports(name, path, set(modules)) if target.startswith(above))
    assert not wrong, wrong
