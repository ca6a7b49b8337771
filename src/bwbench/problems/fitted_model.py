"""Deprecated: ``bwbench.problems.fitted_model`` moved to ``bwbench.problems.hysteresis.fitted_model`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.problems.fitted_model moved to bwbench.problems.hysteresis.fitted_model; import it from there",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = importlib.import_module("bwbench.problems.hysteresis.fitted_model")
