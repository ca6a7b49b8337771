"""Deprecated: ``bwbench.report.document`` moved to ``bwbench.render.document`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.report.document moved to bwbench.render.document; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.render.document")
