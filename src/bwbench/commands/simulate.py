"""``bwbench simulate``, ``evaluate`` and ``identifiability``: a model on one specimen, no optimiser; the
options of a model and of a fit that ``fit`` and ``compare`` share."""

from __future__ import annotations

import argparse
import math

import numpy as np

from bwbench.data import strict_json
from bwbench.problems.hysteresis.settings import (  # noqa: F401  (fit and compare import them from here)
    check_fit_flags,
    checked_settings,
    fix_mass_value,
    refuse_same_file,
)

MAX_GRID = 1000  # profile points per parameter: each is a local fit of ~15 iterations
BLOWS_UP = "the model blows up with these parameters on this specimen (force not finite)"
WALK_BLOWS_UP = "the walk along this direction reached parameters where the model blows up"


def add_model_options(p, formulation_advice: str = "") -> None:
    p.add_argument("--model", help="the model (default switched-bouc-wen; see `bwbench models`)")
    p.add_argument(
        "--state",
        choices=["shared", "split"],
        help="hysteretic state convention of the switched model (default: shared)",
    )
    p.add_argument(
        "--excitation",
        choices=["measured", "sine"],
        help="measured: the specimen's own displacement (default); sine: the paper's fit",
    )
    p.add_argument(
        "--formulation",
        choices=["paper", "direct", "identifiable"],
        help="paper/direct: the model's own parameters in its box; identifiable: symmetry-free "
        "parameters in a box scaled from the data, linear coefficients solved (default: the "
        "model's own: paper for the switched model, identifiable for the others)" + formulation_advice,
    )


def model_settings(args) -> dict:
    """Model, formulation, state and excitation of a command's arguments, checked (``UserError``)."""
    return checked_settings(args.model, args.formulation, args.state, args.excitation)


def add_fit_options(p) -> None:
    """The options of a fit that a study shares (``fit`` and ``compare``): the mass and the weights."""
    p.add_argument(
        "--fix-mass",
        metavar="VALUE",
        help="identifiable formulation: the inertia m in N·s²/mm (1 = 1 t): a number fixes it, 'fit' "
        "always fits it (within [0, 1] unless --bounds says otherwise), 'auto' (default) fits it "
        "only where the data separate it from the stiffness (never on one sine test)",
    )
    p.add_argument(
        "--offsets",
        choices=["branch", "continuous"],
        help="identifiable formulation, switched model: a constant force per branch (branch, default: "
        "a friction-like force that switches at a reversal) or one for both (continuous: no jump)",
    )


def problem_from_args(args):
    """The problem of ``args.specimen`` (one file, or a list: a joint fit) with the command's model,
    formulation, state, excitation, ``--bounds``, ``--fix-mass`` and ``--weighting`` where it has them."""
    from bwbench.data import bounds as bounds_mod
    from bwbench.data.specimen import read_specimen
    from bwbench.problems.hysteresis.formulations import bound_names, make_problem

    settings = model_settings(args)
    if getattr(args, "bounds", None):
        names = bound_names([settings["formulation"]], settings["state"], [settings["model"]])
        settings["bounds"] = bounds_mod.read_json(args.bounds, names)
    mass = fix_mass_value(getattr(args, "fix_mass", None))
    check_fit_flags(settings, mass, getattr(args, "offsets", None), getattr(args, "weighting", None))
    if mass != "auto":
        settings["fix_mass"] = mass
    if getattr(args, "offsets", None):
        settings["offsets"] = args.offsets
    if getattr(args, "weighting", None):
        settings["weighting"] = args.weighting
    paths = args.specimen if isinstance(args.specimen, list) else [args.specimen]
    refuse_same_file(paths)
    specimens = [read_specimen(p) for p in paths]
    # data check's plausibility checks, before any work: a dead channel (or, for a fit or an analysis of
    # the force, no force) refused with the file named, the rest warned about
    from bwbench.data import plausibility

    plausibility.screen(specimens, force_needed=getattr(args, "func", None) not in (simulate, evaluate), warn=False)
    problem = make_problem(specimens if len(specimens) > 1 else specimens[0], settings)
    if "bounds" in settings:
        import time

        start = time.perf_counter()
        print(
            f"probing the search box of --bounds {args.bounds} ({bounds_mod.PROBE_CORNERS} corners, one "
            f"evaluation each) …",
            flush=True,
        )
        bounds_mod.refuse_if_blows_up(problem, f"--bounds {args.bounds}")
        problem.box_probe_s = time.perf_counter() - start
        print(f"probing the search box: done in {problem.box_probe_s:.1f} s", flush=True)
    return problem


