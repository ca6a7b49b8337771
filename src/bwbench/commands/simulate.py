"""``bwbench simulate``, ``evaluate`` and ``identifiability``: a model on one specimen, no optimiser; the
options of a model and of a fit that ``fit`` and ``compare`` share."""

from __future__ import annotations

import argparse
import math

import numpy as np

from bwbench.data import strict_json

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
    """Model, formulation (the model's own when none is given: a parameter file is read in it), state
    and excitation of a command's arguments, checked (``UserError``)."""
    from bwbench.models import registry
    from bwbench.problems.hysteresis.setup import checked_settings

    settings = checked_settings(
        model=args.model, formulation=args.formulation, state=args.state, excitation=args.excitation
    )
    if settings["formulation"] is None:
        settings["formulation"] = registry.get(settings["model"]).default_formulation
    return settings


def add_fit_options(p) -> None:
    """The options of a fit that a study shares (``fit`` and ``compare``): the mass, the weights and the
    start of every record."""
    from bwbench.models.start import INITIAL_STATES

    p.add_argument(
        "--initial-state",
        choices=INITIAL_STATES,
        help="how every model starts each record, the same for all: auto (default: from rest when the record "
        "starts from rest, else after a pre-roll of one cycle of its own motion, left out of the loss), rest, "
        "or pre-roll",
    )
    p.add_argument(
        "--warmup",
        metavar="SECONDS",
        help="the first SECONDS of each record are simulated but left out of the loss, the errors and the "
        "checks (shaded in the figure); default 0",
    )
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


def setup_from_args(args, formulation_from_data: bool = False):
    """The ``FitSetup`` (``problems.hysteresis.setup``) of ``args.specimen`` (one file, or a list: a
    joint fit) with the command's model, formulation, state, excitation, ``--bounds``, ``--fix-mass``,
    ``--offsets`` and ``--weighting`` where it has them. ``formulation_from_data``: with no
    ``--formulation``, choose it from the data (``fit``); otherwise the model's own (a parameter file
    is read in it)."""
    import sys

    from bwbench.problems.hysteresis.setup import setup_fit

    formulation = args.formulation
    if formulation is None and not formulation_from_data:
        formulation = model_settings(args)["formulation"]
    paths = args.specimen if isinstance(args.specimen, list) else [args.specimen]
    return setup_fit(
        paths,
        model=args.model,
        formulation=formulation,
        state=args.state,
        excitation=args.excitation,
        fix_mass=getattr(args, "fix_mass", None) or "auto",
        offsets=getattr(args, "offsets", None),
        weighting=getattr(args, "weighting", None),
        bounds=getattr(args, "bounds", None) or None,
        force_needed=getattr(args, "func", None) not in (simulate, evaluate),
        log=sys.stdout,
        control=getattr(args, "control", None),
        laws=getattr(args, "law", None),
        control_filter=getattr(args, "control_filter", False),
        law_search=(args.optimizer, args.budget, args.seed) if hasattr(args, "optimizer") else None,
        initial_state=getattr(args, "initial_state", None) or "auto",
        warmup=getattr(args, "warmup", None) or 0.0,
    )


def read_for(path, problem):
    """The parameters of ``path`` in ``problem``'s coordinates: its own names, or the model's direct
    parameters mapped into the identifiable formulation when that is the problem's."""
    from bwbench.errors import InputFileError, UserError
    from bwbench.models.switched.parameters import read_json

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
    problem = setup_from_args(args).problem
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
    problem = setup_from_args(args).problem
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
    problem = setup_from_args(args).problem  # refuses a force of 0: every sensitivity would be 0, only NaN to report
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
