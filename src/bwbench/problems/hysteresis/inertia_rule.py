"""The inertia rule of the linear solve: can the data fit the inertia coefficient m, or is it fixed?

Data only, decided once per design. σ̂ = robust force noise from 4th differences of F (polynomial
trends of degree < 4 cancel; Var Δ⁴ε = 70·σ²). With m_ref = 1 N·s²/mm (1 t, the paper's implicit
mass; a reference to say how large an inertia force could be, not a value anything is fixed at):

- excited   ⇔ m_ref·‖ẍ_c‖ ≥ κ·σ̂, ẍ_c = ẍ minus what the offsets absorb: the inertia force of the
  reference mass stands out of the noise over the record (κ = 10);
- separable ⇔ m_ref·‖ã⊥‖ ≥ κ·σ̂ and ‖ã⊥‖ ≥ 10⁻³·‖ã_c‖, ã⊥ = the *informative* acceleration
  orthogonal to the other fixed columns: the data pin m to ±m_ref/κ and the design is not
  near-singular.

The informative acceleration is ẍ, except in a **sine test**: a record whose displacement is a sine
to within ``SINE_TOLERANCE`` (rms of the misfit over the amplitude), over the whole record or over
its steady part (``bwbench.data.steady_part``: a rig ramps a sine in and out over a cycle or so;
those cycles are left out of the judgement, and the reason says so). There ẍ = −ω²·(x − x₀), which
lies in the span of the stiffness and offset columns: m is confounded with k however large the
inertia force and however small the noise. What a recorded sine's ẍ has outside that span is
harmonic distortion and the error of a differentiated signal, and the force misfit of any model is
far larger than the noise it would be compared with, so a fitted m follows model error (measured
MR-damper sines gave 0–5 t across the tests of one damper). In a sine test ã = −ω²·(x − x₀) with
the sine's own ω and x₀: one sine alone never separates m; sines at different frequencies fitted
jointly do (k − m·ω² differs between them), and so does a record that is not a sine.

When m is not fitted it is fixed at ``M_UNFITTED`` = 0: a specimen or damper on a test machine
moves grams to kilograms, not the tonne of the paper's normalisation, and on a record where m is
confounded or not excited the fit is the same whatever m is fixed at (k absorbs −m·ω²), but a
prediction of a test at another frequency is not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from bwbench.models.derivatives import robust_noise

M_REF = 1.0  # N·s²/mm = 1 t (1000 kg): the paper's F = ẍ + ... in the specimens' units
M_UNFITTED = 0.0  # N·s²/mm: the value of an m the data cannot fit (see the module docstring)
KAPPA = 10.0  # signal/noise (as norms over the record) needed to call a column excited
COLLINEAR = 1e-3  # ‖ẍ⊥‖/‖ẍ_c‖ below this: condition number > 1000, m and k_b not separable
RANK_TOL = 1e-9  # a unit-norm column this close to the span of the others is dependent
SINE_TOLERANCE = 0.03  # rms(x − best sine)/amplitude at or below this: a sine test (a triangle is 0.07)


def force_noise(f) -> float:
    """Robust estimate of the force noise σ (N) from the 4th differences of the record.

    Median absolute deviation (×1.4826) of Δ⁴F over √70; reversals, where F jumps, are outliers
    the median ignores. Floored at 1e-12·max|F| so a noise-free record gives a tiny positive σ.
    """
    f = np.asarray(f, dtype=float)
    return float(max(robust_noise(f), 1e-12 * np.max(np.abs(f)), np.finfo(float).tiny))


@dataclass(frozen=True)
class InertiaCheck:
    """Whether the data excite the inertia term; forces are rms over the record (N)."""

    excited: bool
    separable: bool
    reason: str
    inertia_rms_N: float  # m_ref·ẍ_c
    orthogonal_rms_N: float  # m_ref·ã⊥
    noise_N: float  # σ̂
    sine_segments: int = 0  # records of the design that are sine tests

    @property
    def fit(self) -> bool:
        return self.excited and self.separable


def pivoted_qr(cols):
    """Pivoted QR of the columns scaled to unit norm: Q (L, r), R (r, r) with G[:, perm[:r]]·diag(1/scale)
    = Q·R, perm, rank r (numerical, ``RANK_TOL``), scale."""
    G = np.column_stack(cols)
    scale = np.linalg.norm(G, axis=0)
    scale[scale == 0] = 1.0
    Q, R, perm = scipy.linalg.qr(G / scale, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(R)) > RANK_TOL * max(abs(R[0, 0]), 1e-300)))
    return Q[:, :rank], R[:rank, :rank], perm, rank, scale


def sine_test(t, x):
    """(−ω²·(x − x₀) over the whole record in mm/s², the ``SteadyPart`` it was judged on) when x is a sine
    within ``SINE_TOLERANCE`` — the whole record, or else its steady part: a rig ramps a sine test in
    and out over a cycle or so, and those cycles are not the test (``bwbench.data.steady_part``);
    None when it is not a sine test. The sine's ω and x₀ are the steady part's, and ẍ = −ω²·(x − x₀)
    replaces the acceleration over the whole record: the ramps alone would separate m from k only by
    their envelope, far less than the model error a fitted m would then follow."""
    from bwbench.data.steady_part import steady_part

    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    steady = steady_part(t, x)
    for part in (slice(0, len(x)),) + ((steady.part,) if steady.ramped else ()):
        sine = _fitted_sine(t[part], x[part])
        if sine is not None:
            return -((2.0 * np.pi / sine.period) ** 2) * (x - sine.offset), steady if part != slice(0, len(x)) else None
    return None


def _fitted_sine(t, x):
    """The sine fitted to x(t) when x is one within ``SINE_TOLERANCE``, else None."""
    from bwbench.models.excitation import fit_sine

    amplitude = 0.5 * float(np.ptp(x)) if len(x) else 0.0
    if len(x) < 8 or not amplitude > 0:
        return None
    try:
        sine = fit_sine(t, x)
    except (ValueError, np.linalg.LinAlgError):
        return None
    misfit = float(np.sqrt(np.mean((sine.evaluate(t)[0] - x) ** 2)))
    return sine if misfit <= SINE_TOLERANCE * amplitude else None


def _informative(signal) -> tuple[np.ndarray, int, list]:
    """(ã, number of sine tests, the ramps each sine test was judged without): ẍ of each record of
    ``signal`` (one, or its ``segments`` when it stacks several), with a sine test's ẍ replaced by
    −ω²·(x − x₀) (module docstring)."""
    a = np.array(signal.a, dtype=float)
    sines, ramps = 0, []
    for part in getattr(signal, "segments", None) or (slice(0, len(a)),):
        found = sine_test(np.asarray(signal.t)[part], np.asarray(signal.x)[part])
        if found is not None:
            a[part] = found[0]
            sines += 1
            if found[1] is not None:
                ramps.append(found[1].describe())
    return a, sines, ramps


def inertia_check(signal, f, layout, offsets=True, m_ref: float = M_REF, kappa: float = KAPPA) -> InertiaCheck:
    """Apply the rule of the module docstring to an excitation (t, x, v, a; optionally ``segments``,
    slices of the records it stacks) and force f (N)."""
    from bwbench.problems.hysteresis.linear.columns import branch_masks, fixed_columns

    masks = branch_masks(layout, signal.v)
    sigma = force_noise(f)
    L = len(signal.a)
    has_offsets = offsets is not False and any(source == "1" for _, source in layout.fixed)
    base = [m.astype(float) for m in masks.values() if m.any()] if has_offsets else []
    a = np.asarray(signal.a, dtype=float)
    a_c = a - (Q := pivoted_qr(base)[0]) @ (Q.T @ a) if base else a.copy()
    informative, sines, ramps = _informative(signal)
    ai_c = informative - Q @ (Q.T @ informative) if base else informative.copy()
    Q = pivoted_qr(fixed_columns(signal, layout, masks, offsets)[1])[0]
    a_o = informative - Q @ (Q.T @ informative)
    a_o -= Q @ (Q.T @ a_o)  # second pass: ã⊥ may be 1e-6 of ã (a sine)
    n_c, n_o, ni_c = np.linalg.norm(a_c), np.linalg.norm(a_o), np.linalg.norm(ai_c)
    excited = m_ref * n_c >= kappa * sigma
    separable = m_ref * n_o >= kappa * sigma and n_o >= COLLINEAR * ni_c
    rms = 1.0 / np.sqrt(L)
    head = (
        f"inertia force at m = {m_ref:g} N·s²/mm (= {m_ref:g} t): {m_ref * n_c * rms:.3g} N rms, "
        f"{m_ref * n_o * rms:.3g} N rms outside the span of the other fixed columns; force noise {sigma:.3g} N"
    )
    records = getattr(signal, "segments", None) or (None,)
    if sines:
        which = (
            "the record is a sine test"
            if len(records) == 1
            else "every record is a sine test"
            if sines == len(records)
            else f"{sines} of {len(records)} records are sine tests"
        )
        head += f"; {which} (ẍ = −ω²·x)"
        if ramps:
            head += (
                f", judged on its steady part ({'; '.join(ramps)} left out)"
                if len(records) == 1
                else f", {len(ramps)} judged on their steady part (ramp-in/out cycles left out)"
            )
    fixed = f"m fixed at {M_UNFITTED:g}"
    if not excited:
        reason = f"inertia not excited ({head}): {fixed}"
    elif not separable:
        reason = (
            f"inertia excited but not separable from the stiffness ({head}; "
            f"ã⊥/ã = {float(n_o) / max(float(ni_c), 1e-300):.2g}{', a sine confounds m with k' if sines else ''}): "
            f"{fixed}, k absorbs −m·ω² (fit tests at several frequencies together, or fix m with --fix-mass)"
        )
    else:
        reason = f"inertia excited and separable ({head}): m fitted"
    return InertiaCheck(bool(excited), bool(separable), reason, m_ref * n_c * rms, m_ref * n_o * rms, sigma, sines)
