"""How far a label's measured expected time to a target can be trusted: its run-to-run noise.

The expected time to a target (ERT × seconds per evaluation, ``statistics.ranking_table``) is the
one quantity of the verdict that the machine sets, not the seeds: the same seeds on a busier machine
give the same losses and evaluation counts but other wall times. Two sources of noise, both counted:

- the spread of the label's own runs: a bootstrap interval of its expected time, resampling its runs
  within each specimen (the seeds are the repeats), ``LEVEL`` two-sided, ``RESAMPLES`` resamples with
  a fixed seed (the same data give the same interval);
- the load of the machine, which moves all the wall times of a label together: ``LOAD``. Measured on
  the quick study run twice with the same seeds (two sessions of a shared 2-core machine), the
  seconds per evaluation of the candidates changed by factors that differed between labels by up to
  17 %; ±15 % per label is what the held-out check and the tests apply.

A label is *faster beyond the noise* than another only when its interval's upper end, times
``LOAD_FACTOR`` (the most a ±``LOAD`` change can move the ratio of two labels' times), is still
below the other's lower end (``clearly_faster``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import statistics

LEVEL = 0.95
RESAMPLES = 2000
SEED = 20261124  # fixed: the interval is a property of the data, not of the draw
LOAD = 0.15  # a label's wall times may move by ±15 % with the machine's load between two runs
LOAD_FACTOR = (1 + LOAD) / (1 - LOAD)  # ≈ 1.35: how far that can move the ratio of two labels' times


def intervals(runs: pd.DataFrame, traces: pd.DataFrame, taus=statistics.TOLERANCES) -> pd.DataFrame:
    """Per label (ranking runs) and target τ: the expected time to the target (s) and its bootstrap
    interval over the label's runs. Columns ``optimizer``, ``tau``, ``time``, ``low``, ``high``;
    NaN where the runs carry no wall time, inf where (a resample of) the runs never reach τ."""
    ranking = runs[runs["kind"] == "ranking"]
    rt = statistics.runtimes(ranking, traces, taus, statistics.best_known(runs))
    wall = (
        ranking.set_index(["specimen", "optimizer", "replicate"])["wall_s"].astype(float)
        if "wall_s" in ranking
        else None
    )
    rng = np.random.default_rng(SEED)
    rows = []
    for (optimizer, tau), g in rt.groupby(["optimizer", "tau"], sort=True):
        keys = list(zip(g["specimen"], g["optimizer"], g["replicate"]))
        seconds = wall.reindex(keys).to_numpy() if wall is not None else np.full(len(g), np.nan)
        spent = np.where(g["reached"], g["evals"], g["nfev"]).astype(float)
        reached = g["reached"].to_numpy(dtype=float)
        nfev = g["nfev"].to_numpy(dtype=float)
        timed = np.isfinite(seconds) & (nfev > 0)
        point = _time(spent, reached, np.where(timed, seconds, 0.0), np.where(timed, nfev, 0.0))
        # resample the seeds within each specimen, as the comparisons do (specimens are the blocks)
        picks = np.concatenate(
            [
                rng.choice(np.flatnonzero(g["specimen"].to_numpy() == s), size=(RESAMPLES, n))
                for s, n in g["specimen"].value_counts(sort=False).items()
            ],
            axis=1,
        )
        boot = _time(
            spent[picks], reached[picks], np.where(timed, seconds, 0.0)[picks], np.where(timed, nfev, 0.0)[picks]
        )
        if not timed.any():
            low = high = np.nan
        else:
            low, high = np.quantile(boot, [(1 - LEVEL) / 2, (1 + LEVEL) / 2], method="inverted_cdf")
        rows.append(
            {"optimizer": optimizer, "tau": float(tau), "time": float(point), "low": float(low), "high": float(high)}
        )
    return pd.DataFrame(rows, columns=["optimizer", "tau", "time", "low", "high"])


def _time(spent, reached, seconds, nfev):
    """ERT × seconds per evaluation along the last axis (inf without a success, NaN without timing)."""
    successes = np.sum(reached, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ert = np.where(successes > 0, np.sum(spent, axis=-1) / np.maximum(successes, 1), np.inf)
        per_eval = np.sum(seconds, axis=-1) / np.sum(nfev, axis=-1)
        return np.where(successes > 0, ert * per_eval, np.inf)


def clearly_faster(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether a label with interval ``a`` = (low, high) is faster than one with ``b`` beyond both
    noises: ``a``'s upper end × ``LOAD_FACTOR`` below ``b``'s lower end. False when either is unknown."""
    return bool(np.isfinite(a[1]) and not np.isnan(b[0]) and a[1] * LOAD_FACTOR < b[0])
