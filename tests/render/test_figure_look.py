"""The look every study figure promises: one style per backend, the same in every figure and in
ranking order; one legend per figure listing only the backends it draws; sized for a 1,200 px
column; the posterior says whether its chain converged."""

import types

import matplotlib.figure
import matplotlib.text
import numpy as np
import pandas as pd
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.database import reader as results_db
from bwbench.models.switched import identifiable as fm
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.problems.hysteresis.report import fit_figures, non_uniqueness, posterior_figures, profile_figures
from bwbench.problems.hysteresis.report import parameter_figures as switched_figures
from bwbench.problems.hysteresis.report.figure_common import problem_for
from bwbench.render import ecdf_figures, palette, waterfall
from bwbench.render import run_figures as figures
from study_fixture import make_study_db

ORDER = ["de", "cmaes", "random"]  # not the configuration's order, nor the median loss's


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    return results_db.load_study(make_study_db(tmp_path_factory.mktemp("db") / "study.sqlite"))


@pytest.fixture
def drawn(monkeypatch):
    """What each figure looked like when it was saved: size, legends, texts, smallest font."""
    seen = []
    original = matplotlib.figure.Figure.savefig

    def savefig(fig, *args, **kwargs):
        result = original(fig, *args, **kwargs)  # laid out and drawn: the texts are final
        entries = []
        for leg in fig.legends:
            for handle, text in zip(leg.legend_handles, leg.get_texts()):
                look = {"text": text.get_text()}
                if hasattr(handle, "get_linestyle") and hasattr(handle, "get_marker"):
                    look.update(
                        colour=matplotlib.colors.to_hex(handle.get_color()),
                        ls=handle.get_linestyle(),
                        marker=handle.get_marker(),
                    )
                entries.append(look)
        texts = [t for t in fig.findobj(matplotlib.text.Text) if t.get_visible() and t.get_text().strip()]
        seen.append(
            types.SimpleNamespace(
                width_in=fig.get_size_inches()[0],
                dpi=kwargs.get("dpi"),
                figure_legends=len(fig.legends),
                axes_legends=sum(ax.get_legend() is not None for ax in fig.axes),
                entries=entries,
                texts=" | ".join(t.get_text() for t in texts),
                smallest_font=min(t.get_fontsize() for t in texts),
            )
        )
        return result

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    return seen


def _backend_entries(record, names):
    """Legend entries of ``record`` that name a backend, as {backend: entry}, in legend order."""
    out = {}
    for entry in record.entries:
        name = entry["text"].split(" (")[0].split(":")[0]
        if name in names:
            out[name] = entry
    return out


def test_a_backend_keeps_its_colour_and_marker_by_name_whatever_its_rank_or_company():
    alone = palette.styles_for(["cmaes", "random"])
    ranked_last = palette.styles_for(["de", "nlopt-bobyqa", "lsq-trf [paper]", "cmaes [paper]", "random [paper]"])
    assert (alone["cmaes"].colour, alone["cmaes"].marker) == ("#0072B2", "o")
    assert (ranked_last["cmaes [paper]"].colour, ranked_last["cmaes [paper]"].marker) == ("#0072B2", "o")
    assert alone["random"].colour == ranked_last["random [paper]"].colour == palette.RANDOM_COLOUR
    builtin = palette.styles_for([*palette.BACKEND_LOOK, "random"])
    assert len({(s.colour, s.marker) for s in builtin.values()}) == len(builtin)  # no two alike
    assert len({s.colour for s in builtin.values()}) == len(builtin)  # not even in colour
    # plug-ins: free looks, in name order, never one a built-in of the study uses
    many = palette.styles_for([f"backend{i}" for i in range(10)] + ["cmaes", "de", "random"])
    assert len({(s.colour, s.marker) for s in many.values()}) == 13
    assert many["backend0"].colour == palette.EXTRA_LOOKS[0][0]


def test_both_formulations_of_a_backend_share_its_colour_and_differ_in_line_and_fill():
    looks = palette.styles_for(["cmaes [identifiable]", "de [paper]", "cmaes [paper]", "de [identifiable]"])
    ident, paper = looks["cmaes [identifiable]"], looks["cmaes [paper]"]
    assert ident.colour == paper.colour and ident.marker == paper.marker
    assert (ident.linestyle, ident.filled) == ("-", True) and (paper.linestyle, paper.filled) == ("--", False)
    assert looks["de [paper]"].colour == looks["de [identifiable]"].colour != ident.colour
    assert palette.split_label("nlopt-bobyqa [paper]") == ("nlopt-bobyqa", "paper")


