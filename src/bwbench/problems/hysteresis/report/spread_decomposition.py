"""Non-uniqueness split into its causes, for a specimen with a posterior (any model): the spread of
the good ranking fits across seeds against the posterior (``bwbench.analysis.spread``), and what the
exact symmetry of the model's direct parameters adds to the spread in those coordinates.

The fits are put in the chain's coordinates (the identifiable ones: the direct fits mapped with
``Model.from_direct``), positions as fractions of the chain's search box; their log-posteriors are
the sampler's own (``posterior_draws.log_posterior``). The symmetry's share is the fraction of the
variance of the direct-coordinate fits (box units) that moving each to one point of its orbit (the
gauge ``Model.to_direct`` maps to) removes; only for a model with symmetries (``Model.symmetries``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import spread
from bwbench.problems.hysteresis.report.posterior_draws import (
    TOLERANCE,
    axis,
    good_fits,
    in_coordinates,
    log_posterior,
    parameters,
    truth,
)

CLASS_COLOURS = {spread.DATA: "#009E73", spread.EARLY: "#D55E00", spread.ELSEWHERE: "#CC79A7"}


def symmetry_part(study, pc, runs: pd.DataFrame) -> dict:
    """{"share", "runs", "names"}: the share of the scatter of the fits that searched the model's direct
    coordinates that is its exact symmetry (NaN when it has none or fewer than 2 such fits)."""
    from bwbench.problems.hysteresis.report.figure_common import formulation_of, problem_for

    model = pc.problem.model
    problem = problem_for(study, pc.chain.specimen, model.direct_name)
    names = list(problem.param_names)
    mine = runs[[formulation_of(study, o) == model.direct_name for o in runs["optimizer"]]]
    P = mine[names].to_numpy(dtype=float) if len(mine) and all(n in mine for n in names) else np.empty((0, len(names)))
    P = P[np.all(np.isfinite(P), axis=1)]
    orbits = model.symmetries(P[0], problem.state) if len(P) else []
    out = {"share": float("nan"), "runs": int(len(P)), "names": [n for n, _ in orbits]}
    if len(P) < 2 or not orbits:
        return out
    gauged = []
    for p in P:
        try:
            theta, coef = model.from_direct(p, problem.state)
            g = model.to_direct(theta, coef, problem.state)
        except (NotImplementedError, ValueError):
            g = None
        gauged.append(np.full(len(names), np.nan) if g is None else np.asarray(g, dtype=float))
    out["share"] = spread.symmetry_share(problem.to_unit(P), problem.to_unit(np.array(gauged)))
    return out


def decomposition(study, pc) -> dict:
    """The decomposition for one posterior chain: ``table`` (``spread.decompose`` rows, labelled),
    ``kinds`` per fit, ``fits``/``draws`` (box units), their log-posteriors, the fits' ``optimizers``,
    ``truth`` (box units or None) and ``symmetry`` (``symmetry_part``)."""
    problem, specimen = pc.problem, pc.chain.specimen
    runs = good_fits(study, specimen)
    rows = [in_coordinates(row.to_dict(), problem) for _, row in runs.iterrows()]
    ok = [i for i, r in enumerate(rows) if r is not None]
    P = np.array([rows[i] for i in ok]).reshape(-1, len(pc.names))
    fits_lp = log_posterior(problem, P) if len(P) else np.empty(0)
    draws = pc.unit_draws()
    main = pc.main.walkers
    draws_lp = pc.chain.log_prob[pc.burn :, main].reshape(-1) if pc.chain.log_prob is not None else None
    if draws_lp is None:
        draws_lp = log_posterior(problem, problem.from_unit(draws))
    fits = problem.to_unit(P)
    # held by a reduced model, or in its gauge (trading with a held one): the full model's fits cannot
    # be placed against the reduced posterior there, so only the other parameters classify the fits
    gauge = problem.model.reduced_gauge(pc.fixed, problem.state)
    compared = [j for j, n in enumerate(pc.names) if n not in pc.fixed and n not in gauge]
    part, kinds = spread.decompose(
        fits[:, compared], fits_lp, draws[:, compared], draws_lp, [pc.names[j] for j in compared]
    )
    by_name = {r["parameter"]: r for r in part.to_dict("records")}
    for j, n in enumerate(pc.names):
        if n not in by_name:
            by_name[n] = {
                "parameter": n,
                "fits_spread": float(np.ptp(fits[:, j])) if len(fits) else np.nan,
                "posterior_width": np.nan,
                "inside": 0,
                "stopped_early": 0,
                "elsewhere": 0,
                "scatter": "the data (held fixed: a linear branch)"
                if n in pc.fixed
                else "the data (the reduced model's gauge: trades with a held parameter)",
            }
    table = pd.DataFrame([by_name[n] for n in pc.names])
    known = truth(study, problem, specimen)
    true = None if known is None else problem.to_unit(np.array([known.get(n, np.nan) for n in pc.names]))
    return {
        "table": table,
        "kinds": kinds,
        "fits": fits,
        "draws": draws,
        "fits_log_prob": fits_lp,
        "draws_log_prob": draws_lp,
        "optimizers": list(runs["optimizer"].iloc[ok]),
        "truth": true,
        "symmetry": symmetry_part(study, pc, runs),
        "runs": len(runs),
    }


def shown_table(pc, d: dict) -> pd.DataFrame:
    labels = parameters(pc.problem)
    t = d["table"]
    n = len(d["fits"])
    return pd.DataFrame(
        {
            "parameter": [axis(pc.problem, p, labels) for p in t["parameter"]],
            "good fits' spread (% of box)": [f"{x:.0%}" for x in t["fits_spread"]],
            "posterior's 99 % range (% of box)": [
                ("held" if p in pc.fixed else "–" if not np.isfinite(x) else f"{x:.0%}")
                for p, x in zip(t["parameter"], t["posterior_width"])
            ],
            "fits inside it": [
                f"{i}/{n}" if np.isfinite(x) else "–" for i, x in zip(t["inside"], t["posterior_width"])
            ],
            "outside, stopped early": t["stopped_early"],
            "outside, as probable": t["elsewhere"],
            "the scatter is": t["scatter"],
        }
    )


def sentence(pc, d: dict) -> str:
    kinds, n = d["kinds"], len(d["kinds"])
    counts = {k: int(np.sum(kinds == k)) for k in (spread.DATA, spread.EARLY, spread.ELSEWHERE)}
    t = d["table"][~d["table"]["parameter"].isin(pc.fixed)]
    labels = parameters(pc.problem)
    data = [labels[p][0] for p in t.loc[t["scatter"] == "the data", "parameter"]]
    early = [labels[p][0] for p in t.loc[t["scatter"] == "the optimiser", "parameter"]]
    other = [labels[p][0] for p in t.loc[t["scatter"] == "another mode", "parameter"]]
    text = (
        f"Of the {n} good fits, {counts[spread.DATA]} are as probable as the posterior's own draws and lie inside "
        f"the range of its draws in every parameter, {counts[spread.EARLY]} stopped before the posterior's bulk "
        f"(log-posterior below its draws' 1 % quantile) and {counts[spread.ELSEWHERE]} are as probable but lie "
        "where the draws do not go. "
    )
    if data:
        text += (
            f"The scatter of {', '.join(data)} stays within the posterior: the data cannot tell those values apart. "
        )
    if early:
        text += f"{', '.join(early)} scatter beyond it mostly through fits that stopped early: the optimisers'. "
    if other:
        text += (
            f"{', '.join(other)} scatter beyond it through fits as probable as the posterior's draws but where they "
            "do not go: another mode the chain did not visit. "
        )
    if pc.fixed:
        text += (
            f"{', '.join(labels[p][0] for p in pc.fixed)} are held fixed in the posterior (a branch the data "
            "cannot tell from a linear one): whatever the fits say of them, the data do not determine them. "
        )
        gauge = [n for n in pc.names if n in pc.problem.model.reduced_gauge(pc.fixed, pc.problem.state)]
        if gauge:
            text += (
                f"{', '.join(labels[p][0] for p in gauge)} trade with the held parameters along directions the data "
                "do not see (the reduced model's gauge), so the fits are placed against the posterior on the "
                "other parameters only. "
            )
    sym = d["symmetry"]
    if np.isfinite(sym["share"]):
        text += (
            f"In the model's direct coordinates, the exact symmetry ({'; '.join(sym['names'])}) accounts for "
            f"{sym['share']:.0%} of the scatter of the {sym['runs']} fits that searched them (it disappears when "
            "each is moved to one point of its orbit); this table is about the rest."
        )
    return text


def figure(study, out_dir, pc, d: dict):
    """Per sampled parameter: the posterior draws (violin) and their 95 % interval, the good fits by class
    and the truth, in units of the search box; beside it the fits' log-posteriors against the draws'."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from bwbench.problems.hysteresis.report.figure_common import synthetic
    from bwbench.render.palette import MAX_WIDTH_IN, TRUTH, legend, save, slug, theme
    from bwbench.render.palette import figure as new_figure

    theme()
    gauge = pc.problem.model.reduced_gauge(pc.fixed, pc.problem.state)
    names = [n for n in pc.names if n not in pc.fixed and n not in gauge]  # the compared ones
    idx = [pc.names.index(n) for n in names]
    fig, (left, right) = new_figure(MAX_WIDTH_IN, 5.2, ncols=2, gridspec_kw={"width_ratios": [2.3, 1]})
    x = np.arange(len(names))
    parts = left.violinplot([d["draws"][:, j] for j in idx], positions=x, widths=0.8, showextrema=False)
    for body in parts["bodies"]:
        body.set(facecolor="0.75", edgecolor="0.5", alpha=0.7)
    lo, hi = np.quantile(d["draws"][:, idx], [(1 - spread.LEVEL) / 2, (1 + spread.LEVEL) / 2], axis=0)
    left.vlines(x, lo, hi, color="0.25", lw=3, zorder=3)
    rng = np.random.default_rng(0)  # jitter only
    rows = []
    for k, kind in enumerate(d["kinds"]):
        jitter = rng.uniform(-0.22, 0.22)
        left.plot(
            x + jitter,
            np.clip(d["fits"][k, idx], -0.05, 1.05),
            ls="",
            marker="o",
            ms=5.5,
            mec="black",
            mew=0.5,
            color=CLASS_COLOURS[kind],
            alpha=0.9,
            zorder=4,
        )
        rows += [
            {
                "source": "fit",
                "optimizer": d["optimizers"][k],
                "class": kind,
                "parameter": n,
                "box_position": float(d["fits"][k, j]),
                "log_posterior": float(d["fits_log_prob"][k]),
            }
            for n, j in zip(names, idx)
        ]
    if d["truth"] is not None:
        left.plot(x, d["truth"][idx], **TRUTH, zorder=5)
    left.set_xticks(x, [parameters(pc.problem)[n][0] for n in names])
    left.set_ylim(-0.06, 1.06)
    left.set_ylabel("position in the search box (–)")
    left.set_title("posterior draws (violins, bar: central 99 %) and the good fits of the ranking", loc="left")
    lp_d, lp_f = d["draws_log_prob"], d["fits_log_prob"]
    top = float(np.max(lp_d))
    floor = float(np.quantile(lp_d, spread.FLOOR))
    right.hist(lp_d - top, bins=40, color="0.7", density=True, orientation="horizontal")
    right.axhline(floor - top, color="0.25", ls="--", lw=1)
    low = max(float(np.min(lp_d - top)) - 10.0, floor - top - 40.0)
    for k, kind in enumerate(d["kinds"]):
        y = max(float(lp_f[k] - top), low) if np.isfinite(lp_f[k]) else low
        right.plot(
            rng.uniform(0.02, 0.12) * right.get_xlim()[1],
            y,
            ls="",
            marker="o",
            ms=5.5,
            mec="black",
            mew=0.5,
            color=CLASS_COLOURS[kind],
            zorder=4,
        )
    right.set_ylim(low - 1.0, 1.0 + max(0.0, float(np.max(lp_f - top)) if len(lp_f) else 0.0))
    right.set_ylabel("log-posterior − the draws' highest (–)")
    right.set_xlabel("density of the draws (–)")
    right.set_title(
        "how probable the fits are\n(dashed: the draws' 1 % quantile;\nfits far below: at the bottom edge)", loc="left"
    )
    handles = [
        Patch(color="0.75", label="posterior draws"),
        *[
            Line2D(
                [],
                [],
                ls="",
                marker="o",
                ms=6,
                mec="black",
                mew=0.5,
                color=c,
                label=f"good fit, {k} ({int(np.sum(d['kinds'] == k))})",
            )
            for k, c in CLASS_COLOURS.items()
        ],
    ]
    if d["truth"] is not None:
        handles.append(Line2D([], [], **TRUTH, label="truth"))
    legend(fig, handles, ncol=len(handles))
    sym = d["symmetry"]
    fig.suptitle(
        f"{pc.chain.specimen}: why the {len(d['kinds'])} good ranking fits (MSE within {TOLERANCE:.0%} of the "
        "best) scatter\nthe data (inside the posterior) or the optimiser (stopped early)"
        + (
            f"; in the direct coordinates the exact symmetry adds {sym['share']:.0%} of their scatter"
            if np.isfinite(sym["share"])
            else ""
        )
    )
    frame = pd.DataFrame(rows)
    return save(
        fig, out_dir, f"nonuniqueness_posterior_{slug(pc.chain.specimen)}", frame, synthetic(study, [pc.chain.specimen])
    )
