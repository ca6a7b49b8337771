"""Checks of a fit that can fail: what the linear solve does not force, and the shape of the residual.

**Energy by branch and at the reversals.** The energy a fitted model dissipates per cycle, ∮F·dx,
is close to the measured loop's for any fit that is not far off: the least-squares coefficients (a
viscous c, a stiffness, an offset) absorb the mismatch (measured MR-damper fits at NRMSE 0.058 and
0.236 both matched it to four digits), so it cannot tell a good fit from a poor one. What they do not force is *where* the energy goes: the work of
each branch (ẋ ≥ 0 and ẋ < 0; a constant force offset moves work from one to the other) and the work
in the **reversal zones** (|x − x_mid| ≥ ``REVERSAL_ZONE`` × the amplitude, where the hysteresis
turns and a wrong yield shape shows). Each is compared with the measured one as a share of the
measured loop's total; the check fails when any differs by more than ``ENERGY_TOLERANCE``.

**Residual structure.** σ̂, the force noise of the record (``inertia_rule.force_noise``), against
the RMSE: model error dominates when RMSE > 2·σ̂. Where it lies: the share of the squared error in
the reversal zones against the share of the samples there (a ratio above ``REVERSAL_EXCESS``: the
model misses the reversals), and the residual's autocorrelation over 1 % of a cycle (``lag``): white
noise gives ≈ 0, model error ≈ 1.
"""

from __future__ import annotations

import numpy as np

REVERSAL_ZONE = 0.8  # × amplitude from mid-stroke: the samples near the ends of the stroke
ENERGY_TOLERANCE = 0.05  # share of the measured loop energy a branch's or the reversals' work may miss by
REVERSAL_EXCESS = 2.0  # the reversal zones' share of the squared error over their share of the samples
NOISE_EXCESS = 2.0  # RMSE / σ̂ above this: the residual is model error, not noise


def _work(x, f, mask) -> float:
    """Σ F·dx (N·mm, trapezoid) over the sample intervals whose both ends are in ``mask``."""
    both = mask[1:] & mask[:-1]
    return float(np.sum((0.5 * (f[1:] + f[:-1]) * np.diff(x))[both]))


def energy_split(x, v, f_model, f_measured) -> dict:
    """Work per branch and in the reversal zones, model and measured (N·mm over the record), and each
    mismatch as a share of the measured loop's total work (–); ``passed`` False when any exceeds
    ``ENERGY_TOLERANCE``."""
    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    fm, fd = np.asarray(f_model, dtype=float), np.asarray(f_measured, dtype=float)
    mid, amplitude = 0.5 * (x.max() + x.min()), 0.5 * float(np.ptp(x))
    zones = {
        "loading (ẋ ≥ 0)": v >= 0,
        "unloading (ẋ < 0)": v < 0,
        "reversal zones": np.abs(x - mid) >= REVERSAL_ZONE * amplitude,
    }
    total = _work(x, fd, np.ones(len(x), dtype=bool))
    out: dict = {"total_measured_Nmm": total, "parts": {}, "tolerance": ENERGY_TOLERANCE}
    worst = 0.0
    for name, mask in zones.items():
        model, measured = _work(x, fm, mask), _work(x, fd, mask)
        share = abs(model - measured) / abs(total) if total != 0 else np.inf
        out["parts"][name] = {"model_Nmm": model, "measured_Nmm": measured, "mismatch": share}
        worst = max(worst, share)
    out["worst_mismatch"] = worst
    out["passed"] = bool(worst <= ENERGY_TOLERANCE)
    return out


def residual_structure(t, x, residual, noise_N: float, cycle_s: float | None) -> dict:
    """RMSE against the noise σ̂, the reversal zones' share of the squared error against their share of
    the samples, and the residual's autocorrelation at a lag of 1 % of a cycle (``cycle_s``; one sample
    when unknown)."""
    x, r = np.asarray(x, dtype=float), np.asarray(residual, dtype=float)
    mid, amplitude = 0.5 * (x.max() + x.min()), 0.5 * float(np.ptp(x))
    zone = np.abs(x - mid) >= REVERSAL_ZONE * amplitude
    squared = r**2
    error_share = float(squared[zone].sum() / squared.sum()) if squared.sum() > 0 else 0.0
    sample_share = float(zone.mean())
    dt = float(np.median(np.diff(np.asarray(t, dtype=float))))
    lag = max(1, int(round(0.01 * cycle_s / dt))) if cycle_s else 1
    centred = r - r.mean()
    denominator = float(np.dot(centred, centred))
    rho = float(np.dot(centred[lag:], centred[:-lag]) / denominator) if denominator > 0 and lag < len(r) else 0.0
    rmse = float(np.sqrt(np.mean(squared)))
    return {
        "rmse_N": rmse,
        "noise_N": float(noise_N),
        "rmse_over_noise": rmse / noise_N if noise_N > 0 else np.inf,
        "reversal_error_share": error_share,
        "reversal_sample_share": sample_share,
        "reversal_excess": error_share / sample_share if sample_share > 0 else np.inf,
        "autocorrelation": rho,
        "lag_samples": lag,
        "model_error_dominates": bool(noise_N > 0 and rmse > NOISE_EXCESS * noise_N),
        "reversals_missed": bool(sample_share > 0 and error_share > REVERSAL_EXCESS * sample_share),
    }
