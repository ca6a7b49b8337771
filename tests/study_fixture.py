"""A small, realistic study database written without running any optimiser.

The schema is the contract of ``bwbench.database.writer`` (written out here on purpose, so the analysis
tests do not depend on the runner). The numbers are synthetic but consistent: every run's
parameters are drawn around the specimen's truth (closer for the "good" backends), and its MSE
is the model's real MSE at those parameters, so the fitted loops and the identifiability analysis
of a fixture run are those of a genuine fit.

    from study_fixture import make_study_db
    db = make_study_db(tmp_path / "study.sqlite")
"""

from __future__ import annotations

import json
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np

from bwbench.data import manifest as manifest_mod
from bwbench.data.specimen import read_specimen
from bwbench.datasets import synthetic
from bwbench.engine import registry
from bwbench.models.switched import parameters as switched_parameters
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.parameters import LOWER, UPPER
from paper_problems import SwitchedBoucWenProblem

DATA_DIR = synthetic.SPECIMEN_DIR
SPECIMENS = ("pom-mt24u01_0.01MPa_r1", "pom-mt24u01_0.09MPa_r1")
# Backend -> spread (standard deviation, unit coordinates) of its final points around the truth.
OPTIMIZERS = {"cmaes": 0.004, "de": 0.03, "random": 0.15}
REPLICATES = 4
BUDGET = 400

_KEY = "kind TEXT, specimen TEXT, optimizer TEXT, replicate INTEGER"
_PK = "PRIMARY KEY (kind, specimen, optimizer, replicate)"
SCHEMA = f"""
CREATE TABLE study (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE runs (
    {_KEY}, seed_entropy TEXT, status TEXT, error TEXT, budget INTEGER, nfev INTEGER,
    mse REAL, f_err REAL, rmse_N REAL, success INTEGER, message TEXT, state TEXT, excitation TEXT,
    options_json TEXT,
    problem TEXT, params_json TEXT, metrics_json TEXT, model TEXT, formulation TEXT, variant TEXT, meta_json TEXT,
    {_PK});
CREATE TABLE timings ({_KEY}, wall_s REAL, worker TEXT, finished_utc TEXT, {_PK});
CREATE TABLE traces ({_KEY}, nfev INTEGER, mse REAL);
CREATE TABLE chains ({_KEY}, steps INTEGER, walkers INTEGER, dim INTEGER, chain BLOB, log_prob BLOB,
    acceptance_fraction REAL, autocorr_json TEXT, {_PK});
CREATE TABLE evidence ({_KEY}, evidence_json TEXT, {_PK});
"""
RUN_COLUMNS = (
    "kind",
    "specimen",
    "optimizer",
    "replicate",
    "seed_entropy",
    "status",
    "error",
    "budget",
    "nfev",
    "mse",
    "f_err",
    "rmse_N",
    "success",
    "message",
    "state",
    "excitation",
    "options_json",
    "problem",
    "params_json",
    "metrics_json",
    "model",
    "formulation",
    "variant",
    "meta_json",
)


def _trace(rng, final_mse: float, nfev: int, reach_fraction: float) -> list[tuple[int, float]]:
    """Best-so-far improvements: geometric decrease from ~1e4·final to ``final_mse``, reached
    after about ``reach_fraction``·nfev evaluations."""
    reach = max(2, int(round(reach_fraction * nfev)))
    steps = np.unique(np.round(np.geomspace(1, reach, 14)).astype(int))
    start = final_mse * 10 ** rng.uniform(3.0, 4.5)
    values = np.geomspace(start, final_mse, steps.size)
    values[-1] = final_mse
    return [(int(n), float(m)) for n, m in zip(steps, values)]


def _chain(rng, u_center, steps: int, walkers: int):
    """AR(1) walkers around ``u_center`` with one strongly correlated pair (ωn₋, α₋), so the
    autocorrelation time is finite and a correlation shows up in the posterior plot."""
    dim = u_center.size
    scale = np.full(dim, 0.01)
    phi = 0.9
    chain = np.empty((steps, walkers, dim))
    x = rng.normal(0.0, 1.0, (walkers, dim))
    for s in range(steps):
        x = phi * x + np.sqrt(1 - phi**2) * rng.normal(0.0, 1.0, (walkers, dim))
        y = x.copy()
        i, j = PARAM_NAMES.index("wn-"), PARAM_NAMES.index("alpha-")
        y[:, j] = 0.95 * x[:, i] + np.sqrt(1 - 0.95**2) * x[:, j]
        chain[s] = np.clip(u_center + scale * y, 0.0, 1.0)
    log_prob = -0.5 * np.sum(((chain - u_center) / scale) ** 2, axis=2)
    return chain, log_prob


