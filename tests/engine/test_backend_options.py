"""Typed backend options: declarations, one resolution for `bwbench fit` and study TOMLs, refusals as
one line, and — over the whole registry — a run at every edge of every declared range ends."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from bwbench import testing
from bwbench.cli import main
from bwbench.engine import fitting, registry
from bwbench.engine.options import Bool, Choice, Float, FloatOrPair, Int, OptionError
from bwbench.errors import UserError
from bwbench.study.config import load_study_config

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN = ROOT / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
DATA = ROOT / "data" / "specimens"
# How long a CLI call may take before it counts as hung: a hang detector, not a speed limit (each
# call below is refused before any evaluation, in well under a second).
HANG_AFTER_S = 60.0

# The inputs that gave a traceback or never ended before options were typed, and what is said now.
REFUSED = [
    ("paper-ga", "population=abc", "paper-ga: option population must be an integer in [2, 100000], got 'abc'"),
    ("paper-ga", "population=0", "paper-ga: option population must be an integer in [2, 100000], got 0"),
    ("de", "strategy=foo", "de: option strategy must be one of 'best1bin', "),
    ("nlopt-bobyqa", "xtol_rel=abc", "nlopt-bobyqa: option xtol_rel must be a number ≥ 0, got 'abc'"),
    ("emcee", "n_walkers=3", "emcee: option n_walkers must be at least 2·d = 28 on this 14-parameter problem"),
    ("firefly", "alpha_decay=-2", "firefly: option alpha_decay must be a number in (0, 1], got -2"),
    ("cmaes", "sigma0=0", "cmaes: option sigma0 must be a number in [1e-11, 1], got 0"),
    ("random", "batch_size=0", "random: option batch_size must be an integer in [1, 100000], got 0"),  # hung
    ("anneal", "maxiter=0", "anneal: option maxiter must be an integer ≥ 1, got 0"),  # hung
]


# ---------------------------------------------------------------------------------------- declarations
def test_int_takes_integers_in_range_and_not_bools_or_floats():
    population = Int(100, minimum=2, maximum=1000)
    assert population.validate(7, "x") == 7 and population.validate(np.int64(7), "x") == 7
    for bad in (1, 1001, True, 2.0, 2.5, "7", None, [3]):
        with pytest.raises(OptionError):
            population.validate(bad, "x")
    with pytest.raises(UserError, match=r"^ga: option population must be an integer in \[2, 1000\], got 'abc'$"):
        population.validate("abc", "ga: option population")
    assert population.describe() == "int in [2, 1000], default 100"
    assert Int(40, minimum=0).describe() == "int ≥ 0, default 40"


def test_float_takes_ints_kept_as_ints_and_refuses_bools_nan_and_infinity():
    sigma = Float(0.3, minimum=0.0, maximum=1.0, exclusive_minimum=True)
    assert sigma.validate(1, "x") == 1 and type(sigma.validate(1, "x")) is int  # a stored study keeps its hash
    assert sigma.validate(np.float64(0.5), "x") == 0.5
    for bad in (0, 0.0, 1.5, True, float("nan"), float("inf"), "0.5", None):
        with pytest.raises(OptionError):
            sigma.validate(bad, "x")
    with pytest.raises(OptionError):  # JSON ints are unbounded; as a double this one is inf
        Float(0.01, minimum=0.0).validate(10**400, "x")
    with pytest.raises(OptionError, match=r"must be a number in \(0, 1\], got NaN$"):
        sigma.validate(float("nan"), "x")
    assert sigma.describe() == "float in (0, 1], default 0.3"
    assert Float(0.01, minimum=0.0).describe() == "float ≥ 0, default 0.01"
    assert Float(0.7, minimum=0.0, maximum=1.0, exclusive_maximum=True).expected() == "a number in [0, 1)"


def test_choice_bool_and_none():
    strategy = Choice("a", ("a", "b"))
    assert strategy.validate("b", "x") == "b" and strategy.edges() == ["a", "b"]
    with pytest.raises(OptionError, match=r"must be one of 'a', 'b', got 'c'$"):
        strategy.validate("c", "x")
    switch = Bool(False)
    assert switch.validate(True, "x") is True and switch.edges() == [False, True]
    for bad in (0, 1, "true", None):
        with pytest.raises(OptionError, match="must be true or false"):
            switch.validate(bad, "x")
    walkers = Int(None, minimum=2, none="2·d + 2")
    assert walkers.validate(None, "x") is None and walkers.default is None and None in walkers.edges()
    assert walkers.describe() == "int ≥ 2 or null (2·d + 2), default null"
    with pytest.raises(OptionError, match=r"must be an integer ≥ 2 \(or null: 2·d \+ 2\), got 1$"):
        walkers.validate(1, "x")
    with pytest.raises(OptionError):
        Int(3, minimum=2).validate(None, "x")  # None only where declared


def test_float_or_pair_takes_a_number_or_an_ordered_pair_in_range():
    mutation = FloatOrPair((0.5, 1.0), minimum=0.0, maximum=2.0, exclusive_maximum=True)
    assert mutation.default == [0.5, 1.0]  # normalised to a list, as JSON and TOML give a pair
    assert mutation.validate(0.7, "x") == 0.7 and mutation.validate((0, 1.5), "x") == [0, 1.5]
    for bad in (2, -0.1, [1.0, 0.5], [0.5, 2.0], [0.5], [0.1, 0.2, 0.3], ["a", 1], True, "0.5"):
        with pytest.raises(OptionError):
            mutation.validate(bad, "x")
    assert mutation.describe() == "float or pair [lo, hi] with lo ≤ hi, each in [0, 2), default [0.5, 1.0]"


def test_a_declared_default_outside_its_range_fails_at_declaration():
    with pytest.raises(ValueError, match="the declared default must be an integer ≥ 2, got 1"):
        Int(1, minimum=2)


def test_edges_are_valid_values_at_the_bounds_and_just_inside():
    assert Int(5, minimum=1, maximum=100).edges() == [1, 2, 99, 100, 5]
    assert Float(0.97, minimum=0.0, maximum=1.0, exclusive_minimum=True).edges() == [1e-6, 1.0, 0.999999, 0.97]
    for declaration in (
        Int(40, minimum=0),
        Float(1.0, minimum=0.0),
        Int(None, minimum=2, none="x"),
        FloatOrPair((0.5, 1.0), minimum=0.0, maximum=2.0, exclusive_maximum=True),
    ):
        for value in declaration.edges():
            assert declaration.validate(value, "x") == value


# ---------------------------------------------------------------------------------------- registry
def test_every_builtin_backend_declares_typed_options_and_its_defaults_derive_from_them():
    for name, backend in registry.available().items():
        if name.startswith("example-"):  # an installed plugin is not ours to judge here
            continue
        assert backend.options, f"{name} declares no typed options"
        assert backend.defaults == {k: d.default for k, d in backend.options.items()}
        assert registry.resolve_options(name) == backend.defaults


def test_resolve_options_merges_defaults_and_refuses_unknown_names_listing_the_known():
    assert registry.resolve_options("paper-ga", {"generations": 3}) == {
        "population": 100,
        "generations": 3,
        "p_mutation": 0.5,
        "p_crossover": 0.5,
    }
    with pytest.raises(
        UserError,
        match=r"^paper-ga: unknown option\(s\) colour, size; it takes population, "
        r"generations, p_mutation, p_crossover$",
    ):
        registry.resolve_options("paper-ga", {"size": 3, "colour": 1})
    with pytest.raises(UserError, match=r"^\[here\] cmaes: option sigma0 must be a number in \[1e-11, 1\], got -1$"):
        registry.resolve_options("cmaes", {"sigma0": -1}, label="[here] cmaes")


def test_register_refuses_both_contracts_at_once_and_undeclared_options():
    with pytest.raises(ValueError, match="not both"):
        registry.register("test-both", family="t", description="t", options={"a": Int(1)}, defaults={"a": 1})
    with pytest.raises(TypeError, match="option 'a' must be declared"):
        registry.register("test-plain", family="t", description="t", options={"a": 1})


def test_a_plugin_on_the_untyped_contract_still_works(monkeypatch, capsys):
    """``defaults=`` (no types): unknown names are refused, values reach the backend unchecked."""
    seen = {}

    def minimize(objective, *, rng, step=0.25):
        seen["step"] = step
        objective.batch(rng.random((objective.remaining, objective.dim)))

    # a copy of the registry (built-ins loaded), so the test entry is gone afterwards
    monkeypatch.setattr(registry.REGISTRY, "items", dict(registry.available()))
    registry.register(
        "test-untyped", family="plugin", description="old contract", defaults={"step": 0.25}, batched=False
    )(minimize)
    assert registry.get("test-untyped").options == {}
    assert registry.resolve_options("test-untyped", {"step": "anything"}) == {"step": "anything"}
    with pytest.raises(UserError, match=r"test-untyped: unknown option\(s\) stp; it takes step"):
        registry.resolve_options("test-untyped", {"stp": 1})
    result = fitting.run(testing.SphereProblem(), "test-untyped", 30, seed=1, options={"step": 0.5})
    assert seen == {"step": 0.5} and result.nfev == 30
    assert main(["optimizers"]) == 0
    assert "    step  untyped, default 0.25" in capsys.readouterr().out.splitlines()


# ---------------------------------------------------------------------------------------- listing
def test_optimizers_lists_every_option_with_type_range_and_default(capsys):
    assert main(["optimizers"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for name, backend in registry.available().items():
        at = next(i for i, line in enumerate(lines) if line.startswith(name + " "))
        assert "per call" in lines[at]
        listed = [line.split(None, 1) for line in lines[at + 1 : at + 1 + len(backend.options)]]
        assert [(key, d.describe()) for key, d in backend.options.items()] == [tuple(x) for x in listed]
    assert "    population   int in [2, 100000], default 100" in lines


# ---------------------------------------------------------------------------------------- refusals
def run_cli(argv, capsys):
    """``bwbench argv`` in this process -> (exit status, stdout, stderr); a thread only as a hang detector."""
    outcome = {}
    thread = threading.Thread(target=lambda: outcome.update(code=main(argv)), daemon=True)
    thread.start()
    thread.join(HANG_AFTER_S)
    assert not thread.is_alive(), f"bwbench {' '.join(argv)}: still running (hang detector, not a speed limit)"
    captured = capsys.readouterr()
    return outcome.get("code"), captured.out, captured.err


@pytest.mark.parametrize("optimizer, option, message", REFUSED, ids=[f"{o} {v}" for o, v, _ in REFUSED])
def test_fit_refuses_a_bad_option_in_one_line(optimizer, option, message, capsys, tmp_path):
    out = tmp_path / "r.json"
    code, _, err = run_cli(
        ["fit", str(SPECIMEN), "--optimizer", optimizer, "--budget", "300", "--out", str(out), "--option", option],
        capsys,
    )
    assert code == 2 and err.startswith(f"error: {message}") and err.count("\n") == 1, err
    assert not out.exists()


def test_fit_refuses_a_negative_seed_in_one_line(capsys, tmp_path):
    code, _, err = run_cli(
        [
            "fit",
            str(SPECIMEN),
            "--optimizer",
            "random",
            "--budget",
            "300",
            "--out",
            str(tmp_path / "r.json"),
            "--seed",
            "-1",
        ],
        capsys,
    )
    assert (code, err) == (2, "error: --seed must be a non-negative integer, got -1\n")
    with pytest.raises(UserError, match="seed must be a non-negative integer, got -1"):
        fitting.run(testing.SphereProblem(), "random", 10, seed=-1)


def test_a_refusal_is_one_line_and_no_traceback_in_a_real_process(tmp_path):
    fit = subprocess.run(
        [
            sys.executable,
            "-m",
            "bwbench.cli",
            "fit",
            str(SPECIMEN),
            "--optimizer",
            "paper-ga",
            "--budget",
            "300",
            "--out",
            str(tmp_path / "r.json"),
            "--option",
            "population=abc",
        ],
        capture_output=True,
        text=True,
        timeout=HANG_AFTER_S,
    )  # timeout: a hang detector
    assert fit.returncode == 2 and fit.stdout == ""
    assert fit.stderr == ("error: paper-ga: option population must be an integer in [2, 100000], got 'abc'\n")


def study_toml(path: Path, optimizers: str, extra: str = "") -> Path:
    path.write_text(
        f"""
