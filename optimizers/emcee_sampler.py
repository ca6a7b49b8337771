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

Start (option ``start``): "uniform": walkers uniform in the box (a sampler used as an optimiser, as in
the ranking); "optimum": a CMA-ES run on ``start_fraction`` of the budget, then the walkers in a ball
of radius ``start_radius`` (unit coordinates) around its best point; "optima" (what a study's
``[posterior]`` uses): ``bwbench.optimizers.sampling.start`` — independent local searches on
``start_fraction`` of the budget, the good optima farthest apart (one per ensemble), walkers drawn
around each from the local curvature, overdispersed. With "optima", a branch the data cannot tell
from a linear one is sampled with its shape parameters held fixed (``bwbench.optimizers.sampling.reduce``).

Ensembles (option ``ensembles``, K): K independent ``emcee.EnsembleSampler``s of ``n_walkers`` each,
stepped in turn so they always have the same length; the chain stores them side by side on the
walker axis (ensemble k: walkers k·W … (k+1)·W − 1). Separate ensembles never exchange walkers, so
ensembles that settle in different modes stay there and the report shows the modes
(``bwbench.analysis.mcmc.modes``) instead of pooling them into one R̂.

Stop (option ``stop``): "budget" runs until the budget is spent; "converged" checks ArviZ's R̂ and
bulk ESS (``bwbench.analysis.mcmc``: R̂ ≤ 1.01, bulk ESS ≥ 400 for every sampled parameter, second
half of the stored chain, within each mode) every ~10 % of the steps so far and stops as soon as
they hold, else when the budget ends; the message says which, and for a chain that did not converge,
which parameter failed and which way it was still moving. Thinning (option ``thin``, None: enough
to store at most ``MAX_STORED`` steps at the budget's longest chain): emcee's ``thin_by``, every
stored step is ``thin`` steps; the checks read the stored chain, as the report does.

Library call: ``emcee.EnsembleSampler(n_walkers, d, log_prob, vectorize=True, moves=...)`` and
``sampler.sample(state, iterations=n, thin_by=thin)`` as a generator. The stretch move updates half
the ensemble at a time, so each half-step is one ``objective.batch`` call holding only the proposals
inside the box (those outside cost nothing). emcee samples from its own ``RandomState``; we set it
through the sampler's public ``random_state`` setter from a generator seeded by ``rng``.

The budget runs out in the middle of a step. Raising ``BudgetExhausted`` through emcee would work
but emcee prints the walkers and a traceback for any exception from the log-probability, so instead
the log-probability stops calling the objective once it is spent and returns −inf: those proposals
are rejected, a lazy but valid transition, the step completes and the loop stops after it.

Options: ``n_walkers`` per ensemble (None = 2·d + 2; else 2 to 10,000, and at least 2·d: emcee's
stretch move with fewer walkers keeps them in a subspace, and emcee refuses it; that part depends on
the problem, so ``minimize`` checks it before evaluating anything and raises ``OptionError``, one
line), ``ensembles`` (1), ``n_data`` (None: see above), ``start`` ("uniform"), ``start_fraction``
(0.1), ``start_radius`` (0.01, "optimum" only), ``moves`` ("stretch": emcee's default; "de":
differential-evolution and snooker moves, for curved ridges), ``stop`` ("budget"), ``thin`` (None).
Should ``STUCK_STEPS`` stored steps in a row evaluate nothing (every proposal outside the box), the
run stops and says so rather than loop.
Extras: ``chain`` (stored steps, K·W, d) in unit coordinates, ``log_prob`` (stored steps, K·W),
``acceptance_fraction`` (mean over walkers), ``autocorr_time`` (per dimension, in steps, emcee's
estimate with ``tol=0``; None before two stored steps), ``n_steps`` (steps taken), ``n_walkers``
(K·W), ``ensembles``, ``thin``, ``converged``, ``fixed`` ({name: value} held fixed).
"""

from __future__ import annotations

import math

import numpy as np

from bwbench.engine.options import Choice, Float, Int, OptionError
from bwbench.engine.registry import register
from bwbench.errors import BudgetExhausted

MAX_STORED = 2000  # stored steps per walker at the longest chain the budget allows
FIRST_CHECK = 100  # stored steps before the first convergence check
STUCK_STEPS = 100  # stored steps in a row that evaluate nothing: stop


@register(
    "emcee",
    family="mcmc",
    description="emcee ensemble sampler, uniform prior on the box, Gaussian likelihood with σ profiled out",
    options={
        "n_walkers": Int(None, minimum=2, maximum=10_000, none="2·d + 2"),
        "n_data": Int(None, minimum=1, maximum=10**9, none="the problem's number of data points"),
        "start": Choice("uniform", ("uniform", "optimum", "optima")),
        "start_fraction": Float(0.1, minimum=0.0, maximum=0.9),
        "moves": Choice("stretch", ("stretch", "de")),
        "start_radius": Float(0.01, minimum=1e-6, maximum=0.5),
        "ensembles": Int(1, minimum=1, maximum=64),
        "stop": Choice("budget", ("budget", "converged")),
        "thin": Int(None, minimum=1, maximum=10_000, none=f"at most {MAX_STORED} stored steps"),
    },
)
def minimize(
    objective,
    *,
    rng,
    n_walkers=None,
    n_data=None,
    start="uniform",
    start_fraction=0.1,
    moves="stretch",
    start_radius=0.01,
    ensembles=1,
    stop="budget",
    thin=None,
):
    d = objective.dim
    if n_walkers is not None and n_walkers < 2 * d:
        raise OptionError(
            f"emcee: option n_walkers must be at least 2·d = {2 * d} on this {d}-parameter "
            f"problem (emcee's stretch move), got {n_walkers}"
        )
    import emcee  # here, not at module level: it pulls in scipy.stats (slow to import for every command)

    W, K = (2 * d + 2 if n_walkers is None else n_walkers), ensembles
    log_prob = _LogProb(objective, n_data)
    notes, fixed, start_lp = [], {}, [None] * K
    # each ensemble's own stream first: a ranking run (one ensemble, walkers uniform in the box) then
    # draws the same whatever else the sampler draws later
    streams = [int(rng.integers(2**63)) for _ in range(K)]
    if start == "optima":
        from bwbench.optimizers.sampling import start as mcmc_start

        plan = mcmc_start.plan(objective, rng, log_prob, K, W, start_fraction)
        starts, start_lp, fixed, notes = plan.walkers, plan.log_prob, plan.fixed, plan.notes
    elif start == "optimum":
        starts = [_ball_at_optimum(objective, rng, W, start_fraction, start_radius)]
        starts += [starts[0][rng.permutation(W)] for _ in range(K - 1)]
    else:
        starts = [rng.random((W, d)) for _ in range(K)]
    free = np.array([j for j in range(d) if j not in fixed], dtype=int)
    embed = _Embedding(d, free, fixed)

    # "de": differential-evolution proposals with 20 % snooker moves, emcee's advice for posteriors with
    # strongly correlated or curved ridges, where the stretch move's autocorrelation runs to ~10³ steps.
    chosen = None if moves == "stretch" else [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    samplers, states = [], []
    for k in range(K):
        sampler = emcee.EnsembleSampler(W, len(free), lambda V: log_prob(embed(V)), vectorize=True, moves=chosen)
        sampler.random_state = np.random.RandomState(np.random.MT19937(streams[k])).get_state()
        samplers.append(sampler)
        states.append(emcee.State(starts[k][:, free], log_prob=start_lp[k]))
    thin = thin or max(1, math.ceil((objective.remaining // (K * W) + 1) / MAX_STORED))
    runs, stored, idle, next_check, verdict = None, 0, 0, FIRST_CHECK, None
    # −inf − (−inf) = NaN in emcee's acceptance test when a walker and its proposal both blew up:
    # the comparison with NaN is False, i.e. rejected, which is right; the warning is noise.
    with np.errstate(invalid="ignore"):
        while not objective.exhausted and idle < STUCK_STEPS:
            spent = objective.nfev
            if runs is None:  # emcee preallocates: ask for as many steps as the budget can still pay for
                length = objective.remaining // (K * W * thin) + 1
                runs = [
                    s.sample(st, iterations=length, thin_by=thin, skip_initial_state_check=True)
                    for s, st in zip(samplers, states)
                ]
            try:
                states = [next(run) for run in runs]
            except StopIteration:  # proposals outside the box cost nothing: steps were cheaper than paid for
                runs = None
                continue
            stored += 1
            idle = idle + 1 if objective.nfev == spent else 0
            if stop == "converged" and stored >= next_check and not objective.exhausted:
                verdict = _verdict(samplers, embed, K, objective)
                if verdict["converged"]:
                    break
                next_check = stored + max(FIRST_CHECK // 2, stored // 10)
    chain, lp = _stacked(samplers, embed)
    if stop == "converged" and (verdict is None or verdict["steps"] != len(chain)):
        verdict = _verdict(samplers, embed, K, objective)
    message = _message(verdict, idle >= STUCK_STEPS, objective, len(chain), thin)
    n_steps = len(chain)
    autocorr = None
    if n_steps >= 2:
        with np.errstate(invalid="ignore", divide="ignore"):  # a walker that never moved: 0/0
            autocorr = emcee.autocorr.integrated_time(chain, quiet=True, tol=0) * thin
        autocorr[list(fixed)] = np.nan  # a coordinate held fixed has no autocorrelation
    return {
        "message": "; ".join([message, *notes]),
        "chain": chain,
        "log_prob": lp,
        "acceptance_fraction": float(np.mean([s.acceptance_fraction for s in samplers])) if n_steps else float("nan"),
        "autocorr_time": autocorr,
        "n_steps": int(n_steps * thin),
        "n_walkers": K * W,
        "n_data": log_prob.n_data,
        "ensembles": K,
        "thin": thin,
        "converged": None if verdict is None else bool(verdict["converged"]),
        "fixed": _fixed_values(objective.problem, embed),
    }


def _fixed_values(problem, embed) -> dict:
    """{name: physical value} of the coordinates a reduced model holds fixed."""
    P = problem.from_unit(embed(np.full((1, len(embed.free)), 0.5)))[0]
    return {problem.param_names[j]: float(P[j]) for j in embed.fixed}


class _LogProb:
    """log posterior of unit points (m, d): −inf outside the box, past the budget and on blow-up."""

    def __init__(self, objective, n_data):
        self.objective = objective
        self.given = n_data is not None
        self.n_data = int(n_data if n_data is not None else getattr(objective.problem, "n_data", 1000))
        self.errstate = np.geterr()

    def __call__(self, U):
        # Never raises: emcee prints the walkers and a traceback for any exception from here.
        U = np.atleast_2d(U)
        inside = np.all((U >= 0.0) & (U <= 1.0), axis=1)
        lp = np.full(len(U), -np.inf)
        if inside.any() and not self.objective.exhausted:
            with np.errstate(**self.errstate):  # the sampling loop's silencing is for emcee only
                if self.given:
                    mse = self.objective.batch(U[inside])
                    # tiny: an exact fit must not give log p = +inf.
                    lp[inside] = -0.5 * self.n_data * np.log(np.maximum(mse, np.finfo(float).tiny))
                else:
                    lp[inside] = self.objective.batch_with_likelihood(U[inside])[1]
        return lp


class _Embedding:
    """The sampled coordinates (m, len(free)) put back into the full unit vector, fixed ones filled in."""

    def __init__(self, d, free, fixed: dict):
        self.d, self.free, self.fixed = d, free, fixed

    def __call__(self, V):
        V = np.atleast_2d(V)
        U = np.empty((len(V), self.d))
        U[:, self.free] = V
        for j, value in self.fixed.items():
            U[:, j] = value
        return U


def _stacked(samplers, embed):
    """(chain (steps, K·W, d), log_prob (steps, K·W)) of every ensemble, cut to the shortest."""
    steps = min(s.iteration for s in samplers)
    if steps == 0:
        return np.empty((0, sum(s.nwalkers for s in samplers), embed.d)), np.empty(
            (0, sum(s.nwalkers for s in samplers))
        )
    chain = np.concatenate([s.get_chain()[:steps] for s in samplers], axis=1)
    full = embed(chain.reshape(-1, chain.shape[2])).reshape(steps, chain.shape[1], embed.d)
    return full, np.concatenate([s.get_log_prob()[:steps] for s in samplers], axis=1)


def _verdict(samplers, embed, K, objective) -> dict:
    from bwbench.analysis import mcmc

    chain, lp = _stacked(samplers, embed)
    return mcmc.assess(chain, lp, K, list(objective.problem.param_names))


def _message(verdict, stuck, objective, stored, thin) -> str:
    steps = f"{stored:,} stored steps" + (f" (1 in {thin} of {stored * thin:,})" if thin > 1 else "")
    if stuck:
        head = "every proposal fell outside the box; stopped"
    elif verdict is not None and verdict["converged"]:
        return (
            f"converged after {objective.nfev:,} evaluations, {steps}: R̂ ≤ 1.01 and bulk ESS ≥ 400 for every "
            f"sampled parameter" + verdict["modes_text"]
        )
    else:
        head = "budget exhausted"
    if verdict is None:
        return head
    return f"{head} before convergence ({steps}){verdict['modes_text']}: " + "; ".join(verdict["why"])


def _ball_at_optimum(objective, rng, n_walkers: int, fraction: float, radius: float) -> np.ndarray:
    """Walkers in a ball of ``radius`` (unit coordinates) around the best point a CMA-ES run on ``fraction`` of the
    remaining budget found (every evaluation counts against the objective's budget)."""
    from bwbench.optimizers.cmaes import minimize as cmaes
    from bwbench.optimizers.sampling.budget_share import Share

    share = Share(objective, int(fraction * objective.remaining))
    try:
        cmaes(share, rng=rng)
    except BudgetExhausted:
        pass
    centre = objective.best_u if objective.best_u is not None else rng.random(objective.dim)
    return np.clip(centre + radius * rng.standard_normal((n_walkers, objective.dim)), 0.0, 1.0)
