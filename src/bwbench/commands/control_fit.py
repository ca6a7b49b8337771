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


def read(args):
    """(specimens with their control, the laws or "auto", the problem settings), every flag checked first."""
    from bwbench.commands.simulate import settings_from_args
    from bwbench.data import control, plausibility
    from bwbench.problems.hysteresis.control import laws as laws_mod
    from bwbench.problems.hysteresis.settings import refuse_same_file

    spec = control.parse_all(args.control)
    if spec is None:
        raise UserError(
            "--law and --control-filter need the control: --control COLUMN (e.g. current_A) or COLUMN=VALUE"
        )
    laws = laws_mod.parse(args.law) if args.law else {}
    if not laws and not args.control_filter:
        raise UserError(
            f"--control {spec.name} without --law: give the laws of the parameters (--law NAME=LAW,... or auto)"
        )
    if args.each:
        raise UserError("--each fits each file alone, with its own constants: drop --law (and --control-filter) for it")
    if laws == "auto" and args.control_filter:
        raise UserError(
            "--law auto fits each control level alone: it needs files of constant control, not --control-filter"
        )
    settings = settings_from_args(args)
    refuse_same_file(args.specimen)
    specimens = [control.read(p, spec) for p in args.specimen]
    plausibility.screen(specimens, warn=False)
    return specimens, laws, settings


def fit_controlled(args, options, workers: int, fit_problem) -> int:
    """The fit of ``bwbench fit`` with ``--control``/``--law``: exit statuses as ``fit``'s. ``fit_problem``:
    ``fit``'s own fit, JSON and printing of a problem (``commands.fit._fit_problem``)."""
    import math
    import sys

    from bwbench import threads
    from bwbench.data import manifest
    from bwbench.data.output_paths import check_outputs, writing
    from bwbench.problems.hysteresis.control import auto
    from bwbench.problems.hysteresis.control.problem import build

    check_outputs(
        {"--out": args.out, "--plot": args.plot, "--laws-figure": args.laws_figure},
        [*args.specimen, getattr(args, "bounds", None)],
    )
    specimens, laws, settings = read(args)
    synthetic = all(manifest.is_synthetic(p) for p in args.specimen)
    points: dict = {}
    with threads.limited(args.threads):
        if laws == "auto":
            levels = sorted({float(s.control[0]) for s in specimens})
            print(
                f"--law auto: fitting each of the {len(levels)} {specimens[0].control_name} levels alone …", flush=True
            )
            fits = auto.per_level_fits(specimens, settings, args.optimizer, args.budget, args.seed)
            units_of = build(specimens[:1], settings, {}).units
            choices = auto.choose_laws(fits, specimens[0].control_name, units_of(list(fits[levels[0]][2])))
            for c in choices:
                print(f"  {c.parameter}: {c.law} — {c.reason}")
            laws = {c.parameter: c.law for c in choices if c.law != "constant"}
            points = {
                n: [(lv, v[n][0], v[n][1]) for lv, (_, _, v) in fits.items() if n in v] for n in fits[levels[0]][2]
            }
        problem = build(specimens, settings, laws, control_filter=args.control_filter)
    status = fit_problem(args, problem, options, workers, synthetic, args.out, args.plot)
    if status:
        return status
    from pathlib import Path

    from bwbench.data import strict_json
    from bwbench.data.json_input import read_json_file

    result = read_json_file(Path(args.out))
    values = result["params"]
    print(
        f"  laws of {problem.control_name} ({', '.join(f'{n} {law.name}' for n, law in problem.laws.items()) or 'none'}):"
    )
    table = problem.law_table(values)
    for row in table:
        unit = "" if row["unit"] in ("", "-") else f" {row['unit']}"
        print(f"    {row['name']} = {row['value']:.6g} ± {row['stderr']:.2g}{unit}")
    result["coefficients"] = table
    if points:
        result["law_choices"] = {c.parameter: {"law": c.law, "why": c.reason} for c in choices}
    if args.leave_one_level_out:
        from bwbench.problems.hysteresis.control.levels import compare_levels

        comparison = compare_levels(
            specimens,
            settings,
            laws,
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
        if not points:
            print(f"  fitting each file alone for {args.laws_figure} …", flush=True)
            points = _each_file_points(specimens, settings, args)
        from bwbench.problems.hysteresis.control import figure

        with writing(args.laws_figure):
            figure.draw(problem, values, points, args.laws_figure)
        print(f"  parameters against {problem.control_name} -> {args.laws_figure}")
    if not math.isfinite(result.get("mse") or math.inf):
        print("error: the fit found nothing finite", file=sys.stderr)
        return 1
    return 0


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
