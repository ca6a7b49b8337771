"""Deprecated: ``bwbench.problems.box`` moved to ``bwbench.optimize.box`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.problems.box moved to bwbench.optimize.box; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.optimize.box")