[study]
name = "options"
seed = 1
budget = 10
seeds = 1
data = "{DATA.as_posix()}"

[specimens]
material = ["POM MT24u01"]
underpressure_MPa = [0.01]
repeat = [1]

[optimizers]
{optimizers}
{extra}
""",
        encoding="utf-8",
    )
    return path


TOML_REFUSED = [
    ("paper-ga", "population = 'abc'", "option population must be an integer in [2, 100000], got 'abc'"),
    ("paper-ga", "population = 0", "option population must be an integer in [2, 100000], got 0"),
    ("paper-ga", "population = 100.0", "option population must be an integer in [2, 100000], got 100.0"),
    ("de", "strategy = 'foo'", "option strategy must be one of 'best1bin', "),
    ("nlopt-bobyqa", "xtol_rel = 'abc'", "option xtol_rel must be a number ≥ 0, got 'abc'"),
    ("emcee", "n_walkers = 1", "option n_walkers must be an integer in [2, 10000] (or null: 2·d + 2), got 1"),
    ("firefly", "alpha_decay = -2", "option alpha_decay must be a number in (0, 1], got -2"),
    ("cmaes", "sigma0 = 0", "option sigma0 must be a number in [1e-11, 1], got 0"),
    ("random", "batch_size = 0", "option batch_size must be an integer in [1, 100000], got 0"),
    ("anneal", "maxiter = 0", "option maxiter must be an integer ≥ 1, got 0"),
    ("anneal", "no_local_search = 1", "option no_local_search must be true or false, got 1"),
    ("pso", "w = nan", "option w must be a number in [0, 1), got NaN"),
    ("random", "colour = 3", "unknown option(s) colour; it takes batch_size"),
]


@pytest.mark.parametrize("optimizer, assignment, message", TOML_REFUSED, ids=[f"{o} {a}" for o, a, _ in TOML_REFUSED])
def test_a_study_toml_refuses_a_bad_option_naming_file_table_and_backend(optimizer, assignment, message, tmp_path):
    other = "pso" if optimizer == "random" else "random"  # a well-configured backend first
    path = study_toml(tmp_path / "x.toml", f"{other} = {{}}\n{optimizer} = {{ {assignment} }}")
    with pytest.raises(UserError) as err:
        load_study_config(path)
    assert str(err.value).startswith(f"{path}: [optimizers] {optimizer}: {message}"), str(err.value)
    assert "\n" not in str(err.value)


def test_a_study_toml_refuses_a_bad_posterior_option(tmp_path):
    path = study_toml(
        tmp_path / "p.toml",
        "random = {}",
        extra="""