def test_default_order_is_the_median_final_loss(study):
    medians = study.ranking.groupby("optimizer")["mse"].median().sort_values()
    assert palette.ranking_order(study)[:3] == list(medians.index)
    assert palette.ranking_order(study, ORDER)[:3] == ORDER
    assert palette.ranking_order(study)[-1] == "emcee"  # posterior only: after the ranking backends


def test_every_backend_has_one_style_in_every_figure_in_ranking_order(study, drawn, tmp_path):
    specimen = study.specimens[0]
    figures.convergence(study, tmp_path, order=ORDER)
    ecdf_figures.runtime_distributions(study, tmp_path, order=ORDER)
    fit_figures.hysteresis_loops(study, tmp_path, specimen, order=ORDER)
    switched_figures.parameter_spread(study, tmp_path, order=ORDER)
    expected = palette.styles(study, ORDER)
    seen = {}
    for record in drawn:
        entries = _backend_entries(record, ORDER)
        listed = [name for name in ORDER if name in entries]
        assert list(entries) == listed  # legend in ranking order
        for name, entry in entries.items():
            assert entry["colour"] == matplotlib.colors.to_hex(expected[name].colour)
            # a figure draws a backend's line, its marker or both: whichever it shows is the backend's
            assert entry["marker"] in (expected[name].marker, "None", "")
            assert entry["ls"] in (expected[name].linestyle, "None", "", " ")
            seen.setdefault(name, set()).add(entry["marker"])
    assert set(seen) == set(ORDER)
    assert all(expected[name].marker in markers for name, markers in seen.items())
    assert list(_backend_entries(drawn[0], ORDER)) == ORDER  # convergence draws all three


def test_legends_list_only_the_backends_a_figure_draws(study, drawn, tmp_path):
    switched_figures.parameter_spread(study, tmp_path, order=ORDER)
    non_uniqueness.figure(study, tmp_path, study.specimens[0], order=ORDER)
    # Only cmaes comes within 10 % of the best known in the fixture: de and random are not listed.
    for record in drawn:
        assert list(_backend_entries(record, ORDER)) == ["cmaes"]


def test_one_legend_per_figure_and_sized_for_the_page(study, drawn, tmp_path):
    material = study.ranking["material"].iloc[0]
    figures.convergence(study, tmp_path, order=ORDER)
    ecdf_figures.runtime_distributions(study, tmp_path, order=ORDER)
    waterfall.waterfall(study, tmp_path, order=ORDER)
    fit_figures.hysteresis_loops(study, tmp_path, study.specimens[0], order=ORDER)
    switched_figures.parameter_spread(study, tmp_path, order=ORDER)
    switched_figures.parameters_vs_underpressure(study, tmp_path, "cmaes", material, order=ORDER)
    posterior_figures.posterior(study, tmp_path, study.chains[0], order=ORDER)
    non_uniqueness.figure(study, tmp_path, study.specimens[0], order=ORDER)
    names = ("wn-", "A+", "n-", "xi+")  # four profiles: two rows of panels
    analysis = {
        "specimen": "toy",
        "mse": 1.0,
        "noise_rmse_N": 1.0,
        "n_data": 100,
        "params": dict.fromkeys(names, 10.0),
        "profiles": {
            name: [{"value": v, "unit": 0.0, "mse": 1.0 + (v - 10) ** 2, "evaluations": 5} for v in (2.0, 10.0, 20.0)]
            for name in names
        },
    }
    profile_figures.profiles(analysis, tmp_path)
    assert len(drawn) == 9
    for record in drawn:
        assert record.figure_legends == 1 and record.axes_legends == 0
        assert record.width_in <= palette.MAX_WIDTH_IN and record.dpi == palette.DPI
        assert record.smallest_font >= palette.MIN_FONT_PT


def _diagnostics(r_hat, ess):
    names = list(PARAM_NAMES)
    return pd.DataFrame({"parameter": names, "r_hat": r_hat, "ess_bulk": ess, "ess_tail": ess})


