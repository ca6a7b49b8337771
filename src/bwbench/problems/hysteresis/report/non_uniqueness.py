"""How non-unique are the fitted parameters, and why: the spread of the good fits across seeds in the
paper's coordinates and in the identifiable ones, and how much of the first is the exact symmetry.

The paper's 14 parameters have an exact symmetry (z → s·z; ``identifiable.scale_paper``): every fit
lies on a curve of parameter vectors with the same force, and where on that curve an optimiser stops
is an accident of its path. Moving every good fit to the same point of its curve (the gauge rule of
``identifiable.to_paper``: nearest the centre of Table 5) removes that part of the scatter; what
remains is scatter in directions the data determine only weakly. The identifiable coordinates have
no such curve: their spread is the second part alone.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import statistics
from bwbench.analysis.spread import symmetry_share
from bwbench.models.switched import identifiable as fm
from bwbench.models.switched import parameters as switched_parameters
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.parameters import LABELS, LOWER, UPPER
from bwbench.render.labels import split_label

TOLERANCE = 0.10  # good fits: final MSE within 10 % of the best known for the specimen


def good_fits(study, specimen: str, tolerance: float = TOLERANCE) -> pd.DataFrame:
    """Ranking runs on ``specimen`` whose final MSE is within ``tolerance`` of the best known."""
    best = statistics.best_known(study.runs)[specimen]
    runs = study.ranking[(study.ranking["specimen"] == specimen) & (study.ranking["status"] == "ok")]
    return runs[runs["mse"] <= best * (1 + tolerance)]


def coordinates(runs: pd.DataFrame, state: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per run: the paper vector as fitted (14), the same loops in the canonical gauge (14), and the
    identifiable hysteretic vector (7 or 6). Runs of the paper formulation are mapped; runs of the
    identifiable one carry both (their paper vector is already in the canonical gauge). NaN rows
    where a map does not exist."""
    names = fm.hysteretic_names(state)
    paper, gauged, theta = [], [], []
    for _, run in runs.iterrows():
        p = run[list(PARAM_NAMES)].to_numpy(dtype=float)
        if np.isfinite(run.get(names[0], np.nan)):  # an identifiable run
            t = run[list(names)].to_numpy(dtype=float)
            paper.append(p)
            gauged.append(p)
            theta.append(t)
            continue
        t, linear = fm.from_paper(p, state)
        mapped = fm.to_paper(t, linear, state).params
        paper.append(p)
        gauged.append(mapped if mapped is not None else np.full(14, np.nan))
        theta.append(t)
    return np.array(paper).reshape(-1, 14), np.array(gauged).reshape(-1, 14), np.array(theta).reshape(-1, len(names))


def spread_table(study, specimen: str) -> tuple[pd.DataFrame, dict]:
    """Per parameter, the range of the good fits as % of its search range: paper coordinates as
    fitted and after fixing the gauge, identifiable coordinates (box scaled from the data); and a
    summary (``runs``, ``share``: the symmetry's part of the scatter of the ``share_runs`` fits searched
    in the paper's coordinates)."""
    from bwbench.data.specimen import read_specimen

    state = study.settings.get("state", "shared")
    runs = good_fits(study, specimen)
    paper, gauged, theta = coordinates(runs, state)
    to_unit = lambda P: (P - LOWER) / (UPPER - LOWER)  # noqa: E731
    spec = read_specimen(study.specimen_path(specimen))
    box = fm.scaled_bounds(spec.x, spec.f, state)
    paper_u, gauged_u, theta_u = to_unit(paper), to_unit(gauged), box.to_unit(theta)

    def width(U, j):
        column = U[:, j][np.isfinite(U[:, j])]
        return float(np.ptp(column)) if column.size >= 2 else float("nan")

    rows = [
        {
            "paper parameter": LABELS[n],
            "spread as fitted (% of Table 5)": width(paper_u, j),
            "after fixing the gauge": width(gauged_u, j),
        }
        for j, n in enumerate(PARAM_NAMES)
    ]
    ident = [
        {"identifiable parameter": fm.LABELS[n], "spread (% of its box)": width(theta_u, j)}
        for j, n in enumerate(box.names)
    ]
    frame = pd.concat([pd.DataFrame(rows), pd.DataFrame(ident)], axis=1)
    # The symmetry's share is a question about fits searched in the paper's 14 coordinates: a fit of
    # the identifiable formulation is mapped back in the canonical gauge already.
    single = study.settings.get("formulation", "paper")
    searched_paper = np.array([(split_label(o)[1] or single) == "paper" for o in runs["optimizer"]], dtype=bool)
    share = symmetry_share(paper_u[searched_paper], gauged_u[searched_paper])
    return frame, {
        "runs": len(runs),
        "share": share,
        "share_runs": int(searched_paper.sum()),
        "paper_unit": paper_u,
        "gauged_unit": gauged_u,
        "theta_unit": theta_u,
        "theta_names": box.names,
        "box": box,
        "optimizers": list(runs["optimizer"]),
    }