def read_for(path, problem):
    """The parameters of ``path`` in ``problem``'s coordinates: its own names, or the model's direct
    parameters mapped into the identifiable formulation when that is the problem's."""
    from bwbench.errors import InputFileError, UserError
    from bwbench.models.switched_parameters import read_json

    try:
        return read_json(path, problem.param_names)
    except InputFileError as err:
        if getattr(problem, "formulation", "paper") != "identifiable":
            raise
        direct_names = [p.name for p in problem.model.direct_parameters(problem.state)]
        try:
            direct = read_json(path, direct_names)
        except InputFileError:
            raise err from None
    try:
        return np.asarray(problem.model.from_direct(direct, problem.state)[0], dtype=float)
    except ValueError as why:
        raise UserError(f"{path}: {why}") from None


def fit_metrics(mse: float, n: int) -> dict:
    return {"mse": mse, "f_err": -mse, "rmse_N": math.sqrt(mse) if math.isfinite(mse) else math.inf, "n": n}


def _stored(args):
    """The ``FittedModel`` to evaluate: the fit result of ``--params`` (flags checked against it), or a
    plain parameter file that holds every coefficient of the identifiable formulation; else None."""
    from bwbench.commands.predict import stored_model

    fitted = stored_model(args, args.params)
    if fitted is not None or (model_settings(args)["formulation"] != "identifiable"):
        return fitted
    from bwbench.data.json_input import read_json_file
    from bwbench.errors import UserError
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    values = read_json_file(args.params)
    if not isinstance(values, dict):
        return None
    settings = model_settings(args)
    try:
        return FittedModel(settings["model"], "identifiable", values, settings["state"], settings["excitation"])
    except (UserError, TypeError):  # not every coefficient: they are solved on the specimen (said in the output)
        return None


SOLVED = "solved on this specimen by least squares (the file has no linear coefficients): a fit, not a prediction"


def simulate(args) -> int:
    import pandas as pd

    from bwbench.commands.predict import simulate_stored
    from bwbench.data.output_paths import check_outputs, write_frame, writing

    fitted = _stored(args)
    if fitted is not None:
        return simulate_stored(args, fitted)
    check_outputs({"--out": args.out}, [args.specimen, args.params])
    problem = problem_from_args(args)
    params = read_for(args.params, problem)
    force = problem.simulate(params)
    s = problem.signal
    frame = pd.DataFrame(
        {
            "time_s": s.t,
            "displacement_mm": s.x,
            "velocity_mm_s": s.v,
            "acceleration_mm_s2": s.a,
            "force_model_N": force,
            "force_measured_N": problem.specimen.f,
        }
    )
    with writing(args.out):
        write_frame(frame, args.out, index=False, float_format="%.6g")
    mse = float(problem.loss_batch(params[None, :])[0])
    extra = {"linear_coefficients": SOLVED} if problem.formulation == "identifiable" else {}
    print(strict_json.dumps({"out": str(args.out), **fit_metrics(mse, len(force)), **extra}, why=BLOWS_UP))
    return _not_finite(args, mse)


def evaluate(args) -> int:
    from bwbench.commands.predict import evaluate_stored

    fitted = _stored(args)
    if fitted is not None:
        return evaluate_stored(args, fitted)
    problem = problem_from_args(args)
    params = read_for(args.params, problem)
    mse = float(problem.loss_batch(params[None, :])[0])
    extra = {"linear_coefficients": SOLVED} if problem.formulation == "identifiable" else {}
    print(
        strict_json.dumps(
            {**fit_metrics(mse, problem.specimen.n_samples), **problem.info, **extra}, why=BLOWS_UP, indent=2
        )
    )
    return _not_finite(args, mse)


