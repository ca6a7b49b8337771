"""Diagnostics of an ensemble MCMC chain (emcee): autocorrelation, effective samples, stuck walkers."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

STUCK_LOG_PROB = 50.0  # a walker this far below the ensemble's median log-probability is stuck


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


def chain_diagnostics(samples: np.ndarray, acceptance_fraction: float | None = None,
                      log_prob: np.ndarray | None = None) -> dict:
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
        warnings.append(f"chain of {steps} steps is shorter than 50·τ = {need} steps: τ and the "
                        f"posterior summaries are not reliable; run it longer")
    if np.isfinite(acceptance_fraction) and not 0.2 <= acceptance_fraction <= 0.5:
        warnings.append(f"acceptance fraction {acceptance_fraction:.2f} is outside the usual 0.2–0.5")
    stuck = int(stuck_walkers(samples, log_prob).sum())
    if stuck:
        warnings.append(f"{stuck} of {walkers} walkers are stuck far from the bulk (left out of the posterior "
                        "figures and correlations)")
    return {"steps": steps, "walkers": walkers, "dim": dim, "acceptance_fraction": float(acceptance_fraction),
            "tau": [float(t) for t in tau], "tau_max": tau_max, "ess": float(ess), "stuck": stuck,
            "warnings": warnings}


def convergence(samples: np.ndarray, names, burn: int | None = None) -> "pd.DataFrame":
    """ArviZ's rank-normalised split-R̂ and bulk and tail effective sample sizes per parameter of an
    ensemble chain (steps, walkers, dim), after dropping ``burn`` steps (default half), each walker
    taken as a chain (``arviz.from_emcee`` does the same).

    Read with Vehtari et al. (2021): converged when R̂ ≤ 1.01 and both ESS ≥ 400.
    """
    import arviz as az
    import pandas as pd

    steps = samples.shape[0]
    burn = steps // 2 if burn is None else burn
    kept = np.swapaxes(samples[burn:], 0, 1)  # (chain, draw, dim)
    data = az.convert_to_dataset({"theta": kept}, dims={"theta": ["parameter"]},
                                 coords={"parameter": list(names)})
    rhat = az.rhat(data)["theta"].values
    bulk = az.ess(data, method="bulk")["theta"].values
    tail = az.ess(data, method="tail")["theta"].values
    return pd.DataFrame({"parameter": list(names), "r_hat": rhat, "ess_bulk": bulk, "ess_tail": tail})
