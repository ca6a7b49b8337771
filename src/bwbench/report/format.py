"""Deprecated: ``bwbench.report.format`` moved to ``bwbench.render.format`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.report.format moved to bwbench.render.format; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.render.format")
