"""A study's posterior from Python, in physical units.

``Study.posterior(specimen)`` gives a DataFrame of draws in physical units,
``Study.to_inference_data(specimen)`` an ArviZ ``InferenceData`` and
``Study.posterior_verdict(specimen)`` the verdict the report and the terminal show.

Read from the stored chains as the report reads them (``posterior_draws``): the sampled coordinates
mapped out of the unit box into physical units with the problem the chain sampled (in the
identifiable formulation: θ), the solved linear coefficients drawn from their conditional Gaussian
given each θ. Every result carries the verdict: ``converged`` and the reasons it failed, the same words
as the report's (``posterior_draws.PosteriorChain.verdict_line``). A parameter the posterior holds fixed
(the same value in every draw, e.g. a mass the problem does not fit) is left out of the draws and named
with its value in ``attrs["held"]``; the units are a dict (JSON text in a netCDF file's attributes).

A nested-sampling posterior: each run's draws are its weighted samples resampled, so a run cut by its
budget repeats its few heavy points; ``posterior`` gives each run's distinct points with their
``weight`` (the weights sum to 1 over all runs, each run 1/runs), which is what such a run holds. An
emcee posterior: ``walker``, ``step`` and the second half of every chain, equally weighted.
"""

from __future__ import annotations

import json

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


def _draws(posterior, thin: int) -> tuple[dict, dict]:
    """({name: (chains, kept draws) array in physical units}, {held name: value}).

    Every sampled and solved parameter after burn-in, every ``thin``-th draw; a parameter with one
    value in every draw is held.
    """
    chain, problem = posterior.chain, posterior.problem
    kept = chain.samples[posterior.burn :: thin]  # (steps, walkers, d), unit coordinates
    steps, walkers, d = kept.shape
    P = problem.from_unit(kept.reshape(-1, d))
    out = {n: P[:, j] for j, n in enumerate(posterior.names)}
    if getattr(problem, "formulation", "") == "identifiable":
        from bwbench.problems.hysteresis.report.posterior_draws import linear_draws

        out.update(linear_draws(problem, P, np.random.default_rng(SEED)))
    held = {}
    for name, values in list(out.items()):
        values = np.asarray(values, dtype=float)
        finite = values[np.isfinite(values)]
        if not finite.size or np.ptp(finite) == 0:
            held[name] = float(finite[0]) if finite.size else float("nan")
            del out[name]
    # (steps·walkers,) in step-major order → (walkers, steps): ArviZ's (chain, draw)
    return {n: np.asarray(v, dtype=float).reshape(steps, walkers).T for n, v in out.items()}, held


def _verdict_attrs(posterior) -> dict:
    out = {
        "converged": bool(posterior.converged),
        "reasons": list(posterior.reasons),
        "verdict": posterior.verdict_line,
    }
    ess = (posterior.chain.evidence or {}).get("run_ess") if posterior.nested is not None else None
    if ess:  # how many independent draws each run's weighted points are worth (a cut run: about 1)
        out["effective_draws"] = [float(e) for e in ess]
    return out


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
        One column per parameter in physical units (``Study.units`` of the problem); a nested-sampling
        posterior's distinct points per ``run`` with their ``weight``, an emcee posterior's ``walker``
        and ``step`` (after burn-in). ``attrs``: ``units`` (dict), ``held`` (dict), ``converged``,
        ``reasons``, ``verdict``, and for nested sampling ``effective_draws`` (each run's Kish
        effective sample size: a run cut by its budget is worth about one draw).

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
    draws, held = _draws(posterior, thin)
    walkers, steps = next(iter(draws.values())).shape if draws else (posterior.chain.walkers, 0)
    if posterior.nested is not None:
        out = _weighted(posterior, draws, thin)
    else:
        index = {
            "walker": np.repeat(np.arange(walkers), steps),
            "step": np.tile(posterior.burn + np.arange(steps) * thin, walkers),
        }
        out = pd.DataFrame({**index, **{n: v.ravel() for n, v in draws.items()}})
    out.attrs.update(units=units(posterior.problem, list(draws)), held=held, **_verdict_attrs(posterior))
    return out


