"""What the lockstep kernel reads before it runs: the excitation cut into pieces at the reversals (per
sample interval: displacement steps, branch, state slot) and the parameter rows loaded per lane."""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.switched.kernel import (
    loading_attractor,
    reversal_pieces,
)


@numba.njit(cache=True, error_model="numpy")
def excitation_pieces(t, x, v, split):
    """Per sample interval k and piece j (before/after a reversal): dx (mm), branch, z slot
    (1: z₋ of the split convention, 0: z₊ or the shared z); active[k]: the slot reported at k + 1."""
    n = max(x.shape[0] - 1, 0)
    dx = np.zeros((n, 2))
    branch = np.zeros((n, 2), dtype=np.int64)
    slot = np.zeros((n, 2), dtype=np.int64)
    active = np.zeros(n, dtype=np.int64)
    for k in range(n):
        b0 = 0 if v[k] >= 0.0 else 1  # as kernel.branch_offset
        b1 = 0 if v[k + 1] >= 0.0 else 1
        if b0 == b1:
            dx[k, 0] = x[k + 1] - x[k]
        else:
            dx[k, 0], dx[k, 1] = reversal_pieces(t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1])
        branch[k, 0], branch[k, 1] = b0, b1
        slot[k, 0] = 1 if split and b0 == 1 else 0
        slot[k, 1] = 1 if split and b1 == 1 else 0
        active[k] = slot[k, 1]
    return dx, branch, slot, active


@numba.njit(cache=True, error_model="numpy")
def load_rows(H, rows):
    """Per branch and lane: A, n, β+γ, β−γ, z_s, n·A/z_s of rows ``rows`` of H, each (2, K)."""
    out = np.empty((6, 2, rows.shape[0]))
    for lane in range(rows.shape[0]):
        r = rows[lane]
        for b in range(2):
            beta, gamma = H[r, 4 * b + 2], H[r, 4 * b + 3]
            out[0, b, lane] = H[r, 4 * b]
            out[1, b, lane] = H[r, 4 * b + 1]
            out[2, b, lane] = beta + gamma
            out[3, b, lane] = beta - gamma
            out[4, b, lane], out[5, b, lane] = loading_attractor(H[r], b)
    return out[0], out[1], out[2], out[3], out[4], out[5]
