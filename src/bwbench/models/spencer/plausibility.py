"""What a fit of Spencer's model says about the damper: each parameter's meaning and, where its value
is not what an MR damper does, why; the series damping the fitted c₀ and k₀ imply."""

from __future__ import annotations

import numpy as np

from bwbench.models.base import amplitude, velocity_scale

# Offsets: Spencer's accumulator offset x₀ within ``X0_STROKES`` × the test's stroke (2·amplitude); the
# published damper has 143 mm on its ±25 mm stroke (2.9 strokes); a larger x₀ is a force offset (a
# preload, or the load cell's zero) that k₁·x₀ cannot hold physically with the fitted k₁.
X0_STROKES = 20.0


def plausibility(values: dict, signal) -> list:
    """[(name, value, unit, meaning, verdict)] of a fit's parameters (``Model.plausibility``): what each
    means for the damper and, where the value is not what an MR damper does, why (else "")."""
    a, v = amplitude(signal.x), velocity_scale(signal)
    duration = float(signal.t[-1] - signal.t[0])
    get = values.get
    rows = []

    def row(name, unit, meaning, verdict=""):
        if isinstance(get(name), (int, float)) and np.isfinite(get(name)):
            rows.append((name, float(get(name)), unit, meaning, verdict))

    xy, n, eta, vy, r0, kappa0 = (get(k, np.nan) for k in ("xy", "n", "eta", "vy", "r0", "kappa0"))
    row(
        "xy",
        "mm",
        "relative displacement over which the damper yields",
        f"x_y > the amplitude {a:.3g} mm: the damper does not yield within the stroke (a viscoelastic element; "
        "n and η are not determined)"
        if xy > a
        else "",
    )
    row(
        "n",
        "-",
        "smoothness of the yield (the literature's fits: 1–4)",
        "a sharper yield than the literature's fits (n > 4)" if n > 4 else "",
    )
    row(
        "eta",
        "-",
        "unloading ratio (β − γ)/(β + γ) (Spencer's fits: 0); below −1 (β < 0) the force unloads "
        "faster after a reversal than it loads",
    )
    row(
        "vy",
        "mm/s",
        "relative velocity at which the damper reaches its yield force",
        f"above the test's peak velocity {v:.3g} mm/s: the damper never yields in this test" if vy > v else "",
    )
    row(
        "r0",
        "-",
        "c₀/c₁, post-yield over pre-yield damping (Spencer's damper: 0.07–0.10)",
        "c₀ > c₁: the damping after the yield exceeds the pre-yield one (no low-velocity roll-off)" if r0 > 1 else "",
    )
    tau = (1.0 + r0) / kappa0 if kappa0 > 0 else np.inf
    row(
        "kappa0",
        "1/s",
        f"k₀/c₁; y relaxes towards x in (1 + r₀)/κ₀ = {tau:.3g} s",
        f"relaxation in {tau:.3g} s, faster than a cycle: k₀ stiffens the loop rather than centring it"
        if tau < duration / 100
        else "",
    )
    row("c1", "N·s/mm", "damping at low velocities (the series dashpot)")
    row("c0", "N·s/mm", "damping at large velocities")
    row("k0", "N/mm", "stiffness at large velocities")
    row("k1", "N/mm", "accumulator stiffness (≥ 0)", "negative: not a gas spring" if get("k1", 0.0) < 0 else "")
    row("alpha", "N/mm", "weight of the evolutionary variable z (gauge A = 300)")
    x0 = get("x0", 0.0)
    limit = X0_STROKES * 2 * a
    row(
        "x0",
        "mm",
        "accumulator offset x₀, from the force offset f₀ = −k₁·x₀",
        f"|x₀| > {X0_STROKES:g} strokes ({limit:.3g} mm): the force offset f₀ = {get('f0', np.nan):.4g} N is a preload "
        "or the load cell's zero, not an offset the fitted k₁ can hold"
        if abs(x0) > limit
        else "",
    )
    return rows


def series_damping(values: dict) -> dict | None:
    """∂F/∂ẋ of the two dashpots in series, c₁·c₀/(c₀ + c₁) = c₁·r₀/(1 + r₀) (N·s/mm)."""
    if "r0" in values:
        return {"": values["c1"] * values["r0"] / (1.0 + values["r0"])}
    if "c0" in values:
        return {"": values["c1"] * values["c0"] / (values["c0"] + values["c1"])}
    return None
