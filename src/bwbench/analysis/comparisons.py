"""Two run labels compared on the right unit: specimens are blocks, seeds are repeats within a block.

A study runs every label (a backend, or "backend [variant]") with the same seeds on the same
specimens. Seed r of one backend shares nothing with seed r of another (the pairing would be
arbitrary), so within a specimen the runs of two labels are two independent samples; across
specimens they are blocks of different difficulty. Hence:

- values: log10 of the final loss of each run (a ratio scale: a specimen with larger forces does not
  dominate); a failed run counts one decade above the worst finished run on its specimen, so it is
  the worst in every rank and nowhere near the middle of a median;
- test: van Elteren's stratified Wilcoxon–Mann–Whitney test (the within-specimen rank sums,
  weighted by 1/(n + 1), normal approximation with ties), which with one specimen is the unpaired
  Mann–Whitney U test (scipy's, exact where scipy can be);
- effect size: the stratified Hodges–Lehmann shift, the median of every within-specimen difference
  log10 loss(a) − log10 loss(b), reported as the ratio 10^shift (< 1: a ends lower), with a 95 %
  percentile bootstrap interval (seeds resampled within each specimen, ``BOOTSTRAP`` resamples from
  a Generator seeded by the two labels' names: the same data give the same interval);
- ``smallest_p``: the smallest p the design can give at all (every run of a below every run of b on
  every specimen), which with Holm's factor says whether a comparison can be significant at all;
- Holm's step-down correction over a stated family of comparisons (``holm``).

Written out because scipy has the two-sample Mann–Whitney test but no stratified version, and
statsmodels is not a dependency.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pandas as pd
import scipy.special
import scipy.stats

BOOTSTRAP = 2000  # resamples for the interval of the Hodges–Lehmann shift
LEVEL = 0.95
SEED = 20240917  # with the labels' names: the generator of every bootstrap interval


def log_losses(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per run: specimen, optimizer, replicate and ``value`` = log10 final loss, a failed
    run (status not ok, or a loss that is not finite) one decade above the worst finished run on
    its specimen (0 + 1 when nothing finished there)."""
    loss = runs["mse"].astype(float).where(runs["status"] == "ok", np.inf)
    with np.errstate(divide="ignore"):
        value = np.log10(loss.where(np.isfinite(loss), np.inf).clip(lower=1e-300))
    finite = value.where(np.isfinite(value))
    worst = finite.groupby(runs["specimen"]).transform("max").fillna(0.0) + 1.0
    return pd.DataFrame(
        {
            "specimen": runs["specimen"].to_numpy(),
            "optimizer": runs["optimizer"].to_numpy(),
            "replicate": runs["replicate"].to_numpy(),
            "value": np.where(np.isfinite(value), value, worst),
        }
    )


def blocks(values: pd.DataFrame, label: str) -> dict:
    """{specimen: sorted array of the label's values} in specimen order (sorted, so that the order of
    the rows cannot change a bootstrap draw)."""
    mine = values[values["optimizer"] == label]
    return {s: np.sort(g["value"].to_numpy(dtype=float)) for s, g in mine.groupby("specimen", sort=True)}


def _common(a: dict, b: dict) -> list:
    return [s for s in a if s in b and len(a[s]) and len(b[s])]


def method_name(n_specimens: int) -> str:
    """The name of the test ``two_sample`` runs with this many specimens."""
    if n_specimens <= 1:
        return (
            "the unpaired Mann–Whitney U test (one specimen: the seeds of each label an independent sample, "
            "nothing to pair them by)"
        )
    return (
        "van Elteren's stratified Wilcoxon–Mann–Whitney test (specimens as blocks, the seeds of each label "
        "independent repeats within a block; normal approximation)"
    )


def van_elteren(a: dict, b: dict) -> tuple[float, float]:
    """(z, two-sided p) of van Elteren's test that a's values are no lower than b's within blocks
    (z < 0: a lower). Blocks whose values are all tied carry no information and are skipped; p is
    nan when no block is left."""
    total, variance = 0.0, 0.0
    for s in _common(a, b):
        x, y = np.asarray(a[s], float), np.asarray(b[s], float)
        pooled = np.concatenate([x, y])
        n, m = x.size, y.size
        N = n + m
        ranks = scipy.stats.rankdata(pooled)
        _, ties = np.unique(pooled, return_counts=True)
        v = n * m * (N + 1) / 12.0 - n * m * float(np.sum(ties**3 - ties)) / (12.0 * N * (N - 1))
        if v <= 0:
            continue
        w = 1.0 / (N + 1)
        total += w * (ranks[:n].sum() - n * (N + 1) / 2.0)
        variance += w * w * v
    if variance <= 0:
        return math.nan, math.nan
    z = total / math.sqrt(variance)
    return z, float(2.0 * scipy.stats.norm.sf(abs(z)))


def two_sample(a: dict, b: dict) -> tuple[float, float]:
    """(statistic, two-sided p): Mann–Whitney U of a with one common specimen, van Elteren's z with
    more. Identical values everywhere: p = 1 (no evidence of a difference)."""
    common = _common(a, b)
    if not common:
        return math.nan, math.nan
    pooled = np.concatenate([np.concatenate([a[s], b[s]]) for s in common])
    if np.ptp(pooled) == 0:
        return 0.0, 1.0
    if len(common) == 1:
        res = scipy.stats.mannwhitneyu(a[common[0]], b[common[0]], alternative="two-sided")
        return float(res.statistic), float(res.pvalue)
    return van_elteren(a, b)


