"""Deprecated: ``bwbench.data.mr_damper`` moved to ``bwbench.datasets.mr_damper`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.data.mr_damper moved to bwbench.datasets.mr_damper; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.datasets.mr_damper")
