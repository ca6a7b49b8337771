"""The report's posterior section on a nested-sampling posterior: the convergence table across runs,
the verdict, the modes with their masses, where the best ranking fit lies, the evidence table and the
draws as an ArviZ InferenceData beside the report. The posterior is written into a fixture study
(two modes of masses 0.7 and 0.3 around the specimen's truth, four runs), so no sampler runs here."""

import json
import re
import sqlite3

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.database import reader as results_db
from bwbench.problems.hysteresis.report.posterior_draws import log_posterior, posterior_chains
from paper_problems import SwitchedBoucWenProblem
from study_fixture import DATA_DIR, SPECIMENS, make_study_db

RUNS, DRAWS = 4, 400


def nested_posterior(db, rng):
    """Replace the fixture's emcee posterior by four runs' equal-weight draws: 70 % around the truth,
    30 % with the first parameter moved by 0.2 of its box."""
    problem = SwitchedBoucWenProblem(read_specimen(DATA_DIR / f"{SPECIMENS[0]}.csv"))
    with sqlite3.connect(db) as conn:
        blob = conn.execute("SELECT chain, steps, walkers, dim FROM chains").fetchone()
        emcee = np.frombuffer(blob[0]).reshape(blob[1], blob[2], blob[3])
        centre = np.median(emcee.reshape(-1, blob[3]), axis=0)
        draws = centre + 0.002 * rng.standard_normal((DRAWS, RUNS, blob[3]))
        second = rng.random((DRAWS, RUNS)) < 0.3
        draws[second, 0] = np.clip(draws[second, 0] + 0.2, 0, 1)
        draws = np.clip(draws, 0, 1)
        lp = log_posterior(problem, problem.from_unit(draws.reshape(-1, blob[3]))).reshape(DRAWS, RUNS)
        evidence = {
            "log_z": [-10.02, -9.95, -10.06, -9.98],
            "log_z_err": [0.1] * RUNS,
            "run_nfev": [5000] * RUNS,
            "run_complete": [True] * RUNS,
            "live_points": 400,
        }
        for table in ("runs", "timings", "traces", "chains"):
            conn.execute(f"UPDATE {table} SET optimizer = 'nested' WHERE kind = 'posterior'")
        conn.execute(
            "UPDATE chains SET steps = ?, walkers = ?, chain = ?, log_prob = ?",
            (DRAWS, RUNS, draws.tobytes(), lp.tobytes()),
        )
        conn.execute(
            "INSERT INTO evidence VALUES ('posterior', ?, 'nested', 0, ?)", (SPECIMENS[0], json.dumps(evidence))
        )
    return draws


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    db = make_study_db(tmp_path_factory.mktemp("db") / "study.sqlite")
    nested_posterior(db, np.random.default_rng(5))
    return db


def test_a_nested_posterior_is_read_with_its_runs_modes_and_evidence(study):
    (pc,) = posterior_chains(results_db.load_study(study))
    assert pc.burn == 0 and pc.chain.walkers == RUNS and pc.chain.evidence["live_points"] == 400
    v = pc.nested
    assert [round(m.mass, 2) for m in v["modes"]] == pytest.approx([0.7, 0.3], abs=0.05)
    assert v["evidence"]["log_z"] == pytest.approx(-10.0, abs=0.05) and v["evidence"]["agree"]
    assert v["best_fit_place"]["where"] in ("mode", "below")  # the fixture's cmaes fits sit at the truth
    assert len(pc.unit_draws()) == RUNS * DRAWS // -(-RUNS * DRAWS // 1000)  # the whole posterior, thinned


def test_the_report_shows_runs_modes_masses_evidence_and_writes_the_draws(study, tmp_path):
    from bwbench.report import build as report

    out = tmp_path / "report"
    report.build_report(study, out, profile_params=1, profile_grid=2)
    md = (out / "report.md").read_text(encoding="utf-8")
    part = md.split("## Posterior sampling")[1]
    # the verdict first, in the words the API and the terminal use, then what it rests on
    subsection = part.split("### ")[1]
    (pc,) = posterior_chains(results_db.load_study(study))
    first = next(line for line in subsection.splitlines()[1:] if line.strip())
    assert pc.verdict_line in first
    assert "| check | result | detail |" in subsection and "| ln Z agree | pass |" in subsection
    assert "| parameter | pooled mean | 5 % | 95 % | runs' means | within target |" in subsection
    assert "| region | pooled mass | runs' masses | spread |" in subsection
    assert "| parameter | R̂ | bulk ESS |" in part
    assert "Nested sampling (UltraNest)" in part and "uniform on the search box" in part
    assert "| mode | mass | best log-likelihood |" in part
    masses = [float(m) for m in re.findall(r"^\| \d \| (0\.\d+) ± 0\.\d+ \|", part, flags=re.M)]
    assert masses == pytest.approx([0.7, 0.3], abs=0.05)
    assert "| model | ln Z | ± |" in part and "-10.0" in part
    assert "The best ranking fit lies" in part
    assert "| fit | MSE | log-likelihood | where |" in part and re.search(
        r"\| cmaes, seed \d \| .* \| (mode 1|below)", part
    )
    nc = next(out.glob("posterior_*.nc"))
    import arviz as az

    data = az.from_netcdf(nc)
    assert data.posterior.sizes["chain"] == RUNS and data.posterior.sizes["draw"] == DRAWS
    # physical units: the fixture's first parameter read back as the problem maps it
    assert float(data.posterior[next(iter(data.posterior.data_vars))].std()) > 0