def figure(study, out_dir, specimen: str, order=None):
    """The good fits of ``specimen`` in both coordinate systems, side by side: the 14 paper parameters
    (Table 5 units) as fitted (filled) and moved to the canonical gauge (open), and the identifiable
    parameters (units of their data-scaled box). Each backend in its report-wide colour and marker
    (``order``: the report's ranking, see ``bwbench.render.palette``); one legend."""
    from bwbench.problems.hysteresis.report.figure_common import EDGE, edge_bands
    from bwbench.render.palette import (
        MAX_WIDTH_IN,
        TRUTH,
        backend_handles,
        legend,
        runs_text,
        save,
        slug,
        styles,
        theme,
        truth_handle,
    )
    from bwbench.render.palette import figure as new_figure

    theme()
    _, s = spread_table(study, specimen)
    look = styles(study, order)
    fig, (left, right) = new_figure(MAX_WIDTH_IN, 5.0, ncols=2, gridspec_kw={"width_ratios": [2, 1]})
    rng = np.random.default_rng(0)  # jitter only: the figure is the same every time
    rows, off_scale = [], 0
    for k, optimizer in enumerate(s["optimizers"]):
        jitter = rng.uniform(-0.18, 0.18)
        point = look[optimizer].point(ms=5.5)
        off_scale += int(np.sum((s["paper_unit"][k] < 0) | (s["paper_unit"][k] > 1)))
        left.plot(
            np.arange(14) + jitter,
            np.clip(s["paper_unit"][k], -EDGE, 1 + EDGE),
            **{**point, "mfc": point["color"]},
            alpha=0.85,
        )
        left.plot(
            np.arange(14) + jitter,
            np.clip(s["gauged_unit"][k], -EDGE, 1 + EDGE),
            **{**point, "mfc": "none", "ms": 7.5},
            alpha=0.85,
        )
        right.plot(
            np.arange(len(s["theta_names"])) + jitter,
            s["theta_unit"][k],
            **{**point, "mfc": point["color"]},
            alpha=0.85,
        )
        rows += [
            {"optimizer": optimizer, "coordinates": kind, "parameter": name, "unit_value": float(value)}
            for kind, names, values in (
                ("paper as fitted", PARAM_NAMES, s["paper_unit"][k]),
                ("paper, canonical gauge", PARAM_NAMES, s["gauged_unit"][k]),
                ("identifiable", s["theta_names"], s["theta_unit"][k]),
            )
            for name, value in zip(names, values)
        ]
    truth = switched_parameters.truth_params(study.specimen_path(specimen))
    if truth is not None:  # the truth's loops, in the canonical gauge and in the identifiable coordinates
        state = study.settings.get("state", "shared")
        t_theta, t_linear = fm.from_paper(truth, state)
        gauged = fm.to_paper(t_theta, t_linear, state).params
        if gauged is not None:
            left.plot(np.arange(14), (gauged - LOWER) / (UPPER - LOWER), **TRUTH, zorder=5)
        right.plot(np.arange(len(t_theta)), s["box"].to_unit(t_theta), **TRUTH, zorder=5)
    left.set_xticks(np.arange(14), [LABELS[n] for n in PARAM_NAMES])
    left.set_ylabel("position in range (–)")
    share = s["share"]
    left.set_title(
        "paper parameters (Table 5 units): filled = as fitted, open = same loops, gauge fixed"
        + (
            f"\n{share:.0%} of the scatter of the {s['share_runs']} paper-coordinate searches is the "
            "exact symmetry z → s·z"
            if np.isfinite(share)
            else ""
        )
        + (f"\n{off_scale} values beyond Table 5 drawn on the grey bands" if off_scale else ""),
        loc="left",
    )
    right.set_xticks(np.arange(len(s["theta_names"])), [fm.LABELS[n] for n in s["theta_names"]])
    right.set_title(
        "identifiable parameters (data-scaled\nbox): no symmetry; what scatters is\nweakly determined", loc="left"
    )
    edge_bands(left)  # fits mapped from the identifiable box can lie beyond Table 5
    right.set_ylim(-0.04, 1.04)
    for ax in (left, right):
        ax.grid(axis="x", visible=False)
    present = list(dict.fromkeys(s["optimizers"]))
    counts = pd.Series(s["optimizers"]).value_counts()
    handles = backend_handles(look, present, {o: f"{o} ({runs_text(int(counts[o]))})" for o in present}, line=False)
    if truth is not None:
        handles.append(truth_handle("truth (gauge fixed)"))
    legend(fig, handles, ncol=min(len(handles), 5))
    fig.suptitle(f"{specimen}: the {s['runs']} ranking runs within {TOLERANCE:.0%} of the best known MSE")
    synthetic = study.problem_type.is_synthetic(study)
    return save(fig, out_dir, f"nonuniqueness_{slug(specimen)}", pd.DataFrame(rows), synthetic)


