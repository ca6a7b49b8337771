"""``bwbench predict``, and ``simulate``/``evaluate`` given a fit result: a fitted model with every
coefficient as stored, nothing refitted (``bwbench.problems.hysteresis.fitted_model``).

A fit result names its model, formulation, state and excitation: a flag that contradicts it is
refused (one line naming the flag and what the file says), never silently replaced. A plain
parameter file (names → values, no "formulation") is read in the formulation the flags say; in the
identifiable formulation it must then hold every linear coefficient too, or they are solved on the
data and the output says that this is no prediction.
"""

from __future__ import annotations

import math
import sys

from bwbench.data import strict_json
from bwbench.errors import UserError

BLOWS_UP = "the model blows up with the stored parameters on this file (force not finite)"


def read_fit(path):
    """The JSON of ``path`` when it is a fit result (a "params" object and a "formulation"), else None."""
    from pathlib import Path

    from bwbench.data.json_input import read_json_file

    data = read_json_file(Path(path))
    if isinstance(data, dict) and isinstance(data.get("params"), dict) and "formulation" in data:
        return data
    return None


def stored_model(args, path):
    """The ``FittedModel`` of the fit result ``path`` with the command's flags checked against it; None
    when ``path`` is a plain parameter file. ``UserError`` for a flag that contradicts the file."""
    from bwbench.models import registry
    from bwbench.problems.hysteresis.control.fitted import model_of_result
    from bwbench.problems.hysteresis.formulations import resolve_formulation

    data = read_fit(path)
    if data is None:
        return None
    fitted = model_of_result(data, str(path))
    given = {
        "--model": getattr(args, "model", None),
        "--formulation": getattr(args, "formulation", None),
        "--state": getattr(args, "state", None),
        "--excitation": getattr(args, "excitation", None),
    }
    if given["--formulation"] is not None:
        given["--formulation"] = resolve_formulation(
            registry.get(given["--model"] or fitted.model), given["--formulation"]
        )
    stored = {
        "--model": fitted.model,
        "--formulation": fitted.formulation,
        "--state": fitted.state,
        "--excitation": fitted.excitation,
    }
    for flag, value in given.items():
        if value is not None and value != stored[flag]:
            raise UserError(
                f"{path} is a fit of {fitted.describe()}: {flag} {value} does not match it (drop "
                f"{flag}: a fit result is evaluated as it was fitted, every coefficient as stored)"
            )
    return fitted


def evaluate_stored(args, fitted) -> int:
    """``bwbench evaluate --params FIT.json``: the errors of the stored model on ``--specimen``."""
    prediction = fitted.predict(args.specimen)
    out = {
        "mse": prediction.mse,
        "f_err": -prediction.mse,
        "rmse_N": prediction.rmse_N,
        "nrmse": prediction.nrmse,
        "n": prediction.n,
        "specimen": prediction.specimen,
        **_described(fitted, args.params),
    }
    print(strict_json.dumps(out, why=BLOWS_UP, indent=2))
    return _blown_up(args.specimen, args.params, prediction.mse)


def simulate_stored(args, fitted) -> int:
    """``bwbench simulate --params FIT.json``: the stored model's force on ``--specimen`` as a CSV."""
    from bwbench.data.output_paths import check_outputs, write_frame, writing

    check_outputs({"--out": args.out}, [args.specimen, args.params])
    frame = fitted.simulate(args.specimen)
    with writing(args.out):
        write_frame(frame, args.out, index=False, float_format="%.6g")
    error = frame["force_model_N"] - frame["force_measured_N"]
    mse = float((error**2).mean()) if error.notna().all() else math.inf
    mse = mse if math.isfinite(mse) else math.inf
    print(
        strict_json.dumps(
            {
                "out": str(args.out),
                "mse": mse,
                "f_err": -mse,
                "rmse_N": math.sqrt(mse),
                "n": len(frame),
                **_described(fitted, args.params),
            },
            why=BLOWS_UP,
        )
    )
    return _blown_up(args.specimen, args.params, mse)


def _described(fitted, source) -> dict:
    return {
        "model": fitted.model,
        "formulation": fitted.formulation,
        "state": fitted.state,
        "excitation": fitted.excitation,
        "coefficients": f"as stored in {source}: nothing refitted",
    }


def _blown_up(specimen, params, mse: float) -> int:
    if math.isfinite(mse):
        return 0
    print(
        f"error: {specimen}: the model blows up with the parameters of {params} (force not finite); the JSON says null",
        file=sys.stderr,
    )
    return 1


