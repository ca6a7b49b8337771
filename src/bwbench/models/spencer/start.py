"""How Spencer's model starts a record, and the arrays its kernels read: a record that starts from rest
starts the model at rest (y = x, z = 0), one cut from a running test after a pre-roll cycle of its own
motion (``kernel.preroll_end``); the kernels tell the two apart by the first velocity sample,
exactly 0 for a start from rest (``kernel_inputs``)."""

from __future__ import annotations

import numpy as np

_LAST_INPUTS: tuple = (None, None)  # (record, its kernel inputs): a fit simulates one record many times


def kernel_inputs(signal) -> list:
    """(t, x, v, a) of a record as both kernels take them (``kernel_arrays``). A record that starts from
    rest (``starts_from_rest``) is given with its first velocity sample at exactly 0: the kernel then
    starts the model at rest instead of after a pre-roll cycle. (The sensitivities once skipped this and
    simulated such a record from its pre-rolled state: 17 mm/s of ẏ apart from the plain simulation on
    a ramped sine.) Kept for the last record asked for (one tuple, swapped whole: joint fits' threads)."""
    from bwbench.models.spencer.kernel import kernel_arrays

    global _LAST_INPUTS
    last = _LAST_INPUTS
    if last[0] is signal:
        return last[1]
    t, x, v, a = (np.asarray(getattr(signal, k), dtype=float) for k in "txva")
    if v[0] != 0.0 and starts_from_rest(t, x, v):
        v = v.copy()
        v[0] = 0.0
    arrays = kernel_arrays(t, x, v, a)
    _LAST_INPUTS = (signal, arrays)
    return arrays


REST_VELOCITY = 0.02  # × max|ẋ|: the record's first samples move slower than this: it starts from rest
REST_POSITION = 0.1  # × amplitude: ... and from near mid-stroke (a record cut at a reversal is at an end)


def starts_from_rest(t, x, v) -> bool:
    """Whether a record starts from rest: over its first few samples (3, or 0.2 % of the record) the
    recorded or estimated velocity stays within its noise-level ``REST_VELOCITY`` × max|ẋ|, and the
    damper sits near mid-stroke (within ``REST_POSITION`` × the amplitude of (x_max + x_min)/2) or the
    test ramps in (``steady_part``). A record cut from the middle of a test at a reversal also has
    ẋ ≈ 0 at its start, but there x is at an end of the stroke and the damper is loaded."""
    from bwbench.data.steady_part import steady_part

    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    head = max(3, len(v) // 500)
    if not np.median(np.abs(v[:head])) <= REST_VELOCITY * float(np.max(np.abs(v))):
        return False
    mid, amplitude = 0.5 * (x.max() + x.min()), 0.5 * float(np.ptp(x))
    return bool(abs(x[0] - mid) <= REST_POSITION * amplitude or steady_part(t, x).ramp_in_cycles > 0)


def initial_state(signal) -> str:
    """Which initial state the model starts a record from, in words (for the fit's result)."""
    from bwbench.models.spencer.kernel import kernel_arrays, preroll_end

    t, x, v = (np.asarray(getattr(signal, k), dtype=float) for k in "txv")
    if v[0] == 0.0 or starts_from_rest(t, x, v):
        return "from rest (y = x, z = 0 at the first sample): the record starts from rest"
    k = int(preroll_end(*kernel_arrays(x, v)))
    if k == 0:
        return "from rest (y = x, z = 0 at the first sample): the record has no full cycle to pre-roll"
    return (
        f"in motion: the record starts moving, so the model starts from the state it reaches after one cycle "
        f"of the record's own motion (pre-roll to t = {t[k]:.4g} s)"
    )
