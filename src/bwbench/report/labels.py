"""Deprecated: ``bwbench.report.labels`` moved to ``bwbench.render.labels`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.report.labels moved to bwbench.render.labels; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.render.labels")
