"""Old import paths of moved modules still work for plug-ins and notebooks, with a DeprecationWarning
naming the new path; the plug-in paths that did not move import without a warning."""

import importlib
import subprocess
import sys

import pytest

ALIASES = {
    "bwbench.problems.box": "bwbench.optimize.box",
    "bwbench.data.synthetic": "bwbench.datasets.synthetic",
    "bwbench.data.mr_damper": "bwbench.datasets.mr_damper",
    "bwbench.report.palette": "bwbench.render.palette",
    "bwbench.report.format": "bwbench.render.format",
    "bwbench.report.labels": "bwbench.render.labels",
    "bwbench.report.document": "bwbench.render.document",
    "bwbench.report.figures": "bwbench.render.figures",
    "bwbench.data.parameters": "bwbench.models.switched_parameters",
    "bwbench.problems.model_problem": "bwbench.problems.hysteresis.model_problem",
    "bwbench.problems.joint_problem": "bwbench.problems.hysteresis.joint_problem",
    "bwbench.problems.fitted_model": "bwbench.problems.hysteresis.fitted_model",
}


@pytest.mark.parametrize("old, new", sorted(ALIASES.items()))
def test_an_old_path_warns_and_gives_the_moved_module(old, new):
    probe = (
        "import warnings; warnings.simplefilter('always')\n"
        "with warnings.catch_warnings(record=True) as seen:\n"
        f"    import {old} as old\n"
        f"import {new} as new; assert old is new, (old, new)\n"
        "print([str(w.message) for w in seen if w.category is DeprecationWarning])"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert f"{old} moved to {new}" in done.stdout


@pytest.mark.parametrize(
    "path",
    [
        "bwbench.models.base",
        "bwbench.optimize.registry",
        "bwbench.optimize.options",
        "bwbench.testing",
        "bwbench.problems",
    ],
)
def test_the_plugin_paths_did_not_move(path):
    probe = f"import warnings; warnings.filterwarnings('error', '.* moved to ', DeprecationWarning); import {path}"
    assert subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True).returncode == 0
    assert importlib.import_module(path).__name__ == path
