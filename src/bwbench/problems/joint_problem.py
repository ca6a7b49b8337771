"""Deprecated: ``bwbench.problems.joint_problem`` moved to ``bwbench.problems.hysteresis.joint_problem`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.problems.joint_problem moved to bwbench.problems.hysteresis.joint_problem; import it from there",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = importlib.import_module("bwbench.problems.hysteresis.joint_problem")