[posterior]
specimens = ["pom-mt24u01_0.01MPa_r1"]
optimizer = "emcee"
budget = 50
options = { n_walkers = 1 }
""",
    )
    with pytest.raises(UserError, match=r"p\.toml: \[posterior\] options: option n_walkers must be an integer"):
        load_study_config(path)


def test_a_study_stores_normalised_options_and_the_defaults_unchanged(tmp_path):
    config = load_study_config(study_toml(tmp_path / "ok.toml", "de = { mutation = [0.2, 0.4], tol = 1 }\ncmaes = {}"))
    assert config.optimizers["de"]["mutation"] == [0.2, 0.4] and config.optimizers["de"]["tol"] == 1
    assert config.optimizers["cmaes"] == {"sigma0": 0.3, "popsize": None}


def test_walkers_below_twice_the_dimension_are_refused_by_the_run_in_one_line(tmp_path):
    """n_walkers ≥ 2·d depends on the problem: a study TOML cannot refuse it, each run does, at once."""
    from bwbench.study.tasks import plan_tasks, run_task

    config = load_study_config(study_toml(tmp_path / "w.toml", "emcee = { n_walkers = 3 }"))
    row = run_task(plan_tasks(config)[0])["row"]
    assert row["status"] == "error" and row["nfev"] is None
    assert row["error"] == (
        "OptionError: emcee: option n_walkers must be at least 2·d = 28 on this "
        "14-parameter problem (emcee's stretch move), got 3"
    )
    # where 2·d allows it, the smallest declared value runs
    assert fitting.run(testing.SphereProblem(dim=1), "emcee", 50, seed=1, options={"n_walkers": 2}).nfev == 50


# ---------------------------------------------------------------------------------------- no loop without budget
CASES = [
    (name, option, value)
    for name in sorted(registry.available())
    if not name.startswith("example-")
    for option, value in testing.option_edge_cases(name)
]


@pytest.mark.parametrize("name, option, value", CASES, ids=[f"{n}-{o}={v!r}" for n, o, v in CASES])
def test_a_run_at_every_edge_of_every_declared_option_ends(name, option, value):
    testing.check_option_ends(name, option, value)


def test_a_restart_that_evaluates_nothing_ends_the_run(monkeypatch):
    """The libraries are replaced by ones that return at once: the restart loops stop, they do not spin."""
    import scipy.optimize  # the backends import from it when they run

    monkeypatch.setattr(scipy.optimize, "dual_annealing", lambda *args, **kwargs: None)
    monkeypatch.setattr(scipy.optimize, "differential_evolution", lambda *args, **kwargs: None)
    for name in ("anneal", "de"):
        result = fitting.run(testing.SphereProblem(), name, 100, seed=1)
        assert result.nfev == 0 and "evaluated nothing" in result.message


def test_a_cma_restart_that_stops_at_once_ends_the_run(monkeypatch):
    import cma

    class StopsAtOnce:
        def __init__(self, *args, **kwargs):
            pass

        def stop(self):
            return {"tolx": 1e-11}

    monkeypatch.setattr(cma, "CMAEvolutionStrategy", StopsAtOnce)
    result = fitting.run(testing.SphereProblem(), "cmaes", 100, seed=1)
    assert result.nfev == 0 and result.message == "cma stopped before asking for points (tolx); stopped"


def test_a_runaway_swarm_ends_the_run(monkeypatch):
    """pyswarms reflects one box width per pass: a particle far out would loop without spending budget."""
    from bwbench.optimizers import pso

    monkeypatch.setattr(pso, "_DIVERGED", 3.0)  # reached quickly by an unstable swarm
    result = fitting.run(testing.SphereProblem(), "pso", 100_000, seed=1, options={"w": 0.99, "c1": 4.0, "c2": 4.0})
    assert 0 < result.nfev < 100_000 and result.message.startswith("the swarm ran away")
