"""Deprecated: ``bwbench.report.figures`` moved to ``bwbench.render.figures`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.report.figures moved to bwbench.render.figures; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.render.figures")
