"""The ``bwbench`` command line (DESIGN.md §5).

A user's mistake (bad file, bad option) prints one line ``error: ...`` on stderr and exits 2;
it never shows a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys

import pandas as pd

from bwbench.errors import UserError


def _cmd_data_check(args) -> int:
    from bwbench.data.specimen import read_specimen

    status = 0
    for path in args.files:
        try:
            spec = read_specimen(path)
        except UserError as err:
            print(f"error: {err}", file=sys.stderr)
            status = 2
        else:
            print(f"ok: {path}: {spec.n_samples} samples, {spec.duration_s:.1f} s")
    return status


def _problem(args):
    from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
    from bwbench.data.specimen import read_specimen

    return SwitchedBoucWenProblem(read_specimen(args.specimen), args.state, args.excitation)


def _check_writable(*paths) -> None:
    """Refuse an output path whose folder does not exist before any work is done, not after."""
    from pathlib import Path

    for path in paths:
        if path is None:
            continue
        folder = Path(path).resolve().parent
        if not folder.is_dir():
            raise UserError(f"cannot write {path}: folder {folder} does not exist")


def _fit_metrics(mse: float, n: int) -> dict:
    return {"mse": mse, "f_err": -mse, "rmse_N": math.sqrt(mse) if math.isfinite(mse) else math.inf, "n": n}


def _cmd_simulate(args) -> int:
    from bwbench.data.parameters import read_json

    _check_writable(args.out)
    params = read_json(args.params)
    problem = _problem(args)
    force = problem.simulate(params)
    s = problem.signal
    frame = pd.DataFrame({
        "time_s": s.t, "displacement_mm": s.x, "velocity_mm_per_s": s.v,
        "acceleration_mm_per_s2": s.a, "force_model_N": force, "force_measured_N": problem.specimen.f,
    })
    frame.to_csv(args.out, index=False, float_format="%.6g")
    mse = float(problem.loss_batch(params[None, :])[0])
    print(json.dumps({"out": str(args.out), **_fit_metrics(mse, len(force))}))
    return 0


def _cmd_evaluate(args) -> int:
    from bwbench.data.parameters import read_json

    params = read_json(args.params)
    problem = _problem(args)
    mse = float(problem.loss_batch(params[None, :])[0])
    out = {**_fit_metrics(mse, problem.specimen.n_samples), **problem.info}
    print(json.dumps(out, indent=2))
    return 0


def _cmd_data_generate(args) -> int:
    from bwbench.data import synthetic

    written = synthetic.generate(args.out)
    print(f"wrote {len(written) - 1} specimens and {synthetic.MANIFEST} to {args.out}")
    return 0


def _cmd_optimizers(args) -> int:
    from bwbench.optimize import registry

    backends = registry.available()
    width = max(len(name) for name in backends)
    for backend in backends.values():
        defaults = ", ".join(f"{k}={v}" for k, v in backend.defaults.items()) or "-"
        print(f"{backend.name:<{width}}  {backend.family:<12}  {backend.description}")
        print(f"{'':<{width}}  {'':<12}  defaults: {defaults}")
    return 0


def _parse_option(text: str):
    """``key=value`` from the command line; the value is read as JSON when it parses (3, 0.5, true)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise UserError(f"--option takes KEY=VALUE, got {text!r}")
    try:
        return key, json.loads(value)
    except json.JSONDecodeError:
        return key, value


def _cmd_fit(args) -> int:
    from bwbench.optimize import fitting
    from bwbench.data import synthetic

    if args.budget < 1:
        raise UserError(f"--budget must be a positive number of evaluations, got {args.budget}")
    _check_writable(args.out, args.plot)
    problem = _problem(args)
    options = dict(_parse_option(o) for o in args.option)
    result = fitting.run(problem, args.optimizer, args.budget, args.seed, options)
    result.write_json(args.out)
    if args.plot:
        from bwbench.problems.switched_vpp.figures import plot_fit

        plot_fit(problem, result, args.plot, synthetic=synthetic.is_synthetic(args.specimen))
    print(f"{args.optimizer}: MSE {result.mse:.4g} N² (F_err {result.f_err:.4g}, RMSE {result.rmse_N:.3g} N) "
          f"in {result.nfev} evaluations, {result.wall_s:.2f} s -> {args.out}")
    return 0