def _with_control(args, fitted) -> list:
    """The files of a model across a control, each with its control: the fit's column, or ``--control
    NAME=VALUE`` for a file without it (a level no fitted file had is a prediction like any other)."""
    from bwbench.data import control

    spec = control.parse_all(getattr(args, "control", None)) or control.ControlSpec(fitted.control_name)
    if spec.name != fitted.control_name:
        raise UserError(f"--control {spec.name}: {args.fit} is a model across {fitted.control_name}")
    return [control.read(p, spec) for p in args.data]


def predict(args) -> int:
    """``bwbench predict --fit FIT.json DATA.csv ...``: exit 0, 1 when the model blows up on a file, 2
    for a mistake in the input (one line, before anything is written)."""
    from bwbench.data.output_paths import check_outputs, writing
    from bwbench.data.specimen import read_specimen

    check_outputs({"--out": args.out, "--plot": args.plot}, [args.fit, *args.data])
    if read_fit(args.fit) is None:
        raise UserError(
            f'{args.fit}: not a fit result (no "params" and "formulation"): give the JSON that '
            "`bwbench fit --out` wrote"
        )
    fitted = stored_model(args, args.fit)
    specimens = [read_specimen(p) for p in args.data] if not hasattr(fitted, "control") else _with_control(args, fitted)
    from bwbench.data import plausibility

    plausibility.screen(specimens, force_needed=False, warn=False)  # a dead channel refused before any work
    refit = bool(getattr(args, "refit_offset", False))
    predictions = [fitted.predict(s, refit_offset=refit) for s in specimens]
    stored = (
        "every coefficient as stored but the constant force, re-solved on each file (--refit-offset)"
        if refit
        else "every coefficient as stored, nothing refitted"
    )
    if args.out:
        document = {
            "fit": str(args.fit),
            **_described(fitted, args.fit),
            **(
                {"coefficients": f"as stored in {args.fit} but the constant force, re-solved on each file"}
                if refit
                else {}
            ),
            "predictions": [p.metrics() for p in predictions],
        }
        with writing(args.out):
            strict_json.write(args.out, document, why=BLOWS_UP)
    if args.plot:
        from bwbench.data import manifest
        from bwbench.problems.hysteresis.report.prediction_figures import plot_predictions

        with writing(args.plot):
            from pathlib import Path

            plot_predictions(
                predictions,
                args.plot,
                f"prediction by {fitted.describe()} of {Path(args.fit).name}\n{stored}",
                synthetic=all(manifest.is_synthetic(p) for p in args.data),
            )
    # Printed after every file is written: a reader that stops early (``| head -1``) loses no output.
    for p in predictions:
        offset = "" if p.offset_N is None else f"; constant force re-solved on this record: {p.offset_N:+.4g} N"
        print(
            f"{p.specimen}: RMSE {p.rmse_N:.4g} N, NRMSE {p.nrmse:.4g} (RMSE / max|F| = {p.rmse_N:.4g} / "
            f"{float(max(abs(p.measured_N))):.4g} N), {p.n} samples{offset}"
        )
    print(f"predicted by {fitted.describe()} of {args.fit}: {stored}")
    plausibility.print_warnings(specimens)  # data check's words, once every refusal is behind
    blown = [p.specimen for p in predictions if not math.isfinite(p.mse)]
    for name in blown:
        print(f"error: {name}: the fitted model blows up on this record (force not finite)", file=sys.stderr)
    return 1 if blown else 0


def add_arguments(parser) -> None:
    parser.add_argument("data", nargs="+", help="specimen CSV(s) to predict")
    parser.add_argument(
        "--fit", required=True, metavar="FIT.json", help="a result of `bwbench fit` (one file or joint)"
    )
    parser.add_argument(
        "--control",
        action="append",
        metavar="COLUMN[=VALUE]",
        help="a fit across a control (--law): the level of files without the fit's control column "
        "(any level: the laws give the parameters there)",
    )
    parser.add_argument("--out", help="JSON with each file's RMSE (N) and NRMSE (RMSE / max|F|)")
    parser.add_argument("--plot", help="PNG of predicted against measured loops and the residual over time")
    parser.add_argument(
        "--refit-offset",
        action="store_true",
        help="re-solve the constant force on each file (a record from another test set-up, whose load cell "
        "reads another zero); every other coefficient as stored; the output says by how much",
    )
    parser.set_defaults(func=predict)
