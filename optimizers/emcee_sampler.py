"""Affine-invariant ensemble MCMC (emcee) on the posterior over the unit box.

Not an optimiser: it samples, and the point estimate is the best loss the objective met along
the way (the objective tracks it). The chain comes back in the extras.

Posterior over u ∈ [0, 1]^d: a uniform prior on the box (log p = −inf outside) times the
likelihood ``objective.batch_with_likelihood`` gives: the problem's own marginal likelihood when it
has one (the identifiable formulation integrates its linear coefficients out analytically), else a
Gaussian likelihood with the noise σ integrated out under Jeffreys' prior p(σ) ∝ 1/σ,

    log p(u) = −(L/2)·log MSE(u)           (L = number of data points)

(∫ σ^(−L)·exp(−L·MSE/(2σ²))·dσ/σ ∝ MSE^(−L/2)). A blown-up model: log p = −inf. With the option
``n_data`` given, that formula is used with L = ``n_data`` whatever the problem.

Start (option ``start``): "uniform" walkers uniform in the box (a sampler used as an optimiser, as in
the ranking); "optimum": first a CMA-ES run (the ``cmaes`` backend) on ``start_fraction`` of the
budget, then the walkers in a ball of radius 0.01 (unit coordinates) around the best point it found
(option ``start_radius``, 0.01) — the usual start of an ensemble sampler (walkers scattered over a 7- or 14-dimensional box get stuck
in the poor regions for a very long time, and the chain never mixes).

Library call: ``emcee.EnsembleSampler(n_walkers, d, log_prob, vectorize=True)`` with the
default stretch move, and ``sampler.sample(state,
iterations=n)`` in a loop, ``n`` being what the remaining budget can pay for. The stretch move updates half
the ensemble at a time, so each half-step is one ``objective.batch`` call holding only the
proposals inside the box (those outside cost nothing). emcee samples from its own
``RandomState``, initialised from numpy's global state; we set it through the sampler's public
``random_state`` setter from a generator seeded by ``rng``.

The budget runs out in the middle of a step. Raising ``BudgetExhausted`` through emcee would
work but emcee prints the walkers and a traceback for any exception from the log-probability,
so instead the log-probability stops calling the objective once it is spent and returns −inf
(proposals the objective cut read +inf, i.e. −inf too): those proposals are rejected, which
is a lazy but valid transition, the step completes, is stored, and the loop stops after it.
The backend then returns what the chain holds, with the message "budget exhausted".

Options: ``n_walkers`` (None = 2·d + 2; else 2 to 10,000, and at least 2·d: emcee's stretch move
with fewer walkers keeps them in a subspace, and emcee refuses it; that part depends on the problem,
so ``minimize`` checks it before evaluating anything and raises ``OptionError``, one line, e.g.
``emcee: option n_walkers must be at least 2·d = 28 on this 14-parameter problem, got 3``),
``n_data`` (None: see above; else 1 to 10⁹, the number of residuals L), ``start`` ("uniform"),
``start_fraction`` (0.1, the share of the budget the start's optimisation may spend), ``moves``
("stretch": emcee's default; "de": differential-evolution and snooker moves, for curved ridges).
Should a whole ``sample`` call evaluate nothing (every proposal outside the box), the run stops
and says so rather than loop.
Extras: ``chain`` (steps, walkers, d) in unit coordinates, ``log_prob`` (steps, walkers),
``acceptance_fraction`` (mean over walkers), ``autocorr_time`` (per dimension, emcee's estimate
with ``tol=0``, so it is computed however short the chain; None before two steps), ``n_steps``.
"""

from __future__ import annotations

import numpy as np

from bwbench.errors import BudgetExhausted
from bwbench.optimize.options import Choice, Float, Int, OptionError
from bwbench.optimize.registry import register


