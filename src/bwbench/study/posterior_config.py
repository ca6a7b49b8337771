"""The [posterior] table of a study: which specimens, which samplers (one or several, compared on the
same budget), their options on top of what converges without options, and the posterior runs each
formulation of the study gets."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from bwbench.problems.base import ProblemSetup, integer
from bwbench.study.config_checks import bounded, check_backend, resolve_backend_options

POSTERIOR_KEYS = ("specimens", "optimizer", "budget", "seeds", "options")


# What a [posterior] run of a backend gets before its own options: the settings that converge on the
# shipped specimens and on others of the same kind (docs/posterior.md), not the backend's
# defaults, which are a sampler used as an optimiser in the ranking (walkers uniform in the box, one
# ensemble, the whole budget spent).
POSTERIOR_OPTIONS = {
    "emcee": {
        "start": "optima",
        "moves": "de",
        "ensembles": 3,
        "n_walkers": None,
        "start_fraction": 0.05,
        "stop": "converged",
    },
    "nested": {},
}  # its defaults are the posterior's: runs of 200 live points, added until precise


DEFAULT_POSTERIOR_OPTIMIZER = "nested"
# Evaluations per specimen, all runs together, when [posterior] gives no budget: a cap (nested sampling's
# runs stop once they agree to the precision target). What the default specimen's posterior needs
# (docs/posterior.md): ~4 runs of 400 live points and the runs the precision then asks for.
DEFAULT_POSTERIOR_BUDGET = 6_000_000


@dataclass(frozen=True)
class PosteriorConfig:
    specimens: tuple  # of SpecimenEntry
    optimizer: str  # the first sampler
    budget: int
    seeds: int
    options: dict  # the first sampler's defaults updated with the configured options
    # every sampler with its resolved options, in the order given: several are compared on the same
    # specimens and budget (the report's "posterior samplers" section)
    samplers: tuple = ()

    @property
    def backends(self) -> tuple:
        """((backend, options), ...) of every sampler."""
        return self.samplers or ((self.optimizer, self.options),)


def posterior_variants(setup: ProblemSetup) -> list:
    """The variants (label, settings) a ``[posterior]`` samples: each model's last one (its last formulation
    listed: the identifiable one when both are), so a study comparing models has each model's evidence;
    ``[("", settings)]`` without variants."""
    variants = setup.variants or (("", setup.settings),)
    last: dict = {}
    for label, settings in variants:
        last[settings.get("model")] = (label, settings)
    return list(last.values())


def posterior_table(fail, table, setup: ProblemSetup) -> PosteriorConfig:
    if not isinstance(table, dict):
        fail("[posterior] must be a table")
    unknown = [k for k in table if k not in POSTERIOR_KEYS]
    if unknown:
        fail(f"[posterior] unknown key {unknown[0]!r} (known: {', '.join(POSTERIOR_KEYS)})")
    available = setup.available
    only = list(available) if len(available) == 1 else None
    if "specimens" not in table and only is None:
        fail("[posterior] specimens is required")
    names = table.get("specimens", only)
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        fail("[posterior] specimens must be a non-empty list of specimen names (file stems)")
    if only is not None and names != only:
        fail(f'[posterior] specimens: this study has one specimen, ["{only[0]}"] (or omit the key)')
    for stem in names:
        if stem not in available:
            fail(f"[posterior] specimens: no specimen {stem!r} in this study's data")
        if not Path(available[stem].path).exists():
            fail(f"[posterior] specimens: {stem}: {available[stem].path} does not exist")
    if len(set(names)) != len(names):
        fail("[posterior] specimens lists a specimen twice")
    samplers = _samplers(fail, table)
    _say_assumptions(samplers, table["budget"])
    return PosteriorConfig(
        specimens=tuple(available[stem] for stem in names),
        optimizer=samplers[0][0],
        budget=bounded(
            fail,
            "[posterior] budget",
            integer(fail, "[posterior] budget", table.get("budget", DEFAULT_POSTERIOR_BUDGET)),
            "BWBENCH_MAX_BUDGET",
        ),
        seeds=bounded(
            fail, "[posterior] seeds", integer(fail, "[posterior] seeds", table.get("seeds", 1)), "BWBENCH_MAX_SEEDS"
        ),
        options=samplers[0][1],
        samplers=samplers if len(samplers) > 1 else (),
    )


SAMPLER_FAMILIES = ("mcmc", "nested")  # the backends that draw from a posterior
# Below this many evaluations no built-in sampler draws enough for its convergence check: emcee's default
# ensemble (2·d + 2 walkers, up to 30) would take fewer steps than it has walkers, nested sampling's live
# points alone take 100 evaluations per run.
MIN_POSTERIOR_BUDGET = 1000


def _say_assumptions(samplers, budget) -> None:
    """A warning for a posterior that will run but cannot give what the report's posterior section
    shows: an optimiser in place of a sampler, or a budget below ``MIN_POSTERIOR_BUDGET``."""
    from bwbench.engine import registry
    from bwbench.notices import assume

    for name, _ in samplers:
        family = registry.get(name).family
        if family not in SAMPLER_FAMILIES:
            assume(
                f'[posterior] optimizer "{name}" is an optimiser ({family}), not a sampler: its runs are '
                "recorded, but they draw no posterior and the report has no posterior section for them "
                '(samplers: "emcee", "nested")'
            )
    if isinstance(budget, int) and not isinstance(budget, bool) and 0 < budget < MIN_POSTERIOR_BUDGET:
        assume(
            f"[posterior] budget = {budget}: below {MIN_POSTERIOR_BUDGET} evaluations no sampler draws enough "
            "for its convergence check (R̂, ESS); the report will say the posterior did not converge"
        )


def _samplers(fail, table: dict) -> tuple:
    """((backend, resolved options), ...) of ``[posterior] optimizer`` (a name or a list of names) and
    ``options`` (one sampler: its table; several: a table per sampler, by name)."""
    optimizer = table.get("optimizer", DEFAULT_POSTERIOR_OPTIMIZER)
    several = isinstance(optimizer, list)
    names = optimizer if several else [optimizer]
    if not names or not all(isinstance(n, str) for n in names):
        fail('[posterior] optimizer must be a backend name or a non-empty list of them, e.g. ["nested", "emcee"]')
    if len(set(names)) != len(names):
        fail("[posterior] optimizer names a backend twice")
    for name in names:
        check_backend(fail, "[posterior] optimizer", name)
    given = table.get("options", {})
    if not several:
        return (
            (
                names[0],
                resolve_backend_options(fail, "[posterior] options", names[0], _posterior_options(names[0], given)),
            ),
        )
    if not isinstance(given, dict) or not all(isinstance(v, dict) for v in given.values()):
        fail(
            "[posterior] options: with several samplers, one table per sampler, e.g. "
            "options = { emcee = { n_walkers = 32 } }"
        )
    unknown = [k for k in given if k not in names]
    if unknown:
        fail(f"[posterior] options: {unknown[0]!r} is not one of the samplers ({', '.join(names)})")
    return tuple(
        (
            name,
            resolve_backend_options(
                fail, f"[posterior] options {name}", name, _posterior_options(name, given.get(name, {}))
            ),
        )
        for name in names
    )


def _posterior_options(optimizer: str, given):
    """``given`` options on top of the backend's ``POSTERIOR_OPTIONS`` (left as given when they are not a
    table: ``resolve_backend_options`` says what is wrong)."""
    if not isinstance(given, dict):
        return given
    return {**POSTERIOR_OPTIONS.get(optimizer, {}), **given}