def _not_finite(args, mse: float) -> int:
    """1 with one line when these parameters blow the model up on this specimen, else 0."""
    if math.isfinite(mse):
        return 0
    import sys

    print(
        f"error: {args.specimen}: the model blows up with the parameters of {args.params} (force not finite); "
        "the JSON above says null",
        file=sys.stderr,
    )
    return 1


def add_simulate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--params",
        required=True,
        help="a fit result (its model, formulation and every coefficient "
        "as stored), or a parameters JSON (names -> values, in the formulation the flags say)",
    )
    parser.add_argument("--specimen", required=True, help="specimen CSV")
    add_model_options(parser)
    parser.add_argument("--out", required=True, help="output CSV")
    parser.set_defaults(func=simulate)


def add_evaluate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--params",
        required=True,
        help="a fit result (its model, formulation and every coefficient "
        "as stored), or a parameters JSON (names -> values, in the formulation the flags say)",
    )
    parser.add_argument("--specimen", required=True, help="specimen CSV")
    add_model_options(parser)
    parser.set_defaults(func=evaluate)


def add_identifiability_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("specimen", help="specimen CSV")
    parser.add_argument("--params", required=True, help="parameters JSON (the 14 names, or a fit result)")
    add_model_options(parser)
    parser.add_argument("--bounds", metavar="FILE.json", help="search box: a JSON object of name -> [lower, upper]")
    parser.add_argument(
        "--profile",
        action="append",
        default=[],
        metavar="NAME",
        help="also profile this parameter (repeatable; e.g. wn-)",
    )
    parser.add_argument("--grid", type=int, default=9, help="profile grid points over the range (default 9)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.set_defaults(func=identifiability)


def _settings_from_fit(args) -> None:
    """When ``--params`` is a fit result, the model, formulation, state and excitation it was fitted with
    stand in for the flags not given (a flag that contradicts it is refused): a Spencer fit is analysed as
    Spencer's model without ``--model spencer``."""
    from bwbench.commands.predict import stored_model

    fitted = stored_model(args, args.params)
    if fitted is None:
        return
    args.model = args.model or fitted.model
    args.formulation = args.formulation or (
        "paper" if fitted.formulation in ("paper", "direct") else fitted.formulation
    )
    args.state = args.state or fitted.state
    args.excitation = args.excitation or fitted.excitation


def identifiability(args) -> int:
    """``bwbench identifiability S.csv --params P.json [--json]``; raises ``UserError`` for bad input."""
    import sys

    from bwbench.data import bounds as bounds_mod
    from bwbench.errors import UserError
    from bwbench.problems.hysteresis.identifiability import analyse, format_text

    if not 2 <= args.grid <= MAX_GRID:
        raise UserError(f"--grid must be 2 to {MAX_GRID} points (each is a local fit), got {args.grid}")
    _settings_from_fit(args)
    problem = problem_from_args(args)  # refuses a force of 0: every sensitivity would be 0, only NaN to report
    params = read_for(args.params, problem)
    box = bounds_mod.read_json(args.bounds, problem.param_names) if args.bounds else None
    settings = model_settings(args)
    result = analyse(
        args.specimen,
        params,
        settings["state"],
        settings["excitation"],
        formulation=settings["formulation"],
        model=settings["model"],
        bounds=box,
        profile_names=args.profile,
        grid=args.grid,
    )
    if args.json:  # strict JSON, whole or nothing: a value that is not finite is null
        sys.stdout.write(strict_json.dumps(result, why={"null_directions": WALK_BLOWS_UP}, indent=2) + "\n")
    else:
        print(format_text(result))
    from bwbench.data import manifest, plausibility

    plausibility.print_warnings([problem.specimen], manifest.is_synthetic(args.specimen))  # data check's words
    return 0
