"""Deprecated: ``bwbench.problems.model_problem`` moved to ``bwbench.problems.hysteresis.model_problem`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.problems.model_problem moved to bwbench.problems.hysteresis.model_problem; import it from there",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = importlib.import_module("bwbench.problems.hysteresis.model_problem")
