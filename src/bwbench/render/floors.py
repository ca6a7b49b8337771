"""When a number may be called a noise floor.

A synthetic specimen's manifest gives its truth and the force noise it was generated with (1σ,
N). The truth's MSE is the *noise floor* — the loss a perfect fit reaches — only when the model
reproduces the data up to that noise, i.e. when the truth's MSE is within ``FACTOR`` of the stated
noise variance (either way). Otherwise (e.g. the model is driven by a velocity estimated from a
noisy displacement, so the truth itself misfits) it is only "the truth's MSE", and a loss is
measured against the best known loss. Measured data have no manifest truth and no floor.
"""

from __future__ import annotations

import math

FACTOR = 1.25  # the truth's MSE within 1.25× of the stated noise variance: a noise floor
NOISE_KEYS = ("noise_force_n", "noise_force_N")  # manifest settings: force noise, N (1σ)


def stated_noise_variance(study) -> float | None:
    """σ² (N²) of the force noise the manifest says the specimens were generated with, or None."""
    settings = (study.manifest() or {}).get("settings", {})
    for key in NOISE_KEYS:
        value = settings.get(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
            return float(value) ** 2
    return None


def is_noise_floor(truth_mse, noise_variance) -> bool:
    """Whether a truth's MSE is within ``FACTOR`` of the noise variance."""
    if truth_mse is None or noise_variance is None or not math.isfinite(truth_mse) or noise_variance <= 0:
        return False
    return noise_variance / FACTOR <= truth_mse <= noise_variance * FACTOR


def floors(study, specimens) -> dict:
    """{specimen: (truth's MSE, "noise floor" or "truth's MSE")} for the specimens with a manifest truth."""
    variance = stated_noise_variance(study)
    out = {}
    for specimen in specimens:
        value = study.problem_type.noise_floor(study, specimen)
        if value is not None:
            out[specimen] = (float(value), "noise floor" if is_noise_floor(value, variance) else "truth's MSE")
    return out


def noise_floors(study, specimens) -> dict:
    """Only the specimens whose truth's MSE is a noise floor: {specimen: (value, "noise floor")}."""
    return {s: v for s, v in floors(study, specimens).items() if v[1] == "noise floor"}