def smallest_p(a: dict, b: dict) -> float:
    """The smallest two-sided p ``two_sample`` can give with these block sizes: every value of a
    below every value of b in every block, no ties."""
    common = _common(a, b)
    if not common:
        return math.nan
    if len(common) == 1:
        n, m = len(a[common[0]]), len(b[common[0]])
        return float(min(1.0, 2.0 / scipy.special.comb(n + m, n, exact=True)))
    extreme = {s: (np.arange(len(a[s])), len(a[s]) + np.arange(len(b[s]))) for s in common}
    return van_elteren({s: x for s, (x, _) in extreme.items()}, {s: y for s, (_, y) in extreme.items()})[1]


def _differences(a: dict, b: dict, common) -> np.ndarray:
    return np.concatenate([np.subtract.outer(a[s], b[s]).ravel() for s in common])


def hodges_lehmann(a: dict, b: dict) -> float:
    """Median of every within-block difference a − b (log10 units); nan without a common block."""
    common = _common(a, b)
    return float(np.median(_differences(a, b, common))) if common else math.nan


def hl_interval(
    a: dict, b: dict, rng: np.random.Generator, resamples: int = BOOTSTRAP, level: float = LEVEL
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``hodges_lehmann``: the seeds of each label resampled with
    replacement within each block, ``resamples`` times."""
    common = _common(a, b)
    if not common:
        return math.nan, math.nan
    parts = []
    for s in common:
        x, y = np.asarray(a[s], float), np.asarray(b[s], float)
        xs = x[rng.integers(0, x.size, (resamples, x.size))]
        ys = y[rng.integers(0, y.size, (resamples, y.size))]
        parts.append((xs[:, :, None] - ys[:, None, :]).reshape(resamples, -1))
    medians = np.median(np.concatenate(parts, axis=1), axis=1)
    tail = (1.0 - level) / 2.0
    low, high = np.quantile(medians, [tail, 1.0 - tail])
    return float(low), float(high)


def generator(a: str, b: str) -> np.random.Generator:
    """The bootstrap's generator for the pair (a, b): fixed by the names, not by the order of work."""
    return np.random.default_rng([SEED, zlib.crc32(f"{a}\x00{b}".encode("utf-8"))])


def compare(values: pd.DataFrame, a: str, b: str) -> dict:
    """Label ``a`` against label ``b``: specimens and runs compared, the test's statistic and p,
    the smallest p the design allows, and the Hodges–Lehmann shift (log10) with its interval,
    also as loss ratios a/b (``ratio``, ``ratio_low``, ``ratio_high``)."""
    x, y = blocks(values, a), blocks(values, b)
    common = _common(x, y)
    statistic, p = two_sample(x, y)
    shift = hodges_lehmann(x, y)
    low, high = hl_interval(x, y, generator(a, b))
    return {
        "a": a,
        "b": b,
        "specimens": len(common),
        "runs_a": int(sum(len(x[s]) for s in common)),
        "runs_b": int(sum(len(y[s]) for s in common)),
        "statistic": statistic,
        "p": p,
        "min_p": smallest_p(x, y),
        "shift": shift,
        "shift_low": low,
        "shift_high": high,
        "ratio": 10.0**shift,
        "ratio_low": 10.0**low,
        "ratio_high": 10.0**high,
    }


def family(values: pd.DataFrame, pairs, name: str, alpha: float) -> pd.DataFrame:
    """``compare`` for each (a, b) of ``pairs``, Holm-corrected over exactly these comparisons:
    columns of ``compare`` plus ``family`` (= ``name``), ``p_holm`` and ``significant``."""
    rows = [compare(values, a, b) for a, b in pairs]
    columns = [
        "a",
        "b",
        "specimens",
        "runs_a",
        "runs_b",
        "statistic",
        "p",
        "min_p",
        "shift",
        "shift_low",
        "shift_high",
        "ratio",
        "ratio_low",
        "ratio_high",
    ]
    out = pd.DataFrame(rows, columns=columns)
    out.insert(0, "family", name)
    out["p_holm"] = holm(out["p"].to_numpy()) if len(out) else []
    out["significant"] = out["p_holm"] < alpha
    return out


def holm(pvalues) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (step-down, family-wise error control); NaN stays NaN.

    Written out because scipy's ``false_discovery_control`` only offers BH/BY (FDR, not FWER)
    and statsmodels is not a dependency.
    """
    p = np.asarray(pvalues, dtype=float)
    out = np.full(p.shape, np.nan)
    valid = np.flatnonzero(~np.isnan(p))
    m = valid.size
    order = valid[np.argsort(p[valid], kind="stable")]
    adjusted = np.maximum.accumulate((m - np.arange(m)) * p[order])
    out[order] = np.minimum(adjusted, 1.0)
    return out


def holm_floor(frame: pd.DataFrame) -> float:
    """The smallest Holm-adjusted p a family can reach: its smallest possible raw p times its size."""
    if frame is None or not len(frame):
        return math.nan
    return float(min(1.0, frame["min_p"].min() * len(frame)))
