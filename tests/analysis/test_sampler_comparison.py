"""Samplers compared like optimisers (the report's "Posterior samplers" table): on a two-mode toy of
masses 0.7/0.3, at the same budget, nested sampling finds both modes with their masses and the ensemble
sampler, started as the study's posterior starts it, settles in the 0.7 mode and misses the 0.3 one."""

import re
from types import SimpleNamespace

import numpy as np
import pytest

from bwbench.analysis import mcmc, posterior_verdict, sampler_comparison
from bwbench.engine import fitting
from bwbench.problems.hysteresis.report.posterior_draws import PosteriorChain
from bwbench.problems.hysteresis.report.samplers_section import comparison_table, groups
from bwbench.study.posterior_config import POSTERIOR_OPTIONS
from toy_posteriors import MixtureToy

BUDGET = 30_000
NAMES = ["p0", "p1"]


def posterior(label, result):
    """A ``PosteriorChain`` as the report reads a stored run of ``result``."""
    e = result.extras
    samples = e["chain"]
    chain = SimpleNamespace(
        samples=samples,
        log_prob=e["log_prob"],
        optimizer=label,
        specimen="toy",
        steps=samples.shape[0],
        walkers=samples.shape[1],
    )
    run = {"nfev": result.nfev, "wall_s": 12.5}
    if "log_z" in e:
        verdict = posterior_verdict.judge(samples, e["log_prob"], e["log_z"], e["log_z_err"], NAMES)
        whole = mcmc.Mode(tuple(range(chain.walkers)), np.arange(chain.walkers), 0.0)
        assessment = {"converged": verdict["converged"], "modes": [whole], "diagnostics": [verdict["diagnostics"]]}
        return PosteriorChain(chain, None, run, chain.walkers, assessment, NAMES, [], verdict)
    ensembles = POSTERIOR_OPTIONS["emcee"]["ensembles"]
    return PosteriorChain(chain, None, run, ensembles, mcmc.assess(samples, e["log_prob"], ensembles, NAMES), NAMES)


@pytest.fixture(scope="module")
def samplers():
    toy = MixtureToy([[0.3, 0.3], [0.7, 0.7]], 0.04, [0.7, 0.3])
    reference = fitting.run(toy, "nested", BUDGET, 1, {"live_points": 120, "min_ess": 60, "runs": 3})
    emcee = fitting.run(toy, "emcee", BUDGET, 1, dict(POSTERIOR_OPTIONS["emcee"]))
    return posterior("nested [toy]", reference), posterior("emcee [toy]", emcee)


def test_nested_finds_both_modes_and_emcee_misses_the_light_one(samplers):
    reference, emcee = samplers
    shares = sampler_comparison.mode_shares(
        reference.chain.samples, reference.nested, emcee.chain.samples[emcee.burn :].reshape(-1, 2)
    )
    assert shares.reference == pytest.approx([0.7, 0.3], abs=0.05)
    assert shares.shares[0] > 0.95 and shares.shares[1] < 0.01
    assert list(shares.found) == [True, False]
    own = sampler_comparison.mode_shares(
        reference.chain.samples, reference.nested, reference.chain.samples.reshape(-1, 2)
    )
    assert own.all_found and own.shares == pytest.approx(own.reference, abs=1e-9)


def test_the_table_says_which_sampler_misses_a_mode_with_masses_evaluations_and_time(samplers):
    reference, emcee = samplers
    ((key, by_backend),) = groups([emcee, reference]).items()
    assert key == ("toy", "toy") and set(by_backend) == {"nested", "emcee"}
    table = comparison_table(by_backend)
    assert list(table.columns) == [
        "sampler",
        "finds every mode",
        "mass in each mode",
        "R̂/ESS verdict",
        "evaluations",
        "wall time (s)",
    ]
    first, second = table.to_dict("records")
    assert first["sampler"] == "nested (reference)" and first["finds every mode"] == "yes (2 of 2)"
    assert first["R̂/ESS verdict"].startswith("converged")
    assert second["sampler"] == "emcee" and second["finds every mode"] == "no: misses mode 2 (1 of 2)"
    assert re.search(r"mode 2: 0\.00 \(reference 0\.(2[5-9]|3[0-5]) ± 0\.\d\d\)", second["mass in each mode"])
    assert second["evaluations"] == f"{BUDGET:,}" and int(first["evaluations"].replace(",", "")) <= BUDGET
    assert second["wall time (s)"] == "12.5"


def test_one_sampler_per_specimen_is_no_comparison(samplers):
    reference, _ = samplers
    assert groups([reference]) == {}


def test_an_emcee_posterior_that_misses_a_good_fit_is_never_called_converged(samplers, monkeypatch):
    """The ensemble sampler settles in the 0.7 mode and passes R̂; a good ranking fit at the 0.3 mode's peak,
    as probable as its draws, where none go, makes its verdict "not converged" with the reason."""
    import pandas as pd

    from bwbench.problems.hysteresis.report import posterior_draws

    _, emcee = samplers
    toy = MixtureToy([[0.3, 0.3], [0.7, 0.7]], 0.04, [0.7, 0.3])
    # as if its R̂ and ESS had passed (all its walkers sit in the 0.7 mode)
    passed = {**emcee.assessment, "converged": True, "why": []}
    pc = PosteriorChain(emcee.chain, toy, emcee.run, emcee.ensembles, passed, NAMES)
    assert pc.converged and pc.verdict_line.startswith("Posterior converged")
    fit = pd.DataFrame([{"optimizer": "lsq-trf", "replicate": 0, "mse": 1.0, "p0": 0.7, "p1": 0.7}])
    monkeypatch.setattr(posterior_draws, "good_fits", lambda study, specimen: fit)
    posterior_draws._best_fit_covered(None, pc)
    assert not pc.converged
    assert pc.verdict_line.startswith("Posterior not converged: the sampler missed a mode at least as probable as")
    assert "lsq-trf, seed 1" in pc.verdict_line