def test_posterior_states_whether_the_chain_converged(study, drawn, tmp_path):
    chain = study.chains[0]
    posterior_figures.posterior(study, tmp_path, chain, diagnostics=_diagnostics(1.002, 900.0))
    posterior_figures.posterior(study, tmp_path, chain, diagnostics=_diagnostics(np.linspace(1.0, 1.3, 14), 40.0))
    converged, unconverged = drawn
    assert "converged: R̂ ≤ 1.01 and bulk ESS ≥ 400 for every parameter" in converged.texts
    assert "NOT converged" not in converged.texts
    assert "NOT converged: R̂ up to 1.3" in unconverged.texts and "bulk ESS down to 40" in unconverged.texts


def test_posterior_in_the_identifiable_coordinates(study, tmp_path):
    chain = study.chains[0]
    spec = read_specimen(study.specimen_path(chain.specimen))
    box = fm.scaled_bounds(spec.x, spec.f, "shared")
    names = list(fm.hysteretic_names("shared"))
    rng = np.random.default_rng(3)
    unit = np.clip(0.5 + 0.02 * rng.standard_normal((200, 20, len(names))), 0, 1)
    ident = results_db.Chain("posterior", chain.specimen, "emcee", 0, unit, None, 0.3, None)
    png = posterior_figures.posterior(study, tmp_path, ident, names=names, from_unit=box.from_unit)
    frame = pd.read_csv(png.with_suffix(".csv"))
    assert list(frame.columns) == ["source", "optimizer", *names]
    samples = frame[frame["source"] == "posterior"][names].to_numpy()
    assert np.all((samples >= box.lower * (1 - 1e-6)) & (samples <= box.upper * (1 + 1e-6)))
    truth = frame[frame["source"] == "truth"][names].to_numpy()  # mapped from the paper's 14
    assert truth.shape == (1, len(names)) and np.all(np.isfinite(truth))


def test_profiles_say_when_the_profile_found_a_better_fit(drawn, tmp_path):
    analysis = {
        "specimen": "toy",
        "mse": 2.0,
        "noise_rmse_N": 1.0,
        "n_data": 100,
        "params": {"beta+": 1.0},
        "profiles": {
            "beta+": [
                {"value": v, "unit": 0.0, "mse": m, "evaluations": 5}
                for v, m in ((0.5, 3.0), (1.0, 2.0), (1.5, 1.5), (2.0, 1.5))
            ]
        },
    }
    frame = pd.read_csv(profile_figures.profiles(analysis, tmp_path).with_suffix(".csv"))
    assert "the profile found a better fit: 1.5 N², 25.00% below the analysed fit's 2 N²" in drawn[0].texts
    assert "95 % region bounded below only" in drawn[0].texts
    assert set(frame["bounded"]) == {"below only"}


def test_a_better_fit_callout_shows_the_difference_or_is_left_out():
    from bwbench.problems.hysteresis.report.profile_figures import better_fit_text

    # the quick report printed "9.7483 vs 9.7483 N²": now enough digits to see the gap, or nothing
    assert better_fit_text(9.74831, 9.74834) is None  # 3e-6 relative: not a better fit worth a callout
    text = better_fit_text(9.7041, 9.7483)
    assert text == "9.7041 N², 0.45% below the analysed fit's 9.7483 N²"
    close = better_fit_text(9.7473, 9.7483)  # 1e-4: the digits tell them apart
    assert close == "9.7473 N², 0.01% below the analysed fit's 9.7483 N²"


def test_profiles_claim_a_bound_only_from_converged_points(drawn, tmp_path):
    from bwbench.problems.hysteresis.report.profile_figures import bounded

    values, mse = [0.0, 1.0, 2.0, 3.0], [9.0, 1.0, 1.01, 9.0]
    assert bounded(values, mse, 2.0) == "both sides"
    assert bounded(values, mse, 2.0, [True, True, True, False]) == "below only"
    assert bounded(values, mse, 2.0, [False, True, True, False]) == "not shown"  # upper bounds only
    assert bounded(values, [1.5, 1.0, 1.2, 1.9], 2.0, [False] * 4) == "neither"  # below: shown either way
    analysis = {
        "specimen": "toy",
        "mse": 1.0,
        "noise_rmse_N": 1.0,
        "n_data": 100,
        "params": {"n+": 1.0},
        "profiles": {
            "n+": [
                {"value": v, "unit": 0.0, "mse": m, "evaluations": 5, "converged": c}
                for v, m, c in zip(values, mse, [False, True, True, False])
            ]
        },
    }
    profile_figures.profiles(analysis, tmp_path)
    assert "95 % region no bound shown (not converged)" in drawn[0].texts
    assert "bounded on both sides" not in drawn[0].texts


