"""The layout's promises: no import cycle inside bwbench (lazy imports included), layers that run one way,
no private name imported from another module, and no module so long that it is surely two ideas."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
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


def _imports(name: str, path: Path, known: set, only=None) -> set:
    """Every bwbench module ``name`` imports, at module level or inside functions. Importing ``a.b.c``
    also runs the packages ``a.b`` and ``a``: those count too, except the packages ``name`` itself
    lives in (they run before it whatever it imports); naming one of those explicitly does count."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in [only] if only is not None else ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                anchor = name.split(".") if is_package else name.split(".")[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
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
                return stack[stack.index(nxt) :] + [nxt]
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


# A smoke alarm, not a rule: modules are split by idea, never by size (docs/contributing.md).
LONGEST = 800
# One idea that is long: the model protocol, every member documented with numpydoc sections.
LONGER = {"bwbench.models.base": 900}


@pytest.mark.parametrize("name, path", sorted(_modules().items()))
def test_no_module_is_so_long_that_it_is_surely_two_ideas(name, path):
    assert len(path.read_text(encoding="utf-8").splitlines()) <= LONGER.get(name, LONGEST), name


def private_imports(modules: dict) -> list[str]:
    """``path:line: module imports _name from other`` for every private name (one leading underscore)
    one module imports from another bwbench module: a name another module needs is public."""
    found = []
    for name, path in sorted(modules.items()):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("bwbench"):
                for alias in node.names:
                    if alias.name.startswith("_") and not alias.name.startswith("__"):
                        shown = path.relative_to(ROOT) if ROOT in path.parents else path
                        found.append(f"{shown}:{node.lineno}: {name} imports {alias.name} from {node.module}")
    return found


def test_no_module_imports_another_modules_private_names():
    wrong = private_imports(_modules())
    assert not wrong, "private names imported across modules (make them public where they are shared):\n" + "\n".join(
        wrong
    )


def test_a_private_import_is_named_with_its_line(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from bwbench.models.switched.kernel import _HA\n", encoding="utf-8")
    wrong = private_imports({"bwbench.models.bad": bad})
    assert wrong == [f"{bad}:1: bwbench.models.bad imports _HA from bwbench.models.switched.kernel"]


# The layers the issue of models as plug-ins asked for: the report and the store read results and
# never the runner or the optimiser registry; models know nothing of problems, studies or reports.
LOWER_LAYERS = {
    "bwbench.report": ("bwbench.study", "bwbench.engine"),
    "bwbench.database": ("bwbench.study", "bwbench.engine", "bwbench.report"),
    "bwbench.models": ("bwbench.problems", "bwbench.study", "bwbench.engine", "bwbench.report", "bwbench.database"),
}


@pytest.mark.parametrize("layer", sorted(LOWER_LAYERS))
def test_a_layer_does_not_import_the_layers_above_it(layer):
    modules = _modules()
    above = LOWER_LAYERS[layer]
    wrong = sorted(
        f"{name} -> {target}"
        for name, path in modules.items()
        if name.startswith(layer)
        for target in _imports(name, path, set(modules))
        if target.startswith(above)
    )
    assert not wrong, wrong


# The order of the sub-packages, top layer first, written once: a module may import its own
# sub-package and those of the layers below it, never one above it or beside it (docs/contributing.md).
LAYERS = (
    ("bwbench.__main__",),
    ("bwbench", "bwbench.cli"),
    ("bwbench.commands",),
    ("bwbench.api", "bwbench.testing"),
    ("bwbench.study",),
    ("bwbench.report",),
    ("bwbench.database",),
    ("bwbench.problems",),
    ("bwbench.optimizers",),
    ("bwbench.engine",),
    ("bwbench.datasets",),
    ("bwbench.models",),
    ("bwbench.render",),
    ("bwbench.data", "bwbench.analysis"),
    (
        "bwbench.plugins",
        "bwbench.limits",
        "bwbench.threads",
        "bwbench.version",
        "bwbench.notices",
        "bwbench.text_streams",
    ),
    ("bwbench.errors",),
)
ROOMS = {room: depth for depth, layer in enumerate(LAYERS) for room in layer}


def room_of(module: str) -> str:
    """The sub-package (or top-level module) of LAYERS that ``module`` belongs to."""
    parts = module.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in ROOMS:
            return ".".join(parts[:k])
    raise AssertionError(f"{module} is in no layer of LAYERS: add its sub-package there")


def layer_violations(modules: dict) -> list[str]:
    """``path:line: module -> target`` for every import (module level or in a function) of a room that
    is not below the importer's, nor its own."""
    known, found = set(modules), []
    for name, path in sorted(modules.items()):
        source = room_of(name)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            for target in sorted(_imports(name, path, known, only=node)):
                aim = room_of(target)
                if aim != source and ROOMS[aim] <= ROOMS[source]:
                    where = "beside" if ROOMS[aim] == ROOMS[source] else "above"
                    shown = path.relative_to(ROOT) if ROOT in path.parents else path
                    found.append(
                        f"{shown}:{node.lineno}: {name} imports {target} ({aim} is {where} {source} in LAYERS)"
                    )
    return found


def test_every_module_is_in_a_layer():
    for name in _modules():
        room_of(name)


def test_the_layers_run_one_way():
    wrong = layer_violations(_modules())
    assert not wrong, "imports against the order of LAYERS:\n" + "\n".join(wrong)


def test_a_wrong_import_is_named_with_its_line(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import math\n\nfrom bwbench.study import config\n", encoding="utf-8")
    modules = {**_modules(), "bwbench.models.bad": bad}
    wrong = [line for line in layer_violations(modules) if "bwbench.models.bad" in line]
    assert any(
        line.endswith(
            "bad.py:3: bwbench.models.bad imports bwbench.study.config "
            "(bwbench.study is above bwbench.models in LAYERS)"
        )
        for line in wrong
    ), wrong
