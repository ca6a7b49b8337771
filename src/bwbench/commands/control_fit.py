"""``bwbench fit FILES --control COLUMN --law ...``: one model across a damper's control range.

The files are read with their control (``bwbench.data.control``), the laws parsed (``--law
alpha=quadratic,c1=linear`` or ``auto``), and one ``ControlledProblem`` fitted; the result JSON is the
joint fit's with a ``control`` block (the laws, their nodes, closed forms) that ``bwbench predict`` reads.
``--law auto`` first fits each control level alone and prints the law it chose for every parameter
and why; ``--laws-figure`` draws each parameter against the control (each file fitted alone with its
95 % interval, or each level with ``auto``; the law with its band); ``--leave-one-level-out`` adds the
comparison of ``control.levels`` (per-test constants against the laws on held-out levels).
"""

from __future__ import annotations

from bwbench.errors import UserError


def wants_control(args) -> bool:
    return bool(getattr(args, "control", None) or getattr(args, "law", None) or getattr(args, "control_filter", False))


def check_flags(args) -> None:
    """The control flags that cannot go with the others, refused before any file is read."""
    if args.each and (args.law or args.control_filter):
        raise UserError("--each fits each file alone, with its own constants: drop --law (and --control-filter) for it")


def outputs(args) -> dict:
    """The control's own outputs, checked with ``fit``'s."""
    return {"--laws-figure": getattr(args, "laws_figure", None)}


def after(args, setup, status: int) -> int:
    """What a fit across a control adds once the fit is written: each coefficient with its standard error,
    ``--leave-one-level-out``, ``--laws-figure``; the exit status (``status`` unless these fail)."""
    from pathlib import Path

    from bwbench import threads
    from bwbench.data import strict_json
    from bwbench.data.json_input import read_json_file
    from bwbench.data.output_paths import writing

    problem = setup.problem
    result = read_json_file(Path(args.out))
    values = result.get("params") or {}
    if status or not all(isinstance(values.get(n), (int, float)) for n in problem.param_names):
        return status
    laws = ", ".join(f"{n} {law.name}" for n, law in problem.laws.items()) or "none"
    print(f"  laws of {problem.control_name} ({laws}):")
    for row in result.get("coefficients", []):
        unit = "" if row["unit"] in ("", "-", "–") else f" {row['unit']}"
        value, error = row["value"], row["stderr"]  # null in the JSON: not finite
        shown = "not finite" if value is None else f"{value:.6g}"
        spread = "not determined" if error is None or error == float("inf") else f"{error:.2g}"
        print(f"    {row['name']} = {shown} ± {spread}{unit}")
    with threads.limited(args.threads):
        if args.leave_one_level_out:
            from bwbench.problems.hysteresis.control.levels import compare_levels

            comparison = compare_levels(
                list(setup.specimens),
                {k: v for k, v in problem.settings.items()},
                {n: law for n, law in problem.laws.items()},
                optimizer=args.optimizer,
                budget=args.budget,
                seed=args.seed,
                progress=lambda line: print(f"  leave one level out: {line} …", flush=True),
            )
            print(comparison.table())
            print(comparison.summary())
            result["leave_one_level_out"] = comparison.to_dict()
            with writing(args.out):
                strict_json.write(args.out, result)
        if args.laws_figure:
            points = getattr(problem, "law_points", None) or {}
            if not points:
                print(f"  fitting each file alone for {args.laws_figure} …", flush=True)
                points = _each_file_points(setup.specimens, problem.settings, args)
            from bwbench.problems.hysteresis.control import figure

            with writing(args.laws_figure):
                figure.draw(problem, values, points, args.laws_figure)
            print(f"  parameters against {problem.control_name} -> {args.laws_figure}")
    return status


def _each_file_points(specimens, settings, args) -> dict:
    """{parameter: [(level, value, standard error)]} of each file fitted alone with constants."""
    import numpy as np

    from bwbench.problems.hysteresis.control.problem import build
    from bwbench.problems.hysteresis.fit_result import run_fit

    points: dict = {}
    for s in specimens:
        one = build([s], settings, {})
        fit = run_fit(one, args.optimizer, args.budget, args.seed, stop="agreed")
        names, cov, _ = one.covariance(fit.result.params)
        se = dict(zip(names, np.sqrt(np.abs(np.diag(cov)))))
        level = float(np.mean(s.control))
        for n, v in fit.result.params.items():
            points.setdefault(n, []).append((level, float(v), float(se.get(n, np.nan))))
    return points


def add_arguments(parser) -> None:
    """The control flags of ``bwbench fit``."""
    parser.add_argument(
        "--control",
        action="append",
        metavar="COLUMN[=VALUE]",
        help="the control of a controllable damper: a column <quantity>_<unit> of the files (current_A, "
        "voltage_V, underpressure_MPa), read when named; =VALUE: the level of files without it (a "
        "manifest.json field of that name also gives a file's level)",
    )
    parser.add_argument(
        "--law",
        metavar="NAME=LAW,...|auto",
        help="parameters as laws of the control, LAW one of constant, linear, quadratic, exponential "
        "(names as `bwbench models` lists them, e.g. vy=linear,c1=linear); auto: each level fitted alone "
        "first, each parameter given the smallest law its per-level values need beyond their errors",
    )
    parser.add_argument(
        "--control-filter",
        action="store_true",
        help="a first-order lag between the command in the file and the control that acts, "
        "u' = -eta_u (u - v), eta_u fitted (Spencer et al. 1997); without it the control acts at once",
    )
    parser.add_argument(
        "--laws-figure",
        metavar="PNG",
        help="each parameter against the control: each file (or level, with auto) fitted alone with its "
        "95%% interval, the law with its 95%% band",
    )
    parser.add_argument(
        "--leave-one-level-out",
        action="store_true",
        help="also fit the laws without each level and predict its files; compare with each file "
        "fitted alone and with the nearest level's constants (NRMSE = RMSE/max|F|)",
    )
