"""Nested sampling (UltraNest) of the posterior over the unit box: every mode with its mass, and the
model evidence ln Z, from independent runs added until the runs' scatter says the posterior is known to
the precision target (``bwbench.analysis.posterior_verdict``) or the budget is spent.

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

**Runs, added until precise.** ``runs`` independent ``ultranest.ReactiveNestedSampler`` runs first, each
on an equal share of the budget, each from its own seed drawn from ``rng`` in order (UltraNest draws from
numpy's global generator: ``bwbench.engine.global_rng.seeded_global_rng``). Then the verdict's
precision — the standard error of every pooled mean, 5/95 % quantile and region mass from the scatter
between runs — says how many runs the target needs (the SE falls as 1/√runs); that many more are run,
on equal shares of what is left, and so on until the target is met, ``max_runs`` is reached, or the
budget would not pay for another run of the size the finished ones took. Which runs are added depends
only on the finished runs, never on ``workers``: ``workers`` processes (forked, each with its own
objective on its run's share; their evaluations and best points are then counted here) run a round's
runs side by side, and give the same draws as one.

A run stops when the evidence left in its live points is below ``dlogz`` and it holds ``min_ess``
effective draws (UltraNest's own criteria), or when its share is spent (then it is "cut" and says so).
Sampling inside the likelihood contour: UltraNest's MLFriends region (rejection from ellipsoids around
the live points) up to ``REGION_MAX_DIM`` parameters, its vectorised simple population slice sampler
beyond (option ``step_sampler``): a quarter of the live points as walkers, each moved ``steps``·d slice
steps, each step along either the difference of two live points or a principal axis of their ellipsoid
(UltraNest's mixture direction), every shrink of every walker one batch. **The steps are checked by
doubling**, as UltraNest advises: every ``DOUBLED_EVERY``-th run takes twice the steps, and the verdict
compares those runs with the others. UltraNest's insertion-order test (is each new live point's rank
among the live points uniform?) is recorded for every run. Measured on pom-mt24u01 0.05 MPa (switched
model, d = 7): UltraNest's other population slice sampler, which reverts a walker whenever the
threshold overtakes one of its past steps, restarted most walkers and every run was cut; this one lets
every run end by its own rule.

Draws: each run's weighted samples become ``draws_per_run`` equal-weight draws (systematic resampling,
shuffled) — at least ``MIN_DRAWS``, more when every run's Kish effective sample size allows, so a run cut
by the budget or a tiny run still gives draws (repeats of its few heavy points: the weighted draws as
they are) and never a table of NaN; each run's effective sample size is kept beside them. All runs hold
the same number of draws, so they form the chains (draws, runs, d) of the verdict.

A model that blows up, or a point past the budget: log-likelihood −1e300 (UltraNest refuses −inf),
never a live point. Options: ``runs`` (4 first), ``max_runs`` (32), ``live_points`` (200), ``steps``
(slice steps per parameter, 1), ``dlogz`` (0.5), ``min_ess`` (300 per run: the verdict's R̂ badge wants
≥ 300 effective draws a run), ``step_sampler`` ("auto"), ``workers`` (1), ``n_data`` (None). Extras:
``chain`` (draws, runs, d) unit coordinates, ``log_prob`` (draws, runs) log-likelihood, per run
``log_z``, ``log_z_err``, ``run_nfev``, ``run_complete``, ``run_ess``, ``run_steps``, ``insertion``
(UltraNest's test passed, or None), ``live_points``, ``converged``, ``verdict`` (``Verdict.as_dict``), and
``profile`` (``posterior_profile.profile`` from the pooled draws, with its ``nfev``) when the budget is at
least ``PROFILE_SHARE`` times what the profiles cost (their evaluations are kept aside from the start).
"""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
import warnings

import numpy as np

from bwbench.analysis import posterior_profile
from bwbench.engine.options import Choice, Float, Int
from bwbench.engine.registry import register

# MLFriends' rejection sampling: efficient on round posteriors of a few parameters; on the models' thin
# curved ridges (7 parameters of the switched model's identifiable formulation) it accepted 0 of 1,024
# draws by iteration 98. Beyond this many parameters, the vectorised slice sampler.
REGION_MAX_DIM = 3
MAX_DRAWS = 4000  # equal-weight draws kept per run at most
MIN_DRAWS = 1000  # and at least (repeats of a cut run's few heavy points)
NDRAW_MAX = 1024  # most points UltraNest's region sampling draws in one vectorised call
MIN_LIVE = 20  # fewer live points than this: the run is not started
POP_DIVISOR = 4  # slice walkers = live points / this: a quarter of the live points per vectorised batch
DOUBLED_EVERY = 4  # every 4th run takes twice the slice steps: the steps checked by doubling
SLICE_DIRECTION = "generate_mixture_random_direction"  # region-oriented or differential, at random
IMPOSSIBLE = -1e300  # the log-likelihood UltraNest gets for a blow-up (it refuses non-finite values)
PROFILE_SHARE = 20  # the profiles are run when the budget is at least this many times their cost
MIN_ADDED = 2  # runs added in a round at least (the SE's estimate from few runs is rough)

