"""The figure of parameters against the control: each file's (or level's) own fit with its 95 % interval,
and the fitted law with its 95 % band (the delta method through the law's coefficients' covariance).
One panel per parameter, units on both axes; the points come from ``fit --each`` or ``--law auto``'s
per-level fits."""

from __future__ import annotations

import math

import numpy as np

Z95 = 1.959964
SUFFIX = {"": "", "+": "₊", "-": "₋"}


def law_curve(problem, values: dict, names, cov, parameter: str, u) -> tuple[np.ndarray, np.ndarray]:
    """(θ(u), its standard error) of ``parameter`` over controls u from the fitted ``values`` and the
    covariance ``cov`` of the coefficients ``names`` (``ControlledProblem.covariance``)."""
    law = problem.laws.get(parameter)
    index = {n: i for i, n in enumerate(names)}
    if law is None:
        value = float(values[parameter])
        i = index.get(parameter)
        sd = math.sqrt(abs(cov[i, i])) if i is not None else math.nan
        return np.full(len(u), value), np.full(len(u), sd)
    nodes = law.nodes(*problem.law_nodes)
    coefs = law.coefficient_names(parameter, nodes, problem.control_unit)
    c = np.array([values[n] for n in coefs], dtype=float)
    theta = law.value(c, u, nodes)
    G = law.jacobian(c, u, nodes)
    if all(n in index for n in coefs):
        sub = cov[np.ix_([index[n] for n in coefs], [index[n] for n in coefs])]
        se = np.sqrt(np.abs(np.einsum("li,ij,lj->l", G, sub, G)))
    else:
        se = np.full(len(u), math.nan)  # a coefficient held on a bound: no interval
    return theta, se


def draw(problem, values: dict, points: dict, path=None, parameters=None, title: str | None = None):
    """The figure (a matplotlib ``Figure``, saved to ``path`` when given). ``points``: {parameter: [(u,
    value, standard error)]}; ``parameters``: the panels (default: those with a law, then the others
    with points)."""
    import matplotlib
    from matplotlib.figure import Figure

    from bwbench.render.fit_plots import STYLE

    names, cov, _ = problem.covariance(values)
    chosen = list(parameters or [*problem.laws, *(p for p in points if p not in problem.laws)])
    units = problem.units(chosen)
    labels = {p.name: p.label for p in problem.parameter_list}
    if problem.design is not None:
        layout = problem.model.linear_layout(problem.state)
        labels.update(
            {
                n: layout.labels.get(n.rstrip("+-"), n.rstrip("+-")) + SUFFIX[n[len(n.rstrip("+-")) :]]
                for n in problem.solved_names
            }
        )
    span = problem.u_hi - problem.u_lo
    u = np.linspace(problem.u_lo - 0.1 * span, problem.u_hi + 0.1 * span, 200)
    cols = min(3, len(chosen))
    rows = math.ceil(len(chosen) / cols)
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(3.6 * cols + 0.4, 2.8 * rows + 0.5), layout="constrained")
        axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
        for ax, name in zip(axes, chosen):
            theta, se = law_curve(problem, values, names, cov, name, u)
            law = problem.laws.get(name)
            ax.plot(
                u, theta, color="tab:red", lw=1.2, label=f"{law.name if law else 'constant'} law (one fit of all files)"
            )
            if np.all(np.isfinite(se)):
                ax.fill_between(
                    u, theta - Z95 * se, theta + Z95 * se, color="tab:red", alpha=0.2, lw=0, label="95 % band"
                )
            pts = points.get(name, [])
            if pts:
                pu, pv, ps = (np.array(a, dtype=float) for a in zip(*pts))
                err = np.where(np.isfinite(ps), Z95 * ps, np.nan)
                ax.errorbar(
                    pu, pv, yerr=err, fmt="o", ms=3.5, color="0.2", capsize=2, lw=0.8, label="each file alone (95 %)"
                )
            _limits(ax, theta, [p[1] for p in pts])
            unit = units.get(name, "")
            unit = "–" if unit in ("", "-") else unit
            ax.set_ylabel(f"{labels.get(name, name)} ({unit})")
            ax.set_xlabel(f"{problem.control_name.rsplit('_', 1)[0]} ({problem.control_unit})")
            ax.set_title(name, fontsize="medium")
        for ax in axes[len(chosen) :]:
            ax.set_visible(False)
        axes[0].legend(fontsize="x-small", loc="best")
        fig.suptitle(
            title or f"{problem.model.name} ({problem.formulation}): parameters against {problem.control_name}",
            fontsize="medium",
        )
        if path is not None:
            fig.savefig(path, dpi=110)
    return fig


def _limits(ax, curve, values) -> None:
    """The y-range of the law and the points (10 % margin): an interval or band of a parameter the data do
    not determine (± 10⁶) would otherwise flatten everything else; it runs off the panel instead."""
    shown = np.concatenate([np.asarray(curve, dtype=float), np.asarray(values, dtype=float)])
    shown = shown[np.isfinite(shown)]
    if not shown.size:
        return
    low, high = float(shown.min()), float(shown.max())
    pad = 0.1 * (high - low) if high > low else 0.1 * max(abs(high), 1e-12)
    ax.set_ylim(low - pad, high + pad)
