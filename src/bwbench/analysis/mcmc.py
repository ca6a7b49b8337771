"""Diagnostics of an ensemble MCMC chain (emcee): autocorrelation, effective samples, stuck walkers,
ArviZ's convergence verdict, the modes several ensembles settled in, and why a chain has not converged.

Convergence is read with Vehtari et al. (2021): converged when the rank-normalised split-R̂ ≤ 1.01
and the bulk effective sample size ≥ 400 for every parameter, each walker taken as a chain
(``arviz.from_emcee`` does the same) over the second half of the chain. The sampler (the ``emcee``
backend) and the report apply the same test to the same stored chain.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

STUCK_LOG_PROB = 50.0  # a walker this far below the ensemble's median log-probability is stuck
R_HAT_MAX = 1.01
ESS_MIN = 400


def stuck_walkers(samples: np.ndarray, log_prob: np.ndarray | None = None, burn: int | None = None) -> np.ndarray:
    """Boolean mask of walkers stuck away from the bulk over the steps after ``burn`` (default half).

    With ``log_prob``: the walker's median log-probability is more than ``STUCK_LOG_PROB`` below
    the median walker's (a density e^50 times lower: it is not sampling the posterior). Without:
    the walker moved in fewer than a fifth as many steps as the median walker.
    """
    steps, walkers, _ = samples.shape
    burn = steps // 2 if burn is None else burn
    if steps - burn < 2:
        return np.zeros(walkers, dtype=bool)
    if log_prob is not None:
        med = np.median(log_prob[burn:], axis=0)
        finite = np.isfinite(med)
        if finite.any():
            return ~finite | (med < np.median(med[finite]) - STUCK_LOG_PROB)
    moved = np.any(np.diff(samples[burn:], axis=0) != 0, axis=2).mean(axis=0)
    return moved < 0.2 * np.median(moved)


def chain_diagnostics(
    samples: np.ndarray, acceptance_fraction: float | None = None, log_prob: np.ndarray | None = None
) -> dict:
    """Diagnostics of an ensemble chain of shape (steps, walkers, dim).

    ``tau`` per dimension (``emcee.autocorr.integrated_time``, quiet), ``tau_max``, effective
    sample size ``ess`` = steps·walkers/tau_max, and ``warnings`` (plain sentences): the chain is
    shorter than 50·tau_max (emcee's rule for a trustworthy tau), or the acceptance fraction is
    outside 0.2–0.5, or walkers are stuck (``stuck_walkers``, second half of the chain; their
    number is ``stuck``). The acceptance fraction is estimated from the chain when not given.
    """
    import emcee

    steps, walkers, dim = samples.shape
    if acceptance_fraction is None or not np.isfinite(acceptance_fraction):
        moved = np.any(np.diff(samples, axis=0) != 0, axis=2)
        acceptance_fraction = float(moved.mean()) if steps > 1 else np.nan
    tau = emcee.autocorr.integrated_time(samples, quiet=True, tol=0) if steps > 1 else np.full(dim, np.nan)
    tau_max = float(np.nanmax(tau)) if np.isfinite(tau).any() else np.nan
    ess = steps * walkers / tau_max if np.isfinite(tau_max) and tau_max > 0 else np.nan
    warnings = []
    if not np.isfinite(tau_max) or steps < 50 * tau_max:
        need = f"{50 * tau_max:.0f}" if np.isfinite(tau_max) else "?"
        warnings.append(
            f"chain of {steps} steps is shorter than 50·τ = {need} steps: τ and the "
            f"posterior summaries are not reliable; run it longer"
        )
    if np.isfinite(acceptance_fraction) and not 0.2 <= acceptance_fraction <= 0.5:
        warnings.append(f"acceptance fraction {acceptance_fraction:.2f} is outside the usual 0.2–0.5")
    stuck = int(stuck_walkers(samples, log_prob).sum())
    if stuck:
        warnings.append(
            f"{stuck} of {walkers} walkers are stuck far from the bulk (left out of the posterior "
            "figures and correlations)"
        )
    return {
        "steps": steps,
        "walkers": walkers,
        "dim": dim,
        "acceptance_fraction": float(acceptance_fraction),
        "tau": [float(t) for t in tau],
        "tau_max": tau_max,
        "ess": float(ess),
        "stuck": stuck,
        "warnings": warnings,
    }


def convergence(samples: np.ndarray, names, burn: int | None = None) -> "pd.DataFrame":
    """ArviZ's rank-normalised split-R̂ and bulk and tail effective sample sizes per parameter of an
    ensemble chain (steps, walkers, dim), after dropping ``burn`` steps (default half), each walker
    taken as a chain (``arviz.from_emcee`` does the same).

    Read with Vehtari et al. (2021): converged when R̂ ≤ 1.01 and both ESS ≥ 400.
    """
    from bwbench.threads import settle_numba_environment

    settle_numba_environment()  # ArviZ compiles numba code at import
    import arviz as az
    import pandas as pd

    steps = samples.shape[0]
    burn = steps // 2 if burn is None else burn
    kept = np.swapaxes(samples[burn:], 0, 1)  # (chain, draw, dim)
    with warnings.catch_warnings():  # "more chains than draws": each walker is a chain, by design
        warnings.simplefilter("ignore", UserWarning)
        data = az.convert_to_dataset({"theta": kept}, dims={"theta": ["parameter"]}, coords={"parameter": list(names)})
    rhat = az.rhat(data)["theta"].values
    bulk = az.ess(data, method="bulk")["theta"].values
    tail = az.ess(data, method="tail")["theta"].values
    return pd.DataFrame({"parameter": list(names), "r_hat": rhat, "ess_bulk": bulk, "ess_tail": tail})


def converged(diagnostics) -> bool:
    """R̂ ≤ ``R_HAT_MAX`` and bulk ESS ≥ ``ESS_MIN`` for every row of a ``convergence`` table (NaN fails)."""
    r_hat = np.asarray(diagnostics["r_hat"], dtype=float)
    ess = np.asarray(diagnostics["ess_bulk"], dtype=float)
    return bool(len(r_hat) and np.all(r_hat <= R_HAT_MAX) and np.all(ess >= ESS_MIN))


def sampled(samples: np.ndarray) -> np.ndarray:
    """Mask of the dimensions that move in the chain (steps, walkers, d): a parameter held fixed
    (a reduced model) is constant and has no R̂."""
    flat = samples.reshape(-1, samples.shape[2])
    return np.ptp(flat, axis=0) > 0


@dataclass(frozen=True)
class Mode:
    """Ensembles (indices) that settled in one region, their walkers (indices into the chain's walker
    axis) and the median log-probability of their kept samples."""

    ensembles: tuple
    walkers: np.ndarray
    log_prob: float


def ensembles_of(walkers: int, count: int) -> list[np.ndarray]:
    """The walker indices of each of ``count`` equal ensembles stored side by side (the emcee backend's
    layout: ensemble k holds walkers k·W … (k+1)·W − 1)."""
    if count < 1 or walkers % count:
        raise ValueError(f"{walkers} walkers do not split into {count} equal ensembles")
    size = walkers // count
    return [np.arange(k * size, (k + 1) * size) for k in range(count)]


def modes(samples: np.ndarray, log_prob: np.ndarray | None, ensembles, burn: int | None = None) -> list[Mode]:
    """Group independent ensembles by where they settled, best log-probability first.

    Two ensembles share a mode when, for every parameter, their central 90 % intervals over the kept
    steps (after ``burn``, default half) overlap; modes are the connected groups. Ensembles that do
    not overlap have sampled different regions: separate modes, or one mode the chains have not yet
    crossed — either way their samples must not be pooled into one R̂.
    """
    steps = samples.shape[0]
    burn = steps // 2 if burn is None else burn
    ensembles = [np.asarray(e) for e in ensembles]
    bands = [np.quantile(samples[burn:, e].reshape(-1, samples.shape[2]), [0.05, 0.95], axis=0) for e in ensembles]
    k = len(ensembles)
    parent = list(range(k))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for a in range(k):
        for b in range(a + 1, k):
            overlap = np.all((bands[a][0] <= bands[b][1]) & (bands[b][0] <= bands[a][1]))
            if overlap:
                parent[root(b)] = root(a)
    groups: dict[int, list[int]] = {}
    for i in range(k):
        groups.setdefault(root(i), []).append(i)
    out = []
    for members in groups.values():
        walkers = np.concatenate([ensembles[i] for i in members])
        lp = float(np.median(log_prob[burn:, walkers])) if log_prob is not None else float("nan")
        out.append(Mode(tuple(members), walkers, lp))
    return sorted(out, key=lambda m: (-m.log_prob if np.isfinite(m.log_prob) else np.inf, m.ensembles))


def why_not_converged(samples: np.ndarray, diagnostics, labels=None, burn: int | None = None) -> list[str]:
    """Why the parameters failing R̂ or ESS fail, one sentence per reason, each naming the parameters with
    their R̂ and bulk ESS: which way they are still moving, or that the walkers disagree.

    The direction compares the median of the first and the last quarter of the kept steps (all
    walkers, unit coordinates): a shift of more than a fifth of the kept spread (5–95 %) is a drift
    (the chain is still travelling that way; "towards the upper/lower edge of its box" when it ends
    in the outer tenth); otherwise the walkers disagree with each other or mix slowly.
    """
    steps, _, d = samples.shape
    burn = steps // 2 if burn is None else burn
    kept = samples[burn:]
    labels = list(diagnostics["parameter"]) if labels is None else list(labels)
    r_hat = np.asarray(diagnostics["r_hat"], dtype=float)
    ess = np.asarray(diagnostics["ess_bulk"], dtype=float)
    quarter = max(1, len(kept) // 4)
    groups: dict[str, list[str]] = {}
    for j in range(d):
        if r_hat[j] <= R_HAT_MAX and ess[j] >= ESS_MIN:
            continue
        early, late = np.median(kept[:quarter, :, j]), np.median(kept[-quarter:, :, j])
        lo, hi = np.quantile(kept[:, :, j], [0.05, 0.95])
        if hi > lo and abs(late - early) > 0.2 * (hi - lo):
            where = (
                " towards the upper edge of the box"
                if late > early and late > 0.9
                else (" towards the lower edge of the box" if late < early and late < 0.1 else "")
            )
            reason = f"still drifting {'up' if late > early else 'down'}{where}"
        else:
            reason = "the walkers disagree or mix slowly (no net drift)"
        groups.setdefault(reason, []).append(f"{labels[j]} (R̂ {r_hat[j]:.3f}, bulk ESS {ess[j]:.0f})")
    return [f"{', '.join(names)}: {reason}" for reason, names in groups.items()]


def assess(samples: np.ndarray, log_prob: np.ndarray | None, ensembles: int, names, burn: int | None = None) -> dict:
    """The convergence verdict of a chain of ``ensembles`` independent ensembles side by side
    (``ensembles_of``), on the parameters it samples (``sampled``), mode by mode (``modes``).

    Returns ``converged`` (every mode converged), ``modes`` (list of ``Mode``), ``diagnostics`` (one
    ``convergence`` table per mode, sampled parameters only), ``why`` (``why_not_converged`` sentences,
    prefixed with the mode when there are several), ``modes_text`` (", 2 modes: ensembles 1, 2 | 3"
    or "") and ``steps``.
    """
    names = list(names)
    found = modes(samples, log_prob, ensembles_of(samples.shape[1], ensembles), burn)
    moving = sampled(samples)
    kept = [n for n, m in zip(names, moving) if m]
    tables, why = [], []
    for i, mode in enumerate(found):
        part = samples[:, mode.walkers][:, :, moving]
        table = convergence(part, kept, burn)
        tables.append(table)
        prefix = f"mode {i + 1}: " if len(found) > 1 else ""
        why += [prefix + text for text in why_not_converged(part, table, burn=burn)]
    text = ""
    if len(found) > 1:
        text = (
            f", {len(found)} modes (ensembles "
            + " | ".join(", ".join(str(e + 1) for e in m.ensembles) for m in found)
            + ")"
        )
    return {
        "converged": bool(tables) and all(converged(t) for t in tables),
        "modes": found,
        "diagnostics": tables,
        "why": why,
        "modes_text": text,
        "steps": int(samples.shape[0]),
    }
