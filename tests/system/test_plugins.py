"""One failure policy for the three plug-in registries (optimisers, problems, models): an installed
plug-in that fails to load breaks only itself, and asking for it is one line naming its entry point
and its error. (Installed packages end to end: tests/system/test_plugin_packages.py.)"""

from importlib.metadata import EntryPoint

import pytest

from bwbench import plugins, problems
from bwbench.engine import registry as optimizers
from bwbench.errors import UserError
from bwbench.models import registry as models

MISSING = "ModuleNotFoundError: No module named 'no_such_plugin_module'"


def broken_entry_point(name: str, group: str) -> EntryPoint:
    return EntryPoint(name=name, value="no_such_plugin_module:THING", group=group)


def expected(kind: str, name: str, group: str) -> str:
    return (
        f"{kind} plug-in {name!r} (entry point 'no_such_plugin_module:THING' of group {group!r}) "
        f"failed to load: {MISSING}"
    )


def installed(monkeypatch, module, *eps):
    """Make ``module``'s registry see ``eps`` as the installed entry points, loaded afresh."""
    monkeypatch.setattr(plugins, "entry_points", lambda group: [ep for ep in eps if ep.group == group])
    monkeypatch.setattr(module.REGISTRY, "plugins_loaded", False)
    monkeypatch.setattr(module.REGISTRY, "broken", {})
    monkeypatch.setattr(module.REGISTRY, "from_entry_points", set())


def test_a_broken_optimiser_plugin_breaks_only_itself(monkeypatch):
    installed(monkeypatch, optimizers, broken_entry_point("bad-search", "bwbench.optimizers"))
    assert "cmaes" in optimizers.available() and "random" in optimizers.available()  # the others still work
    line = expected("optimiser", "bad-search", "bwbench.optimizers")
    assert optimizers.broken() == {"bad-search": line}
    with pytest.raises(plugins.PluginError) as named:
        optimizers.get("bad-search")
    assert str(named.value) == line
    with pytest.raises(
        UserError,
        match=r"^unknown optimiser 'nope'; available: .*random.*; optimiser plug-in "
        r"'bad-search' .* failed to load: ModuleNotFoundError",
    ):
        optimizers.get("nope")


def test_a_broken_model_plugin_breaks_only_itself(monkeypatch):
    installed(monkeypatch, models, broken_entry_point("bad-model", "bwbench.models"))
    assert {"switched-bouc-wen", "spencer", "bouc-wen"} <= set(models.names())
    with pytest.raises(plugins.PluginError) as named:
        models.get("bad-model")
    assert str(named.value) == expected("model", "bad-model", "bwbench.models")


def test_a_broken_problem_plugin_breaks_only_itself(monkeypatch):
    installed(monkeypatch, problems, broken_entry_point("bad-problem", "bwbench.problems"))
    with pytest.raises(plugins.PluginError) as named:
        problems.get("bad-problem")
    assert str(named.value) == expected("problem", "bad-problem", "bwbench.problems")
    assert problems.get("hysteresis").name == "hysteresis"
    assert problems.get("switched-bouc-wen") is problems.get("hysteresis")  # its former name still reads


def test_a_plugin_of_the_wrong_type_is_named():
    ep = EntryPoint(name="wrong", value="bwbench.errors:UserError", group="bwbench.problems")
    with pytest.raises(
        plugins.PluginError,
        match=r"^problem plug-in 'wrong' \(entry point 'bwbench.errors:UserError' "
        r"of group 'bwbench.problems'\) gives .*not a bwbench.problems",
    ):
        problems._read(ep, plugins.load(ep, "problem"))
