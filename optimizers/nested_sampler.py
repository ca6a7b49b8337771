"""Nested sampling (UltraNest) of the posterior over the unit box: every mode with its mass, and the
model evidence ln Z, from ``runs`` independent runs.

Not an optimiser: it samples, and the point estimate is the best loss the objective met along the way.

Posterior over u ∈ [0, 1]^d: a uniform prior on the box (the searched coordinates, so log-uniform in a
parameter whose box is logarithmic) times the likelihood ``objective.batch_with_likelihood`` gives (the
problem's marginal likelihood when it has one, else −(L/2)·log MSE with σ integrated out under
Jeffreys' prior; with ``n_data`` given, that formula with L = ``n_data``), as in the emcee backend. The
prior's density is 1 on the unit box, so ln Z is the log of the likelihood's mean over the box: a box
twice as wide in a parameter the data pin down lowers ln Z by ln 2 (``bwbench.analysis.nested``).

Why UltraNest: measured against dynesty on toys with a known answer (a 5-D Gaussian of closed-form
ln Z, a 0.7/0.3 two-mode mixture), UltraNest needed the fewest evaluations (13,500 and 17,600 against
dynesty's 20,000 and 20,000 with uniform sampling, 100,000+ with slice sampling), got ln Z and the
masses within their errors, and evaluates a whole population in one vectorised call
(``vectorized=True``), which is what the batched kernel wants; dynesty's pool maps its sampling
functions, not the likelihood, so it cannot batch.

Runs: ``runs`` independent ``ultranest.ReactiveNestedSampler`` runs in turn, each on an equal share
of what is left of the budget (a run that stops early leaves more to the next), each from its own
stream of ``rng`` (UltraNest draws from numpy's global generator:
``bwbench.engine.global_rng.seeded_global_rng``). A run stops when the evidence left in its live
points is below ``dlogz`` and it holds ``min_ess`` effective draws (UltraNest's own criteria), or when
its share is spent (then it is "cut" and says so). Sampling inside the likelihood contour: UltraNest's
MLFriends region (rejection from ellipsoids around the live points) up to ``REGION_MAX_DIM``
parameters, its vectorised simple population slice sampler beyond (option ``step_sampler``): a
quarter of the live points as walkers, each moved d slice steps, each step along either the
difference of two live points or a principal axis of their ellipsoid (UltraNest's mixture direction:
the differences follow curved ridges and weakly pinned directions, the axes straight correlated ones),
every shrink of every walker one batch. Measured on pom-mt24u01 0.05 MPa (switched model, d = 7,
1,000,000 evaluations for 4 runs): UltraNest's other population slice sampler, which reverts a walker
whenever the threshold overtakes one of its past steps, restarted most walkers (176 evaluations an
iteration early on) and every run was cut with one effective draw; with it replaced, every run ends by
its own rule (735,000 evaluations for the 4, ~600 effective draws each), but the runs still disagree on
the weakly pinned directions (R̂ 1.05-1.23 with the mixture, up to 1.42 with axes alone; 2·d steps at 60
live points: runs cut at 250,000, R̂ up to 1.27), and the verdict says so.

Draws: from each run's weighted samples, as many equal-weight draws as its Kish effective sample size
(systematic resampling, shuffled: the draws of a run are then nearly independent, and ArviZ's bulk ESS
of them is honest), all runs cut to the same number so they form the chains (draws, runs, d) of
``bwbench.analysis.nested.assess`` (rank-normalised split-R̂ and bulk ESS across runs, ln Z and mode
masses agreeing between runs). Stored as the ``chain`` extra (equal weights: each draw weighs 1/n).

A model that blows up, or a point past the budget: log-likelihood −1e300 (UltraNest refuses −inf),
never a live point. Options: ``runs`` (4), ``live_points`` (100), ``dlogz`` (0.5), ``min_ess`` (150
per run; 4 runs × 150 leave margin over ArviZ's 400), ``step_sampler`` ("auto"), ``n_data`` (None).
Extras: ``chain`` (draws, runs, d) unit coordinates, ``log_prob`` (draws, runs) log-likelihood,
``log_z``, ``log_z_err``, ``run_nfev``, ``run_complete`` (one per run), ``live_points``, ``converged``.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np

from bwbench.engine.options import Choice, Float, Int
from bwbench.engine.registry import register

# MLFriends' rejection sampling: efficient on round posteriors of a few parameters; on the models' thin
# curved ridges (7 parameters of the switched model's identifiable formulation) it accepted 0 of 1,024
# draws by iteration 98. Beyond this many parameters, the vectorised slice sampler.
REGION_MAX_DIM = 3
MAX_DRAWS = 4000  # equal-weight draws kept per run
NDRAW_MAX = 1024  # most points UltraNest's region sampling draws in one vectorised call
MIN_LIVE = 20  # fewer live points than this: the run is not started
POP_DIVISOR = 4  # slice walkers = live points / this: a quarter of the live points per vectorised batch
SLICE_STEPS_PER_DIM = 1  # slice steps per parameter before a walker's point is handed out
SLICE_DIRECTION = "generate_mixture_random_direction"  # region-oriented or differential, at random
IMPOSSIBLE = -1e300  # the log-likelihood UltraNest gets for a blow-up (it refuses non-finite values)


@register(
    "nested",
    family="nested",
    description="UltraNest nested sampling, uniform prior on the box: every mode with its mass, and ln Z, "
    "from independent runs",
    options={
        "runs": Int(4, minimum=1, maximum=64),
        "live_points": Int(100, minimum=20, maximum=100_000),
        "dlogz": Float(0.5, minimum=0.001, maximum=100.0),
        "min_ess": Int(150, minimum=10, maximum=1_000_000),
        "step_sampler": Choice("auto", ("auto", "region", "slice")),
        "n_data": Int(None, minimum=1, maximum=10**9, none="the problem's number of data points"),
    },
)
def minimize(objective, *, rng, runs=4, live_points=100, dlogz=0.5, min_ess=150, step_sampler="auto", n_data=None):
    from bwbench.engine.global_rng import seeded_global_rng

    _quiet()
    d = objective.dim
    slice_sampling = step_sampler == "slice" or (step_sampler == "auto" and d > REGION_MAX_DIM)
    log_like = _LogLike(objective, n_data)
    results, lost = [], 0
    for k in range(runs):
        share = objective.remaining // (runs - k)
        # a share too small for the asked live points: fewer (a coarser run, said in the message), and
        # below MIN_LIVE none (the run is not started)
        live = min(live_points, share // 4)
        if live < MIN_LIVE:
            results.append(None)
            continue
        log_like.stop = objective.nfev + share
        with seeded_global_rng(rng):
            try:
                results.append(_one_run(log_like, d, live, dlogz, min_ess, share, slice_sampling))
            except _ShareSpent:  # UltraNest only checks max_ncalls between iterations: this run is lost
                results.append(None)
                lost += 1
    if all(r is None for r in results) and not objective.exhausted:
        # not enough budget for one run: the budget goes to prior draws, so there is a best point to report
        log_like.stop, log_like.raise_when_spent = objective.budget, False
        log_like(rng.random((objective.remaining, d)))
        return {
            "message": f"budget of {objective.budget:,} evaluations too small for one nested-sampling run "
            f"(at least {4 * MIN_LIVE * runs:,} for {runs} runs): spent on uniform draws from the "
            "prior, nothing sampled",
            "converged": False,
        }
    extras = _extras(results, rng, objective, live_points, runs)
    if lost:
        extras["message"] += (
            f"; {lost} run(s) spent their share of the budget inside one UltraNest iteration and were lost"
        )
    return extras


def _one_run(log_like, d, live_points, dlogz, min_ess, share, slice_sampling) -> dict:
    import ultranest

    start = log_like.objective.nfev
    popsize = max(1, live_points // POP_DIVISOR)
    sampler = ultranest.ReactiveNestedSampler(
        [f"u{j}" for j in range(d)],
        log_like,
        vectorized=True,
        ndraw_min=min(128, live_points),
        ndraw_max=NDRAW_MAX,
        num_test_samples=2,
    )
    if slice_sampling:
        from ultranest import popstepsampler

        # Each call moves a population of walkers ``nsteps`` whole slice steps at one threshold, every
        # shrink a vectorised batch, and hands out the population one point per iteration; a point that
        # has fallen below the risen threshold by then is skipped (UltraNest checks), so it stays exact.
        # UltraNest's other population sampler (PopulationSliceSampler) reverts every walker whose past
        # steps fall below the threshold: with a population as large as the live points most walkers
        # restarted, 176 evaluations per iteration, and runs were cut at 500,000 evaluations.
        sampler.stepsampler = popstepsampler.PopulationSimpleSliceSampler(
            popsize=popsize, nsteps=SLICE_STEPS_PER_DIM * d, generate_direction=getattr(popstepsampler, SLICE_DIRECTION)
        )
    # UltraNest checks max_ncalls between iterations only, and one iteration may cost up to ndraw_max
    # (region sampling) or a population's slice moves (typically ~10 shrinks per step): stop that much
    # short of the share
    margin = (popsize * SLICE_STEPS_PER_DIM * d * 20) if slice_sampling else NDRAW_MAX
    max_ncalls = max(1, share - 2 - margin)
    # −1e300 likelihoods overflow UltraNest's bootstrapped error of ln Z (squares): its result is still right.
    # Its "sampling from region seems inefficient" warning is about cost, which the run's evaluations show.
    with np.errstate(over="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        out = sampler.run(
            min_num_live_points=live_points,
            dlogz=dlogz,
            min_ess=min_ess,
            show_status=False,
            viz_callback=False,
            max_ncalls=max_ncalls,
            max_num_improvement_loops=3,
            cluster_num_live_points=min(40, live_points // 3),
        )
    nfev = log_like.objective.nfev - start
    weighted = out["weighted_samples"]
    return {
        "live_points": live_points,
        "log_z": float(out["logz"]),
        "log_z_err": float(out["logzerr"]),
        "nfev": int(nfev),
        "complete": bool(sampler.ncall < max_ncalls),
        "u": np.asarray(weighted["upoints"], dtype=float),
        "weights": np.asarray(weighted["weights"], float),
        "logl": np.asarray(weighted["logl"], dtype=float),
        "ess": float(out["ess"]),
    }


class _ShareSpent(Exception):
    """A run asked for a point past its share of the budget."""


class _LogLike:
    """Vectorised log-likelihood of unit points (m, d), counted by the objective; blow-ups read
    ``IMPOSSIBLE``; rows past ``stop`` (this run's share) read ``IMPOSSIBLE`` too, and a call that
    starts there raises ``_ShareSpent`` (UltraNest's slice sampler would otherwise search forever)."""

    def __init__(self, objective, n_data):
        self.objective = objective
        self.given = n_data is not None
        self.n_data = int(n_data if n_data is not None else getattr(objective.problem, "n_data", 1000))
        self.stop = objective.budget
        self.raise_when_spent = True

    def __call__(self, U):
        U = np.atleast_2d(np.asarray(U, dtype=float))
        ll = np.full(len(U), IMPOSSIBLE)
        take = max(0, min(len(U), self.stop - self.objective.nfev, self.objective.remaining))
        if not take and self.raise_when_spent:
            raise _ShareSpent
        if take:
            if self.given:
                mse = self.objective.batch(U[:take])
                with np.errstate(divide="ignore", invalid="ignore"):
                    run = -0.5 * self.n_data * np.log(np.maximum(mse, np.finfo(float).tiny))
            else:
                run = self.objective.batch_with_likelihood(U[:take])[1]
            ll[:take] = np.where(np.isfinite(run), run, IMPOSSIBLE)
        return ll


def equal_weight_draws(u, weights, size: int, rng) -> np.ndarray:
    """``size`` equal-weight draws from weighted points ``u`` (systematic resampling), shuffled."""
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    positions = (rng.random() + np.arange(size)) / size
    index = np.minimum(np.searchsorted(np.cumsum(w), positions), len(w) - 1)
    return index[rng.permutation(size)]


def _extras(results, rng, objective, live_points, runs) -> dict:
    from bwbench.analysis import nested

    done = [r for r in results if r is not None]
    if not done:
        return {
            "message": f"no run finished within the budget of {objective.budget:,} evaluations: nothing sampled",
            "converged": False,
        }
    size = int(min(MAX_DRAWS, *(max(1.0, np.floor(r["ess"])) for r in done)))
    chain, log_prob = [], []
    for r in done:
        index = equal_weight_draws(r["u"], r["weights"], size, rng)
        chain.append(r["u"][index])
        log_prob.append(r["logl"][index])
    chain_arr = np.stack(chain, axis=1)  # (draws, runs, d)
    lp = np.stack(log_prob, axis=1)
    verdict = nested.assess(
        chain_arr,
        lp,
        [r["log_z"] for r in done],
        [r["log_z_err"] for r in done],
        list(objective.problem.param_names),
        complete=[r["complete"] for r in done],
        runs_asked=runs,
    )
    fewer = sorted({r["live_points"] for r in done if r["live_points"] < live_points})
    message = verdict["message"] + (
        f"; the budget allowed only {', '.join(map(str, fewer))} live points in some runs (asked {live_points})"
        if fewer
        else ""
    )
    return {
        "message": message,
        "chain": chain_arr,
        "log_prob": lp,
        "log_z": [r["log_z"] for r in done],
        "log_z_err": [r["log_z_err"] for r in done],
        "run_nfev": [r["nfev"] for r in done],
        "run_complete": [r["complete"] for r in done],
        "live_points": live_points,
        "n_data": objective.problem.n_data if hasattr(objective.problem, "n_data") else None,
        "converged": bool(verdict["converged"]),
    }


def _quiet() -> None:
    """UltraNest logs every run's progress to stdout unless its logger already has a handler."""
    logger = logging.getLogger("ultranest")
    if not logger.handlers:
        logger.addHandler(logging.NullHandler())
        logger.propagate = False