def test_plot_fit_titles_the_formulation_and_shows_the_residual(study, drawn, tmp_path):
    specimen = study.specimens[0]
    problem = problem_for(study, specimen)
    run = study.ranking[study.ranking["specimen"] == specimen].sort_values("mse").iloc[0]
    params = {n: float(run[n]) for n in problem.param_names}
    result = types.SimpleNamespace(
        params=params, optimizer="cmaes", seed=1, nfev=400, rmse_N=float(np.sqrt(run["mse"])), f_err=-float(run["mse"])
    )
    fit_figures.plot_fit(problem, result, tmp_path / "fit.png", synthetic=True)
    assert (tmp_path / "fit.png").stat().st_size > 10_000
    (record,) = drawn
    # the model is named in every title (the switched model too), and NRMSE is given with its definition
    assert "switched-bouc-wen (paper formulation), cmaes" in record.texts
    assert f"residual: RMSE {np.sqrt(run['mse']):.3g} N, NRMSE" in record.texts and "(RMSE/max F" in record.texts
    assert record.width_in <= palette.MAX_WIDTH_IN and record.smallest_font >= palette.MIN_FONT_PT


def test_a_legend_too_wide_for_the_page_gets_fewer_columns(tmp_path, monkeypatch):
    from matplotlib.lines import Line2D

    drawn = {}
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda self, *a, **k: drawn.update(fig=self, legend=self._bwbench_legend_below),
    )
    fig, ax = palette.figure(palette.MAX_WIDTH_IN, 4.0)
    ax.plot([0, 1], [0, 1])
    handles = [Line2D([], [], marker="o", label=f"a long backend name [identifiable] ({i} runs)") for i in range(24)]
    palette.legend(fig, handles, ncol=5)
    palette.save(fig, tmp_path, "wide", pd.DataFrame({"x": [0]}), synthetic_data=False)
    leg, fig = drawn["legend"], drawn["fig"]
    assert leg._ncols < 5 and len(leg.legend_handles) == 24
    assert leg.get_window_extent().width <= fig.get_size_inches()[0] * fig.dpi


def test_three_models_of_one_backend_are_three_line_styles_fixed_by_name():
    labels = ["lsq-trf [spencer]", "lsq-trf [bouc-wen]", "lsq-trf [switched-bouc-wen]"]
    looks = palette.styles_for(labels)
    assert len({(s.linestyle, s.filled) for s in looks.values()}) == 3
    again = palette.styles_for(labels[::-1])  # another ranking: the same look for each model
    assert all((looks[n].linestyle, looks[n].filled) == (again[n].linestyle, again[n].filled) for n in labels)


def test_the_theme_is_seaborns_whitegrid_notebook_without_importing_seaborn():
    import subprocess
    import sys
    import textwrap

    # In a fresh process: the theme must not import seaborn (~0.75 s with scipy.stats); then seaborn's own
    # theme with the same sizes on top must leave every rcParam and colour code as ours did.
    script = textwrap.dedent("""
        import sys, matplotlib, matplotlib.pyplot as plt
        from bwbench.render import palette
        palette.theme()
        ours = {k: str(v) for k, v in plt.rcParams.items()}
        our_codes = {c: matplotlib.colors.to_rgb(c) for c in "bgrmyck"}
        assert "seaborn" not in sys.modules and "scipy.stats" not in sys.modules
        import seaborn as sns
        plt.rcdefaults()
        sns.set_theme(style="whitegrid", context="notebook")
        plt.rcParams.update(palette.SIZES)
        plt.rcParams["image.cmap"] = "viridis"  # seaborn's "rocket" is left out (see palette)
        theirs = {k: str(v) for k, v in plt.rcParams.items()}
        print(sorted(k for k in theirs if ours.get(k) != theirs[k]))
        print(our_codes == {c: matplotlib.colors.to_rgb(c) for c in "bgrmyck"}, our_codes["k"])
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]", "True (0.1, 0.1, 0.1)"]
