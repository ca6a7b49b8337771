"""Deprecated: ``bwbench.data.parameters`` moved to ``bwbench.models.switched_parameters`` (docs/contributing.md#layout); this alias will go."""

import importlib
import sys
import warnings

warnings.warn(
    "bwbench.data.parameters moved to bwbench.models.switched_parameters; import it from there",
    DeprecationWarning,
    stacklevel=2,
)
sys.modules[__name__] = importlib.import_module("bwbench.models.switched_parameters")