def make_study_db(
    path,
    specimens=SPECIMENS,
    optimizers=OPTIMIZERS,
    replicates: int = REPLICATES,
    budget: int = BUDGET,
    *,
    miss: tuple | None = None,
    error: tuple | None = None,
    posterior: bool = True,
    chain_steps: int = 300,
    chain_walkers: int = 30,
    seed: int = 7,
) -> Path:
    """Write a study database at ``path`` and return the path.

    ``miss`` = (specimen, optimizer, replicate): that ranking run ends far from the best (1e3× the
    MSE of its draw), so it misses every target. ``error`` = the same key for a run that raised.
    ``posterior``: one emcee run (chain of ``chain_steps`` × ``chain_walkers``) on the first specimen.
    """
    path = Path(path)
    rng = np.random.default_rng(seed)
    manifest = {e["file"]: e for e in json.loads((DATA_DIR / manifest_mod.MANIFEST).read_text())["specimens"]}
    config = {
        "study": {
            "name": "fixture",
            "seed": seed,
            "budget": budget,
            "seeds": replicates,
            "state": "shared",
            "excitation": "measured",
            "data": "data/specimens",
        },
        "specimens": {"filters": {}, "files": list(specimens)},
        "optimizers": {name: {"fixture_spread": spread} for name, spread in optimizers.items()},
        "posterior": (
            {
                "specimens": [specimens[0]],
                "optimizer": "emcee",
                "budget": chain_steps * chain_walkers,
                "seeds": 1,
                "options": {"n_walkers": chain_walkers, "n_data": None},
            }
            if posterior
            else None
        ),
    }
    runs, timings, traces, chains = [], [], [], []

    def add_run(kind, specimen, optimizer, replicate, params, mse, nfev, trace, options, status="ok"):
        entry = manifest[f"{specimen}.csv"]
        row = dict.fromkeys(RUN_COLUMNS)
        row.update(
            kind=kind,
            specimen=specimen,
            optimizer=optimizer,
            replicate=replicate,
            seed_entropy=str(seed),
            status=status,
            budget=budget if kind == "ranking" else nfev,
            state="shared",
            excitation="measured",
            meta_json=json.dumps({k: entry[k] for k in ("material", "underpressure_MPa", "repeat")}, sort_keys=True),
            options_json=json.dumps(options, sort_keys=True),
            success=0,
            problem="switched-bouc-wen",
            model="switched-bouc-wen",
            formulation="paper",
        )
        if status == "ok":
            row.update(
                nfev=nfev,
                mse=mse,
                f_err=-mse,
                rmse_N=float(np.sqrt(mse)),
                success=1,
                message="budget exhausted",
                params_json=json.dumps(dict(zip(PARAM_NAMES, map(float, params))), sort_keys=True),
                metrics_json="{}",
            )
        else:
            row.update(error="FloatingPointError: fixture failure")
        key = (kind, specimen, optimizer, replicate)
        runs.append(tuple(row[c] for c in RUN_COLUMNS))
        timings.append((*key, float(rng.uniform(0.5, 2.0)), "fixture:1", "2024-01-01T00:00:00Z"))
        traces.extend((*key, n, m) for n, m in trace)

    for specimen in specimens:
        problem = SwitchedBoucWenProblem(read_specimen(DATA_DIR / f"{specimen}.csv"))
        u_truth = problem.to_unit(switched_parameters.truth_params(DATA_DIR / f"{specimen}.csv"))
        for replicate in range(replicates):
            for optimizer, spread in optimizers.items():
                key = (specimen, optimizer, replicate)
                if error == key:
                    add_run("ranking", specimen, optimizer, replicate, None, None, None, [], {}, status="error")
                    continue
                while True:  # a real best-so-far is finite: redraw a blown-up point
                    u = np.clip(u_truth + rng.normal(0.0, spread, u_truth.size), 0.0, 1.0)
                    params = problem.from_unit(u)
                    mse = float(problem.loss_batch(params[None, :])[0])
                    if np.isfinite(mse):
                        break
                if miss == key:
                    mse *= 1e3
                reach = min(0.95, 0.4 + 4.0 * spread)  # tighter backends get there sooner
                trace = _trace(rng, mse, budget, reach)
                add_run(
                    "ranking", specimen, optimizer, replicate, params, mse, budget, trace, {"fixture_spread": spread}
                )
        if posterior and specimen == specimens[0]:
            chain, log_prob = _chain(rng, u_truth, chain_steps, chain_walkers)
            best = chain.reshape(-1, u_truth.size)[np.argmax(log_prob)]
            params = LOWER + best * (UPPER - LOWER)
            mse = float(problem.loss_batch(params[None, :])[0])
            nfev = chain_steps * chain_walkers
            add_run(
                "posterior",
                specimen,
                "emcee",
                0,
                params,
                mse,
                nfev,
                _trace(rng, mse, nfev, 0.7),
                config["posterior"]["options"],
            )
            import emcee

            tau = emcee.autocorr.integrated_time(chain, quiet=True, tol=0)
            chains.append(
                (
                    "posterior",
                    specimen,
                    "emcee",
                    0,
                    chain_steps,
                    chain_walkers,
                    u_truth.size,
                    chain.tobytes(),
                    log_prob.tobytes(),
                    0.31,
                    json.dumps([float(t) for t in tau]),
                )
            )

    if path.exists():
        path.unlink()
    known = registry.available()  # the fixture's names that are real backends (a test may invent others)
    with closing(sqlite3.connect(path)) as conn:
        conn.executescript(SCHEMA)
        conn.executemany(
            "INSERT INTO study VALUES (?, ?)",
            [
                ("name", "fixture"),
                ("config_json", json.dumps(config, sort_keys=True)),
                ("config_hash", "0" * 64),
                ("created_utc", "2024-01-01T00:00:00Z"),
                ("bwbench_version", "fixture"),
                # as the runner records them (bwbench.database.writer.backend_facts); the fixture's backends are real ones
                (
                    "backends",
                    json.dumps(
                        {
                            name: {"family": known[name].family, "batched": known[name].batched}
                            for name in [*optimizers, "emcee"]
                            if name in known
                        },
                        sort_keys=True,
                    ),
                ),
            ],
        )
        conn.executemany(f"INSERT INTO runs VALUES ({', '.join('?' * len(RUN_COLUMNS))})", runs)
        conn.executemany("INSERT INTO timings VALUES (?, ?, ?, ?, ?, ?, ?)", timings)
        conn.executemany("INSERT INTO traces VALUES (?, ?, ?, ?, ?, ?)", traces)
        conn.executemany("INSERT INTO chains VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", chains)
        conn.commit()
    return path