@register(
    "emcee",
    family="mcmc",
    description="emcee ensemble sampler, uniform prior on the box, Gaussian likelihood with σ profiled out",
    options={"n_walkers": Int(None, minimum=2, maximum=10_000, none="2·d + 2"),
             "n_data": Int(None, minimum=1, maximum=10**9, none="the problem's number of data points"),
             "start": Choice("uniform", ("uniform", "optimum")),
             "start_fraction": Float(0.1, minimum=0.0, maximum=0.9),
             "moves": Choice("stretch", ("stretch", "de")),
             "start_radius": Float(0.01, minimum=1e-6, maximum=0.5)},
)
def minimize(objective, *, rng, n_walkers=None, n_data=None, start="uniform", start_fraction=0.1, moves="stretch",
             start_radius=0.01):
    d = objective.dim
    if n_walkers is not None and n_walkers < 2 * d:
        raise OptionError(f"emcee: option n_walkers must be at least 2·d = {2 * d} on this {d}-parameter "
                          f"problem (emcee's stretch move), got {n_walkers}")
    import emcee  # here, not at module level: it pulls in scipy.stats (~0.7 s for every command)

    n_walkers = 2 * d + 2 if n_walkers is None else n_walkers
    given_n_data = n_data is not None
    if n_data is None:
        n_data = getattr(objective.problem, "n_data", 1000)
    half_L = 0.5 * float(n_data)

    callers_errstate = np.geterr()

    def log_prob(U):
        # Never raises: emcee prints the walkers and a traceback for any exception from here.
        inside = np.all((U >= 0.0) & (U <= 1.0), axis=1)
        lp = np.full(len(U), -np.inf)
        if inside.any() and not objective.exhausted:
            with np.errstate(**callers_errstate):  # the sampling loop's silencing is for emcee only
                if given_n_data:
                    mse = objective.batch(U[inside])
                    # tiny: an exact fit must not give log p = +inf.
                    lp[inside] = -half_L * np.log(np.maximum(mse, np.finfo(float).tiny))
                else:
                    lp[inside] = objective.batch_with_likelihood(U[inside])[1]
        return lp

    # "de": differential-evolution proposals with 20 % snooker moves, emcee's advice for posteriors with
    # strongly correlated or curved ridges, where the stretch move's autocorrelation runs to ~10³ steps.
    chosen = None if moves == "stretch" else [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    sampler = emcee.EnsembleSampler(n_walkers, d, log_prob, vectorize=True, moves=chosen)
    sampler.random_state = np.random.RandomState(np.random.MT19937(rng.integers(2**63))).get_state()
    state = rng.random((n_walkers, d)) if start == "uniform" else _ball_at_optimum(objective, rng, n_walkers,
                                                                                  start_fraction, start_radius)
    # −inf − (−inf) = NaN in emcee's acceptance test when a walker and its proposal both blew up:
    # the comparison with NaN is False, i.e. rejected, which is right; the warning is noise.
    stuck = False
    with np.errstate(invalid="ignore"):
        while not objective.exhausted and not stuck:
            spent = objective.nfev
            # Store only as many steps as the budget can still pay for: emcee preallocates them.
            steps = objective.remaining // n_walkers + 1
            # The ensemble check is for user-given starting points, not for a chain being continued.
            continuing = sampler.iteration > 0
            for step in sampler.sample(state, iterations=steps, skip_initial_state_check=continuing):
                state = step  # the last state continues the chain
                if objective.exhausted:
                    break
            stuck = objective.nfev == spent  # every proposal of every step outside the box: never loop for nothing

    n_steps = sampler.iteration
    with np.errstate(invalid="ignore"):  # a walker that never moved has a 0/0 autocorrelation: NaN
        autocorr = sampler.get_autocorr_time(quiet=True, tol=0) if n_steps >= 2 else None
    return {
        "message": "every proposal fell outside the box; stopped" if stuck else "budget exhausted",
        "chain": sampler.get_chain(),
        "log_prob": sampler.get_log_prob(),
        "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)) if n_steps else float("nan"),
        "autocorr_time": autocorr,
        "n_steps": int(n_steps),
        "n_walkers": n_walkers,
        "n_data": int(n_data),
    }


def _ball_at_optimum(objective, rng, n_walkers: int, fraction: float, radius: float) -> np.ndarray:
    """Walkers in a ball of ``radius`` (unit coordinates) around the best point a CMA-ES run on ``fraction`` of the
    remaining budget found (every evaluation counts against the objective's budget)."""
    from bwbench.optimizers.cmaes import minimize as cmaes

    share = _Share(objective, int(fraction * objective.remaining))
    try:
        cmaes(share, rng=rng)
    except BudgetExhausted:
        pass
    centre = objective.best_u if objective.best_u is not None else rng.random(objective.dim)
    return np.clip(centre + radius * rng.standard_normal((n_walkers, objective.dim)), 0.0, 1.0)


class _Share:
    """``objective`` seen through a smaller budget; evaluations count against the real one."""

    def __init__(self, objective, budget: int):
        self.objective, self.dim, self.problem = objective, objective.dim, objective.problem
        self.stop = objective.nfev + budget

    @property
    def nfev(self) -> int:
        return self.objective.nfev

    @property
    def remaining(self) -> int:
        return min(self.stop - self.objective.nfev, self.objective.remaining)

    @property
    def exhausted(self) -> bool:
        return self.remaining <= 0

    def batch(self, U):
        if self.exhausted:
            raise BudgetExhausted("the start's share of the budget is spent")
        U = np.atleast_2d(U)
        losses = np.full(len(U), np.inf)
        take = min(len(U), self.remaining)
        losses[:take] = self.objective.batch(U[:take])
        return losses
