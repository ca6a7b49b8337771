"""A study's posterior from Python, in physical units.

``Study.posterior(specimen)`` gives a DataFrame of draws in physical units and
``Study.to_inference_data(specimen)`` an ArviZ ``InferenceData``.

Read from the stored chains as the report reads them (``posterior_draws``): the sampled coordinates
mapped out of the unit box into physical units with the problem the chain sampled (in the
identifiable formulation: θ), the solved linear coefficients drawn from their conditional Gaussian
given each θ, the first half of every chain dropped as burn-in. The sampler's draws are equally
weighted (an ensemble MCMC), so there is no ``weight`` column; a sampler that weights its draws adds
one (the only place to change when the posterior engine changes is ``_draws``).
"""

from __future__ import annotations

import numpy as np

from bwbench.errors import UserError

SEED = 0  # the conditional draws of the linear coefficients are random: fixed, so a call repeats
DRAWS = 4000  # by default every chain is thinned to about this many draws in all (each is a simulation)


def chain_of(study, specimen: str):
    """The posterior chain of a specimen in a stored study.

    Parameters
    ----------
    study : bwbench.database.reader.Study
        The stored study.
    specimen : str
        The specimen's name.

    Returns
    -------
    bwbench.problems.hysteresis.report.posterior_draws.PosteriorChain

    Raises
    ------
    bwbench.errors.UserError
        When the study has no posterior run, none of ``specimen``, or its chain is not in the
        coordinates of its problem.

    Examples
    --------
    >>> chain_of(stored, "mytest").burn
    """
    from bwbench.problems.hysteresis.report.posterior_draws import posterior_chains

    stored = [c for c in study.chains if c.kind == "posterior"]
    if not stored:
        raise UserError(f"{study.path}: the study has no posterior run (add a [posterior] table to its TOML)")
    names = sorted({c.specimen for c in stored})
    if specimen not in names:
        raise UserError(f"{study.path}: no posterior of {specimen!r}; posteriors: {', '.join(names)}")
    chains = posterior_chains(study, [c for c in stored if c.specimen == specimen])
    if not chains:
        raise UserError(f"{study.path}: the posterior chain of {specimen!r} is not in the coordinates of its problem")
    return chains[0]


def _draws(posterior, thin: int) -> dict:
    """{name: (walkers, kept steps) array in physical units}.

    Every sampled and solved parameter after burn-in, every ``thin``-th step.
    """
    chain, problem = posterior.chain, posterior.problem
    kept = chain.samples[posterior.burn :: thin]  # (steps, walkers, d), unit coordinates
    steps, walkers, d = kept.shape
    P = problem.from_unit(kept.reshape(-1, d))
    out = {n: P[:, j] for j, n in enumerate(posterior.names)}
    if getattr(problem, "formulation", "") == "identifiable":
        from bwbench.problems.hysteresis.report.posterior_draws import linear_draws

        out.update(linear_draws(problem, P, np.random.default_rng(SEED)))
    # (steps·walkers,) in step-major order → (walkers, steps): ArviZ's (chain, draw)
    return {n: np.asarray(v, dtype=float).reshape(steps, walkers).T for n, v in out.items()}


def frame(study, specimen: str, thin: int | None = None):
    """A DataFrame of posterior draws of ``specimen`` (``Study.posterior``).

    Parameters
    ----------
    study : bwbench.database.reader.Study
        The stored study.
    specimen : str
        The specimen's name.
    thin : int or None, default None
        Keep every thin-th step (default: about ``DRAWS`` = 4,000 draws in all).

    Returns
    -------
    pandas.DataFrame
        ``walker``, ``step`` (after burn-in) and one column per parameter in physical units; the units
        in ``.attrs["units"]``.

    Raises
    ------
    bwbench.errors.UserError
        As ``chain_of``, or when ``thin`` is not a positive integer.

    Examples
    --------
    >>> frame(stored, "mytest", thin=10).head()
    """
    import pandas as pd

    posterior = chain_of(study, specimen)
    thin = _check_thin(posterior, thin)
    draws = _draws(posterior, thin)
    walkers, steps = next(iter(draws.values())).shape
    index = {
        "walker": np.repeat(np.arange(walkers), steps),
        "step": np.tile(posterior.burn + np.arange(steps) * thin, walkers),
    }
    out = pd.DataFrame({**index, **{n: v.ravel() for n, v in draws.items()}})
    out.attrs["units"] = units(posterior.problem, list(draws))
    return out


def inference_data(study, specimen: str, thin: int | None = None):
    """ArviZ ``InferenceData`` of the same draws as ``frame`` (``Study.to_inference_data``).

    Parameters
    ----------
    study : bwbench.database.reader.Study
        The stored study.
    specimen : str
        The specimen's name.
    thin : int or None, default None
        Keep every thin-th step (default: about ``DRAWS`` = 4,000 draws in all).

    Returns
    -------
    arviz.InferenceData
        Chains = walkers, draws = kept steps; the log-posterior under ``sample_stats.lp`` when stored;
        units in the posterior group's attrs.

    Raises
    ------
    bwbench.errors.UserError
        As ``frame``.

    Examples
    --------
    >>> inference_data(stored, "mytest").posterior.attrs["units"]
    """
    import arviz as az

    posterior = chain_of(study, specimen)
    thin = _check_thin(posterior, thin)
    draws = _draws(posterior, thin)
    stats = {}
    if posterior.chain.log_prob is not None:
        stats["lp"] = np.asarray(posterior.chain.log_prob[posterior.burn :: thin], dtype=float).T
    data = az.from_dict(
        posterior=draws,
        sample_stats=stats or None,
        attrs={
            "specimen": specimen,
            "sampler": str(posterior.run.get("optimizer", "")),
            "burn_in_steps": posterior.burn,
        },
    )
    data.posterior.attrs["units"] = str(units(posterior.problem, list(draws)))
    return data


def units(problem, names) -> dict:
    """The unit of each named parameter of a problem.

    Parameters
    ----------
    problem : object
        The problem the chain sampled.
    names : iterable of str
        Parameter names.

    Returns
    -------
    dict of str to str
        {name: unit}; "" for a name the problem does not know.
    """
    from bwbench.problems.hysteresis.report.posterior_draws import parameters

    table = parameters(problem)
    return {n: table.get(n, (n, ""))[1] for n in names}


def _check_thin(posterior, thin) -> int:
    """``thin``, or by default the step that keeps about ``DRAWS`` draws."""
    if thin is None:
        kept = (posterior.chain.steps - posterior.burn) * posterior.chain.walkers
        return max(1, -(-kept // DRAWS))
    if isinstance(thin, bool) or not isinstance(thin, int) or thin < 1:
        raise UserError(f"thin must be a positive integer, got {thin!r}")
    return thin
