"""The switched (asymmetric) Bouc-Wen model of the paper, eqs 2-5, compiled with numba.

Displacement-driven: given x(t), ẋ(t), ẍ(t) on sample times, the force is

    F = ẍ + 2·ξ·ωn·ẋ + α·ωn²·x + (1 − α)·ωn²·z
    dz = (A − (β + γ·sign(z·dx))·|z|^n)·dx        (eqs 4-5, rate-independent)

with the '+' set while ẋ ≥ 0 and the '−' set while ẋ < 0. Units follow the specimen files:
x in mm, t in s, F in N; ωn in rad/s, z in mm.

Parameter vectors are ordered as ``PARAM_NAMES``. Two state conventions:

- ``shared`` (default): one z, driven by whichever branch is active;
- ``split``: z₊ and z₋ are separate and each holds its value while its branch is idle.

Integration is in displacement, per sample interval, with the velocity reversal located inside
the interval (linear interpolation of ẋ, cubic Hermite for x). Each piece is integrated with
classical RK4 in as many substeps as the local stiffness needs. The loading attractor
z_s = (A/(β+γ))^(1/n) relaxes at rate n·A/z_s per mm, which for n < 1 reaches 10⁴/mm inside
Table 5; past ``_RK4_MAX_SUBSTEPS`` substeps an L-stable backward-Euler step (scalar Newton,
bracketed) takes over so such parameter sets cost bounded time and do not go unstable. It also takes
a loading piece that starts settled on its attractor (within 1e-2·z_s, more than 8 substeps of work:
``kernel.takes_implicit``), where z only relaxes onto z_s.
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.switched import lockstep
from bwbench.models.switched.kernel import (
    N_PARAMS,
    STATES,
    hysteretic_batch_scalar,
    mse_parallel,
    mse_serial,
    simulate_one,
)


def as_excitation(t, x, v, a):
    arrays = [np.ascontiguousarray(np.asarray(arr, dtype=np.float64)) for arr in (t, x, v, a)]
    n = arrays[0].shape[0]
    if any(arr.ndim != 1 or arr.shape[0] != n for arr in arrays):
        raise ValueError("t, x, v and a must be 1-D arrays of equal length")
    return arrays


def check_state(state: str) -> bool:
    if state not in STATES:
        raise ValueError(f"state must be one of {STATES}, got {state!r}")
    return state == "split"


def simulate(params, t, x, v, a, state: str = "shared") -> np.ndarray:
    """Force (N) of one 14-parameter set on an excitation given at sample times.

    ``t`` in s, ``x`` in mm, ``v`` in mm/s, ``a`` in mm/s², all 1-D of length L. Returns an
    array of length L; every entry is +inf when the model blows up (z or F not finite).
    """
    split = check_state(state)
    p = np.ascontiguousarray(np.asarray(params, dtype=np.float64))
    if p.shape != (N_PARAMS,):
        raise ValueError(f"params must have shape ({N_PARAMS},), got {p.shape}")
    t, x, v, a = as_excitation(t, x, v, a)
    return simulate_one(p, t, x, v, a, split)


def hysteretic_state(H, t, x, v, state: str = "shared") -> np.ndarray:
    """Hysteretic variable z (mm) at the sample times for the 8 parameters H.

    ``H`` = (A+, n+, β+, γ+, A−, n−, β−, γ−) = ``params[HYSTERETIC_INDEX]``; ``t`` in s, ``x`` in mm,
    ``v`` in mm/s, 1-D of length L. Returns the z of the branch active at each sample (split: z₋
    where v < 0, else z₊), all +inf if it is not finite somewhere; ``simulate`` is exactly
    a + 2ξωn·v + αωn²·x + (1 − α)ωn²·z with it (same integration path).
    """
    return hysteretic_state_batch(np.asarray(H, dtype=np.float64)[None], t, x, v, state, kernel="scalar")[0]


def hysteretic_state_batch(H, t, x, v, state: str = "shared", *, kernel: str = "lockstep") -> np.ndarray:
    """``hysteretic_state`` of each row of ``H`` (shape (m, 8)): Z of shape (m, L), +inf rows on blow-up.

    ``kernel="scalar"``: one row at a time (the reference); default: rows in lockstep, same result.
    """
    split = check_state(state)
    H = np.ascontiguousarray(np.atleast_2d(np.asarray(H, dtype=np.float64)))
    if H.ndim != 2 or H.shape[1] != 8:
        raise ValueError(f"H must have shape (m, 8), got {H.shape}")
    t, x, v, _ = as_excitation(t, x, v, v)
    lockstep = _lockstep_module(kernel)
    if lockstep is not None:
        return lockstep.run_hysteretic(H, t, x, v, split)
    return hysteretic_batch_scalar(H, t, x, v, split)


def _lockstep_module(kernel: str):
    if kernel not in ("lockstep", "scalar"):
        raise ValueError(f"kernel must be 'lockstep' or 'scalar', got {kernel!r}")
    if kernel == "scalar":
        return None
    return lockstep


def mse_batch(P, t, x, v, a, f_meas, state: str = "shared", *, kernel: str = "lockstep") -> np.ndarray:
    """Mean squared force error (N²) of each row of ``P`` (shape (m, 14)) against ``f_meas``.

    Rows whose simulation is not finite get +inf. Rows run in parallel over numba's threads;
    ``numba.set_num_threads(1)`` makes it single-core. ``kernel="scalar"``: one row at a time
    (the reference); default: several rows in lockstep (``bwbench.lockstep``), same result.
    """
    split = check_state(state)
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(P, dtype=np.float64)))
    if P.ndim != 2 or P.shape[1] != N_PARAMS:
        raise ValueError(f"P must have shape (m, {N_PARAMS}), got {P.shape}")
    t, x, v, a = as_excitation(t, x, v, a)
    f_meas = np.ascontiguousarray(np.asarray(f_meas, dtype=np.float64))
    if f_meas.shape != x.shape:
        raise ValueError("f_meas must have the same length as the excitation")
    lockstep = _lockstep_module(kernel)
    if lockstep is not None:
        return lockstep.run_mse(P, t, x, v, a, f_meas, split)
    # One-point optimisers call this row by row: waking numba's thread pool would cost more
    # than the simulation, so small batches run on the calling thread.
    scalar = mse_serial if P.shape[0] < 4 or numba.get_num_threads() == 1 else mse_parallel
    return scalar(P, t, x, v, a, f_meas, split)  # IEEE semantics inside (error_model="numpy")