_JOB: dict = {}  # the problem and settings a forked worker reads (set before the fork)


@register(
    "nested",
    family="nested",
    description="UltraNest nested sampling, uniform prior on the box: every mode with its mass, and ln Z, "
    "from independent runs added until they agree to a stated precision",
    options={
        "runs": Int(4, minimum=1, maximum=64),
        "max_runs": Int(32, minimum=1, maximum=256),
        "live_points": Int(200, minimum=20, maximum=100_000),
        "steps": Int(1, minimum=1, maximum=64),
        "dlogz": Float(0.5, minimum=0.001, maximum=100.0),
        "min_ess": Int(300, minimum=10, maximum=1_000_000),
        "step_sampler": Choice("auto", ("auto", "region", "slice")),
        "workers": Int(1, minimum=1, maximum=256),
        "n_data": Int(None, minimum=1, maximum=10**9, none="the problem's number of data points"),
    },
)
def minimize(
    objective,
    *,
    rng,
    runs=4,
    max_runs=32,
    live_points=200,
    steps=1,
    dlogz=0.5,
    min_ess=300,
    step_sampler="auto",
    workers=1,
    n_data=None,
):
    _quiet()
    d = objective.dim
    job = {
        "problem": objective.problem,
        "n_data": n_data,
        "dlogz": dlogz,
        "min_ess": min_ess,
        "slice": step_sampler == "slice" or (step_sampler == "auto" and d > REGION_MAX_DIM),
        "d": d,
    }
    max_runs = max(max_runs, runs)
    # the profile likelihoods after the runs (``posterior_profile``): their evaluations kept aside when the
    # budget is large enough for them to be a small part of it
    reserve = posterior_profile.cost(d) if objective.budget >= PROFILE_SHARE * posterior_profile.cost(d) else 0
    results: list = []
    plan, lost = runs, 0
    while len(results) < plan:
        k = plan - len(results)
        factors = [2 if (len(results) + i) % DOUBLED_EVERY == DOUBLED_EVERY - 1 else 1 for i in range(k)]
        # each run's share of what is left in proportion to its steps (a run of doubled steps costs more)
        unit_share = (objective.remaining - reserve) // sum(factors)
        live = min(live_points, unit_share // 4)  # a share too small for the asked live points: fewer
        if live < MIN_LIVE:
            break
        specs = [
            {"seed": int(rng.integers(2**63)), "share": unit_share * f, "live": live, "steps": steps * f}
            for f in factors
        ]
        for found in _execute(job, specs, workers):
            _count(objective, found.pop("objective"))
            if found.get("lost"):
                lost += 1
            else:
                results.append(found)
        if lost or not all(r["complete"] for r in results):
            break  # runs cut: more runs on smaller shares would be cut too
        plan = _next_plan(results, objective, job, max_runs, reserve)
    if not results:
        # not enough budget for one run: what is left goes to prior draws, so there is a best point to report
        if not objective.exhausted:
            log_like = _LogLike(objective, n_data, stop=objective.budget, raise_when_spent=False)
            log_like(rng.random((objective.remaining, d)))
        if lost:
            why = (
                f"every run ({lost}) spent its share of the {objective.budget:,} evaluations inside one UltraNest "
                "iteration and was lost (fewer live points or a larger budget): nothing sampled"
            )
        else:
            why = (
                f"budget of {objective.budget:,} evaluations too small for one nested-sampling run (at least "
                f"{4 * MIN_LIVE * runs:,} for {runs} runs): spent on uniform draws from the prior, nothing sampled"
            )
        return {"message": why, "converged": False}
    extras = _extras(results, rng, objective, live_points, runs)
    if reserve and objective.remaining >= reserve:
        flat, lp = extras["chain"].reshape(-1, d), extras["log_prob"].reshape(-1)
        extras["profile"] = _profile(objective, n_data, flat, lp)
    if lost:
        extras["message"] += (
            f"; {lost} run(s) spent their share of the budget inside one UltraNest iteration and were lost"
        )
    return extras


def _profile(objective, n_data, draws, log_prob) -> dict:
    """``posterior_profile.profile`` on the objective's budget (counted), with the evaluations it spent."""
    log_like = _LogLike(objective, n_data, stop=objective.budget)
    start = objective.nfev

    def counted(U):
        try:
            return log_like(U)
        except _ShareSpent:
            raise StopIteration from None

    found = posterior_profile.profile(counted, draws, log_prob)
    found["nfev"] = int(objective.nfev - start)
    return found


def _next_plan(results, objective, job, max_runs, reserve) -> int:
    """How many runs in all the precision target asks for, given the finished runs (the verdict's
    ``needed``), capped by ``max_runs`` and by what the budget left pays at the finished runs' size."""
    from bwbench.analysis import posterior_verdict

    if len(results) < posterior_verdict.MIN_RUNS:
        return len(results)
    chain, lp, _ = _draws(results, np.random.default_rng(0))
    verdict = posterior_verdict.judge(
        chain,
        lp,
        [r["log_z"] for r in results],
        [r["log_z_err"] for r in results],
        [f"u{j}" for j in range(job["d"])],
        from_unit=objective.problem.from_unit,
        run_nfev=[r["nfev"] for r in results],
    )
    if verdict.precision_met or verdict.needed is None:
        return len(results)
    per_run = max(r["nfev"] for r in results) * 1.1  # a run's size varies (doubled steps cost more): a margin
    affordable = len(results) + int((objective.remaining - reserve) // per_run)
    want = max(verdict.needed["runs"], len(results) + MIN_ADDED)
    return min(max_runs, affordable, want)


def _execute(job: dict, specs: list, workers: int) -> list:
    """The runs of ``specs`` (in order), side by side in ``workers`` forked processes when more than one."""
    global _JOB
    _JOB = job
    if workers <= 1 or len(specs) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [_run_spec(spec) for spec in specs]
    context = multiprocessing.get_context("fork")
    with context.Pool(min(workers, len(specs))) as pool:
        return pool.map(_run_spec, specs, chunksize=1)


def _run_spec(spec: dict) -> dict:
    """One run on its own objective (its share of the budget); what it spent and found comes back with it."""
    from bwbench.engine.global_rng import seeded_global_rng
    from bwbench.engine.objective import Objective

    job = _JOB
    objective = Objective(job["problem"], spec["share"])
    log_like = _LogLike(objective, job["n_data"], stop=spec["share"])
    with seeded_global_rng(np.random.default_rng(spec["seed"])):
        try:
            found = _one_run(log_like, job, spec)
        except _ShareSpent:  # UltraNest only checks max_ncalls between iterations: this run is lost
            found = {"lost": True}
    found["objective"] = {
        "nfev": objective.nfev,
        "best_mse": objective.best_mse,
        "best_u": objective.best_u,
        "trace": list(zip(objective.trace_nfev, objective.trace_mse)),
        "pid": os.getpid(),
    }
    return found


def _count(objective, spent: dict) -> None:
    """Charge a run's evaluations to the study's objective and keep its best point and trace."""
    base = objective.nfev
    objective.nfev = min(objective.budget, base + spent["nfev"])
    for nfev, mse in spent["trace"]:
        if mse < objective.best_mse:
            objective.best_mse = float(mse)
            objective.trace_nfev.append(base + int(nfev))
            objective.trace_mse.append(float(mse))
            objective.best_u = np.asarray(spent["best_u"], float).copy()


def _one_run(log_like, job: dict, spec: dict) -> dict:
    import ultranest

    d, live_points, share = job["d"], spec["live"], spec["share"]
    popsize = max(1, live_points // POP_DIVISOR)
    sampler = ultranest.ReactiveNestedSampler(
        [f"u{j}" for j in range(d)],
        log_like,
        vectorized=True,
        ndraw_min=min(128, live_points),
        ndraw_max=NDRAW_MAX,
        num_test_samples=2,
    )
    nsteps = spec["steps"] * d
    if job["slice"]:
        from ultranest import popstepsampler

        # Each call moves a population of walkers ``nsteps`` whole slice steps at one threshold, every
        # shrink a vectorised batch, and hands out the population one point per iteration; a point that
        # has fallen below the risen threshold by then is skipped (UltraNest checks), so it stays exact.
        # UltraNest's other population sampler (PopulationSliceSampler) reverts every walker whose past
        # steps fall below the threshold: with a population as large as the live points most walkers
        # restarted, 176 evaluations per iteration, and runs were cut at 500,000 evaluations.
        sampler.stepsampler = popstepsampler.PopulationSimpleSliceSampler(
            popsize=popsize, nsteps=nsteps, generate_direction=getattr(popstepsampler, SLICE_DIRECTION)
        )
    # UltraNest checks max_ncalls between iterations only, and one iteration may cost up to ndraw_max
    # (region sampling) or a population's slice moves (typically ~10 shrinks per step): stop that much
    # short of the share
    margin = (popsize * nsteps * 20) if job["slice"] else NDRAW_MAX
    max_ncalls = max(1, share - 2 - margin)
    # −1e300 likelihoods overflow UltraNest's bootstrapped error of ln Z (squares): its result is still right.
    # Its "sampling from region seems inefficient" warning is about cost, which the run's evaluations show.
    with np.errstate(over="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        out = sampler.run(
            min_num_live_points=live_points,
            dlogz=job["dlogz"],
            min_ess=job["min_ess"],
            show_status=False,
            viz_callback=False,
            max_ncalls=max_ncalls,
            max_num_improvement_loops=3,
            cluster_num_live_points=min(40, live_points // 3),
        )
    weighted = out["weighted_samples"]
    insertion = out.get("insertion_order_MWW_test") or {}
    return {
        "live_points": live_points,
        "steps": nsteps,
        "log_z": float(out["logz"]),
        "log_z_err": float(out["logzerr"]),
        "nfev": int(log_like.objective.nfev),
        "complete": bool(sampler.ncall < max_ncalls),
        "u": np.asarray(weighted["upoints"], dtype=float),
        "weights": np.asarray(weighted["weights"], float),
        "logl": np.asarray(weighted["logl"], dtype=float),
        "ess": float(out["ess"]),
        "insertion": None if "converged" not in insertion else bool(insertion["converged"]),
    }


class _ShareSpent(Exception):
    """A run asked for a point past its share of the budget."""


class _LogLike:
    """Vectorised log-likelihood of unit points (m, d), counted by the objective; blow-ups read
    ``IMPOSSIBLE``; rows past ``stop`` (this run's share) read ``IMPOSSIBLE`` too, and a call that
    starts there raises ``_ShareSpent`` (UltraNest's slice sampler would otherwise search forever)."""

    def __init__(self, objective, n_data, stop: int, raise_when_spent: bool = True):
        self.objective = objective
        self.given = n_data is not None
        self.n_data = int(n_data if n_data is not None else getattr(objective.problem, "n_data", 1000))
        self.stop = stop
        self.raise_when_spent = raise_when_spent

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
    """Indices of ``size`` equal-weight draws from weighted points ``u`` (systematic resampling), shuffled."""
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    positions = (rng.random() + np.arange(size)) / size
    index = np.minimum(np.searchsorted(np.cumsum(w), positions), len(w) - 1)
    return index[rng.permutation(size)]


def draws_per_run(ess) -> int:
    """Equal-weight draws kept per run: every run's effective sample size when all allow it, between
    ``MIN_DRAWS`` and ``MAX_DRAWS``."""
    least = min((max(1.0, math.floor(e)) for e in ess), default=1.0)
    return int(min(MAX_DRAWS, max(MIN_DRAWS, least)))


def _draws(results, rng) -> tuple:
    """(chain (n, runs, d), log-likelihoods (n, runs), n) of the runs' equal-weight draws."""
    size = draws_per_run([r["ess"] for r in results])
    chain, log_prob = [], []
    for r in results:
        index = equal_weight_draws(r["u"], r["weights"], size, rng)
        chain.append(r["u"][index])
        log_prob.append(r["logl"][index])
    return np.stack(chain, axis=1), np.stack(log_prob, axis=1), size


def _extras(results, rng, objective, live_points, runs) -> dict:
    from bwbench.analysis import posterior_verdict

    chain_arr, lp, _ = _draws(results, rng)
    names = list(objective.problem.param_names)
    per_run = {
        "log_z": [r["log_z"] for r in results],
        "log_z_err": [r["log_z_err"] for r in results],
        "run_nfev": [r["nfev"] for r in results],
        "run_complete": [r["complete"] for r in results],
        "run_ess": [r["ess"] for r in results],
        "run_steps": [r["steps"] for r in results],
        "insertion": [r["insertion"] for r in results],
    }
    verdict = posterior_verdict.judge(
        chain_arr,
        lp,
        per_run["log_z"],
        per_run["log_z_err"],
        names,
        complete=per_run["run_complete"],
        ess=per_run["run_ess"],
        insertion=per_run["insertion"],
        run_nfev=per_run["run_nfev"],
        steps=per_run["run_steps"],
        from_unit=objective.problem.from_unit,
        runs_asked=runs,
    )
    fewer = sorted({r["live_points"] for r in results if r["live_points"] < live_points})
    message = verdict.line + (
        f"; the budget allowed only {', '.join(map(str, fewer))} live points in some runs (asked {live_points})"
        if fewer
        else ""
    )
    return {
        "message": message,
        "chain": chain_arr,
        "log_prob": lp,
        **per_run,
        "live_points": live_points,
        "n_data": objective.problem.n_data if hasattr(objective.problem, "n_data") else None,
        "converged": bool(verdict.converged),
        "verdict": verdict.as_dict(),
    }


def _quiet() -> None:
    """UltraNest logs every run's progress to stdout unless its logger already has a handler."""
    logger = logging.getLogger("ultranest")
    if not logger.handlers:
        logger.addHandler(logging.NullHandler())
        logger.propagate = False
