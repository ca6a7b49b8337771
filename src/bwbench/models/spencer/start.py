"""The arrays Spencer's kernels read of a record, kept for the last record asked for. The model starts at
rest at the first sample it is given; how a record is started (from rest, or after a pre-roll of its
own motion) is the same for every model and decided where the record is simulated
(``bwbench.models.start``)."""

from __future__ import annotations

import numpy as np

_LAST_INPUTS: tuple = (None, None)  # (record, its kernel inputs): a fit simulates one record many times


def kernel_inputs(signal) -> list:
    """(t, x, v, a) of a record as both kernels take them (``kernel_arrays``), kept for the last record
    asked for (one tuple, swapped whole: joint fits' threads)."""
    from bwbench.models.spencer.kernel import kernel_arrays

    global _LAST_INPUTS
    last = _LAST_INPUTS
    if last[0] is signal:
        return last[1]
    arrays = kernel_arrays(*(np.asarray(getattr(signal, k), dtype=float) for k in "txva"))
    _LAST_INPUTS = (signal, arrays)
    return arrays