def section(report, paper: bool) -> None:
    """The report's non-uniqueness section: for each specimen with a posterior, the good fits' scatter
    split into the data's, the optimisers' and the symmetry's (``spread_decomposition``, one table and one
    figure); and, when the study searched the paper's coordinates on the paper's data, the symmetry's
    part of the scatter on the featured specimens without a posterior."""
    from bwbench.problems.hysteresis.report import spread_decomposition as sd
    from bwbench.problems.hysteresis.report.posterior_draws import cached

    doc, study = report.doc, report.study
    chains = cached(report)
    searched = study.settings.get("formulation", "paper")
    searched = [searched] if isinstance(searched, str) else list(searched)
    symmetric = "paper" in searched
    if not chains and not symmetric:
        return
    doc.h(2, "Non-uniqueness: the data, the optimiser and the exact symmetry")
    if symmetric:
        doc.p(
            "The paper's 14 parameters have an exact symmetry: z → s·z with A → s·A, β, γ → s^(1−n)·β, "
            "s^(1−n)·γ and (1 − α)·ωn² → (1 − α)·ωn²/s leaves the force unchanged (one s for the shared state, "
            "one per branch for the split), so every fit lies on a curve of equally good parameter vectors; the "
            "identifiable coordinates have no such curve."
        )
    if chains:
        doc.p(
            "Where a specimen has a posterior, the good ranking fits (within 10 % of the best known MSE, every seed "
            "and formulation, put in the posterior's coordinates) are held against it. The posterior is what the "
            "data allow: a fit whose log-posterior reaches the 1 % quantile of the posterior's draws is as probable "
            "as they are, so where it lies the data put it; a fit below stopped before the posterior's bulk (on "
            "~1,900 samples a fit 10 % above the best MSE is e^90 less probable). Per parameter, fits outside the "
            "range the posterior's draws cover (their central 99 %) are scatter the data do not explain: the "
            "optimisers' when they stopped early, another mode the chain did not visit when they are as probable."
        )
    done = set()
    for pc in chains:
        specimen = pc.chain.specimen
        if specimen in done:
            continue
        done.add(specimen)
        d = sd.decomposition(study, pc)
        if not len(d["fits"]):
            doc.p(f"{specimen}: no good ranking fit to hold against the posterior.")
            continue
        doc.table(
            sd.shown_table(pc, d),
            f"{specimen}: the scatter of the {len(d['fits'])} good fits against the "
            "posterior, per parameter (positions as fractions of the search box)",
        )
        text = sd.sentence(pc, d)
        if not pc.assessment["converged"]:  # the reference itself is unreliable: say so first
            text = (
                "**Provisional: this specimen's posterior has not converged (see the posterior section), so its "
                "ranges are where the chain has been, not the posterior; read the split below with that "
                "caution.** " + text
            )
        doc.p(text)
        doc.figure(
            sd.figure(study, report.out, pc, d),
            f"{specimen}: the good fits against the posterior"
            + ("" if pc.assessment["converged"] else " (posterior not converged: provisional)"),
        )
    if not (symmetric and paper):
        return
    for specimen in [s for s in report.featured[:2] if s not in done]:
        table, s = spread_table(study, specimen)
        if s["runs"] < 2:
            doc.p(f"{specimen}: only {s['runs']} good fit(s): no spread to analyse.")
            continue
        shown = table.copy()
        for column in shown.columns:
            if shown[column].dtype.kind == "f":
                shown[column] = shown[column].map(lambda x: "–" if not np.isfinite(x) else f"{x:.0%}")
        doc.table(
            shown.fillna(""),
            f"{specimen}: range of the {s['runs']} good fits, as a fraction of each parameter's search range",
        )
        share = s["share"]
        if np.isfinite(share):
            doc.p(
                f"{specimen}: of the scatter of the paper parameters across the {s['share_runs']} of these fits "
                "that searched the paper's coordinates (total variance in Table 5 units), **{share:.0%} is the "
                "exact symmetry** (it disappears when the gauge is fixed); the rest lies in directions the data "
                "determine only weakly or where the optimisers stopped (no posterior on this specimen to tell "
                "which).".replace("{share:.0%}", f"{share:.0%}")
            )
        doc.figure(
            figure(study, report.out, specimen, order=list(report.table["optimizer"])),
            f"{specimen}: good fits in the paper's and the identifiable coordinates",
        )
