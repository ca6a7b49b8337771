"""Deprecated: ``bwbench.data.synthetic`` moved to ``bwbench.datasets.synthetic`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.data.synthetic moved to bwbench.datasets.synthetic; import it from there", DeprecationWarning, stacklevel=2
)
sys.modules[__name__] = importlib.import_module("bwbench.datasets.synthetic")
