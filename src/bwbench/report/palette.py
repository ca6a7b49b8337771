"""Deprecated: ``bwbench.report.palette`` moved to ``bwbench.render.palette`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.report.palette moved to bwbench.render.palette; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.render.palette")