def _add_model_options(p) -> None:
    p.add_argument("--state", choices=["shared", "split"], default="shared",
                   help="hysteretic state convention (default: shared)")
    p.add_argument("--excitation", choices=["measured", "sine"], default="measured",
                   help="measured: the specimen's own displacement (default); sine: the paper's fit")


# Commands whose modules pull in matplotlib, seaborn and scipy.stats (~1 s): their options are
# added only when that command is the one being run, so `bwbench data check` does not pay for them.
# name -> (module, function to call, help)
_HEAVY_COMMANDS = {
    "compare": ("bwbench.study.runner", "main", "run or resume a study: specimens × backends × seeds"),
    "report": ("bwbench.report.build", "cli_main", "figures, statistics and recommendation of a study"),
    "identifiability": ("bwbench.analysis.identifiability", "cli_main", "which parameters a specimen cannot pin down"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The full parser; a heavy command's options are only added when ``command`` names it."""
    parser = argparse.ArgumentParser(prog="bwbench", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    data = sub.add_parser("data", help="check or regenerate specimen files")
    data_sub = data.add_subparsers(dest="data_command", required=True)
    check = data_sub.add_parser("check", help="validate specimen CSV files")
    check.add_argument("files", nargs="+", help="specimen CSV files")
    check.set_defaults(func=_cmd_data_check)
    generate = data_sub.add_parser("generate", help="rebuild the synthetic dataset, byte-identical")
    generate.add_argument("--out", default=str(_default_specimen_dir()), help="output folder")
    generate.set_defaults(func=_cmd_data_generate)

    simulate = sub.add_parser("simulate", help="model force for a parameter set on a specimen")
    simulate.add_argument("--params", required=True, help="parameters JSON (the 14 names)")
    simulate.add_argument("--specimen", required=True, help="specimen CSV")
    _add_model_options(simulate)
    simulate.add_argument("--out", required=True, help="output CSV")
    simulate.set_defaults(func=_cmd_simulate)

    evaluate = sub.add_parser("evaluate", help="MSE, F_err and RMSE of a parameter set on a specimen")
    evaluate.add_argument("--params", required=True, help="parameters JSON (the 14 names)")
    evaluate.add_argument("--specimen", required=True, help="specimen CSV")
    _add_model_options(evaluate)
    evaluate.set_defaults(func=_cmd_evaluate)

    optimizers = sub.add_parser("optimizers", help="list the registered optimiser backends")
    optimizers.set_defaults(func=_cmd_optimizers)

    fit = sub.add_parser("fit", help="fit one specimen with one optimiser")
    fit.add_argument("specimen", help="specimen CSV")
    fit.add_argument("--optimizer", required=True, help="backend name (see `bwbench optimizers`)")
    fit.add_argument("--budget", type=int, default=4100, help="evaluations (default 4100, the paper's GA)")
    fit.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    fit.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                     help="backend option, repeatable (see `bwbench optimizers`)")
    _add_model_options(fit)
    fit.add_argument("--out", required=True, help="result JSON")
    fit.add_argument("--plot", help="PNG of measured and fitted hysteresis loops and force over time")
    fit.set_defaults(func=_cmd_fit)

    for name, (module_name, function, help_text) in _HEAVY_COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text)
        if name == command:
            module = importlib.import_module(module_name)
            module.add_arguments(command_parser)
            command_parser.set_defaults(func=getattr(module, function))
    return parser


def _default_specimen_dir():
    from bwbench.data.synthetic import SPECIMEN_DIR

    return SPECIMEN_DIR


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    args = build_parser(command).parse_args(argv)
    try:
        return args.func(args)
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # a disk full or a permission refused while writing: still one line
        print(f"error: {err.filename or ''}: {err.strerror or err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