def _weighted(posterior, draws: dict, thin: int):
    """Each run's distinct draws with their ``weight``.

    A point drawn k times is one row; ``weight`` = its share of the run's draws / runs. The linear
    coefficients of a repeated point are those of its first draw.
    """
    import pandas as pd

    kept = posterior.chain.samples[::thin]  # (n, runs, d)
    n, runs, _ = kept.shape
    frames = []
    for k in range(runs):
        _, first, counts = np.unique(kept[:, k], axis=0, return_index=True, return_counts=True)
        order = np.argsort(first)
        rows = first[order]
        frames.append(
            pd.DataFrame(
                {"run": k, "weight": counts[order] / (n * runs), **{name: v[k, rows] for name, v in draws.items()}}
            )
        )
    return pd.concat(frames, ignore_index=True)


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
        Chains = walkers (emcee) or runs (nested sampling: each run's equal-weight draws, a cut run's
        repeated points kept as they are), draws = kept steps; the log-likelihood under
        ``sample_stats.lp``; attrs: ``units`` and ``held`` (JSON text), ``converged`` (1 or 0),
        ``verdict``, ``reasons`` (JSON list).

    Raises
    ------
    bwbench.errors.UserError
        As ``frame``.

    Examples
    --------
    >>> inference_data(stored, "mytest").posterior.attrs["units"]
    """
    from bwbench.threads import settle_numba_environment

    settle_numba_environment()  # ArviZ compiles numba code at import
    import arviz as az

    posterior = chain_of(study, specimen)
    thin = _check_thin(posterior, thin)
    draws, held = _draws(posterior, thin)
    stats = {}
    if posterior.chain.log_prob is not None:
        stats["lp"] = np.asarray(posterior.chain.log_prob[posterior.burn :: thin], dtype=float).T
    verdict = _verdict_attrs(posterior)
    data = az.from_dict(
        posterior=draws,
        sample_stats=stats or None,
        attrs={
            "specimen": specimen,
            "sampler": str(posterior.run.get("optimizer", "")),
            "burn_in_steps": posterior.burn,
            "converged": int(verdict["converged"]),
            "verdict": verdict["verdict"],
            "reasons": json.dumps(verdict["reasons"], ensure_ascii=False),
            **({"effective_draws": verdict["effective_draws"]} if "effective_draws" in verdict else {}),
        },
    )
    data.posterior.attrs["units"] = json.dumps(units(posterior.problem, list(draws)), ensure_ascii=False)
    data.posterior.attrs["held"] = json.dumps(held, ensure_ascii=False)
    return data


def verdict(study, specimen: str):
    """The posterior's verdict, the report's and the terminal's.

    A nested-sampling posterior's ``posterior_verdict.Verdict`` (``converged``, ``reasons``, ``line``,
    ``checks``, ``precision``, ``regions``, ``badge``, ``needed``); an emcee posterior's
    converged/reasons/line as a dict.
    """
    posterior = chain_of(study, specimen)
    if posterior.nested is not None:
        return posterior.nested
    return {"converged": bool(posterior.converged), "reasons": list(posterior.reasons), "line": posterior.verdict_line}


def verdict_lines(study) -> list[str]:
    """One line per posterior of a stored study: '<specimen> (<sampler>): <verdict>'.

    What the terminal prints after a study, in the report's words.
    """
    from bwbench.problems.hysteresis.report.posterior_draws import posterior_chains

    try:
        chains = posterior_chains(study)
    except (UserError, ValueError, KeyError, OSError):
        return []
    return [f"{pc.chain.specimen} ({pc.chain.optimizer}): {pc.verdict_line}" for pc in chains]


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
