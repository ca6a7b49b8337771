"""``bwbench optimizers`` (the registered backends) and ``bwbench fit`` (one specimen, one backend)."""

from __future__ import annotations

import argparse
import json

import bwbench.limits as limits
import bwbench.threads as threads
from bwbench.data.output_paths import check_outputs, writing
from bwbench.errors import UserError


def list_backends(args) -> int:
    """One line per backend (name, family, how it asks, description), then one line per option."""
    import sys

    from bwbench.engine import registry
    from bwbench.engine.options import show

    backends = registry.available()
    for line in registry.broken().values():  # the others are listed; this one is named with its error
        print(f"warning: {line}", file=sys.stderr)
    width = max(len(name) for name in backends)
    for backend in backends.values():
        asks = "populations per call" if backend.batched else "one point per call"
        print(f"{backend.name:<{width}}  {backend.family:<18}  {asks:<20}  {backend.description}")
        if backend.options:
            lines = {key: declaration.describe() for key, declaration in backend.options.items()}
        else:  # a plugin on the untyped contract (defaults=): no type or range to show
            lines = {key: f"untyped, default {show(value)}" for key, value in backend.defaults.items()}
        key_width = max(map(len, lines), default=0)
        for key, text in lines.items():
            print(f"    {key:<{key_width}}  {text}")
        if not lines:
            print("    (no options)")
    return 0


def parse_option(text: str):
    """``key=value`` from the command line; the value is read as JSON when it parses (3, 0.5, true)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise UserError(f"--option takes KEY=VALUE, got {text!r}")
    try:
        return key, json.loads(value)
    except json.JSONDecodeError:
        return key, value


def fit(args) -> int:
    """Exit 0 with the result JSON (and plot); 1 when the fit failed (no evaluation gave a finite loss,
    or the fit is further from the data than the best constant force: the JSON is still written,
    ``findings.failure_reasons``); 2 for a mistake in the input. Several specimens: one joint fit
    (``bwbench.problems.hysteresis.joint_problem``), or with ``--each`` one fit of each in this one
    process (``_fit_each``)."""
    from bwbench.engine import registry

    if args.budget < 1:
        raise UserError(f"--budget must be a positive number of evaluations, got {args.budget}")
    limits.check("--budget", args.budget, "BWBENCH_MAX_BUDGET")
    if args.seed < 0:
        raise UserError(f"--seed must be a non-negative integer, got {args.seed}")
    if getattr(args, "weighting", "equal") != "equal" and (args.each or len(args.specimen) == 1):
        raise UserError(
            f"--weighting {args.weighting} weighs the files of a joint fit; "
            + ("--each fits every file alone" if args.each else "one file has nothing to weigh")
        )
    # Options are checked before the specimen is read or anything runs (fitting.run checks them again).
    options = registry.resolve_options(args.optimizer, dict(parse_option(o) for o in args.option))
    workers = threads.check(args.workers, "--workers")
    threads.check(args.threads)
    from bwbench.commands import control_fit

    controlled = control_fit.wants_control(args)  # one model across a control range (--control, --law)
    if controlled:
        control_fit.check_flags(args)
    if args.each:
        return _fit_each(args, options, workers)
    outputs = {"--out": args.out, "--plot": args.plot, **control_fit.outputs(args)}
    check_outputs(outputs, [*args.specimen, getattr(args, "bounds", None)])
    setup = _read_setup(args)
    status = _fit_setup(args, setup, options, workers, args.out, args.plot)
    return control_fit.after(args, setup, status) if controlled else status


def _read_setup(args):
    """The fit's setup from the command line (reads and checks the specimens and settings)."""
    from bwbench.commands.simulate import setup_from_args

    with threads.limited(args.threads):  # 1 by default: see bwbench.threads
        return setup_from_args(args, formulation_from_data=True)


def _fit_each(args, options, workers: int) -> int:
    """``--each``: one fit of each specimen, with the same options, in this one process (a process pays
    for its libraries' start-up before it reads a file; a lab's dozens of tests pay it once). ``--out``
    and ``--plot`` name folders: each file's result is ``<stem>.json`` (and ``<stem>.png``) there. Every
    file is read and checked, and every output checked, before the first fit. Exit 1 when a fit
    failed (the others are still made)."""
    import time
    from pathlib import Path

    from bwbench.data.output_paths import FIGURE_FORMATS, check_folder
    from bwbench.problems.hysteresis.setup import refuse_same_file
    from bwbench.study import stop

    refuse_same_file(args.specimen)
    stems: dict[str, str] = {}
    for path in args.specimen:
        stem = Path(path).stem
        if stem in stems:
            raise UserError(
                f"{path}: --each writes <name>.json per file, and {stems[stem]} has the same name {stem!r}: "
                "rename one, or fit them in two runs"
            )
        stems[stem] = path
    out_dir, plot_dir = Path(args.out), Path(args.plot) if args.plot else None
    folders = {"--out": out_dir, "--plot": plot_dir}
    for flag, folder in folders.items():
        if folder is None:
            continue
        check_folder(flag, folder)
        if not folder.exists() and folder.suffix.lower() in (".json", *FIGURE_FORMATS):
            raise UserError(
                f"{flag} {folder}: with --each, {flag} names a folder (one file per specimen is written there)"
            )
    runs = []
    for path in args.specimen:  # every file read (and refused, naming it) before any fit
        one = argparse.Namespace(**{**vars(args), "specimen": [path]})
        runs.append((one, _read_setup(one)))
    for folder in {f for f in folders.values() if f is not None}:
        folder.mkdir(parents=True, exist_ok=True)
    outputs: list[tuple[str, str | None]] = []
    for one, _ in runs:
        stem = Path(one.specimen[0]).stem
        out = str(out_dir / f"{stem}.json")
        plot = str(plot_dir / f"{stem}.png") if plot_dir is not None else None
        check_outputs({"--out": out, "--plot": plot}, [*args.specimen, getattr(args, "bounds", None)])
        outputs.append((out, plot))
    started, statuses = time.perf_counter(), []
    for k, ((one, setup), (out, plot)) in enumerate(zip(runs, outputs), start=1):
        print(f"[{k}/{len(runs)}] {one.specimen[0]}")
        statuses.append(_fit_setup(one, setup, options, workers, out, plot))
        stop.kept.append(f"{k} of {len(runs)} fits written in {out_dir} (run the rest with --each on their files)")
    failed = sum(1 for status in statuses if status)
    print(
        f"{len(runs)} fit{'s' if len(runs) > 1 else ''} in {time.perf_counter() - started:.1f} s -> {out_dir}"
        + (f" ({failed} failed)" if failed else "")
    )
    return 1 if failed else 0


def _fit_setup(args, setup, options, workers: int, out: str, plot: str | None) -> int:
    """Fit the problem of ``setup``, write ``out`` (and ``plot``), print what the fit found (its
    ``findings``); the exit status: 1 when the fit failed."""
    import sys

    from bwbench.problems.hysteresis.fit_result import provenance, run_fit

    problem = setup.problem
    extra = {"bounds_file": setup.bounds_file, **provenance(args.specimen, setup.bounds_file)}
    extra["formulation_reason"] = setup.formulation_reason
    if setup.box_probe_s is not None:
        extra["box_probe_s"] = setup.box_probe_s  # not in wall_s, the backend's own time
    from bwbench.render.format import files_text

    where = files_text(args.specimen)  # one line even for a joint fit of dozens of files
    print(f"fitting {where}: {setup.formulation_reason}")
    with threads.for_workers(problem, max(workers, args.threads)):
        fitted = run_fit(
            problem, args.optimizer, args.budget, args.seed, options, setup.synthetic, extra=extra, stop=args.stop
        )
    result = fitted.result
    with writing(out):
        fitted.write_json(out)
    if plot and fitted.success:
        with writing(plot):
            _plot(problem, fitted, plot, setup.synthetic)
    joint = len(fitted.files) > 1
    probe = f" (+ {setup.box_probe_s:.1f} s probing the --bounds box)" if setup.box_probe_s is not None else ""
    accuracy = "" if joint else f", {_nrmse_text(fitted.files[0])}"
    print(
        f"{args.optimizer}: {'loss' if joint else 'MSE'} {result.mse:.4g} N² (F_err {result.f_err:.4g}, RMSE "
        f"{result.rmse_N:.3g} N{accuracy}) in {result.nfev} evaluations{' of every file' if joint else ''}, "
        f"{result.wall_s:.2f} s{probe} -> {out}"
    )
    for row in fitted.files if joint else ():
        print(f"  {row['specimen']}: RMSE {row['rmse_N']:.4g} N, {_nrmse_text(row)} (weight {row['weight']:.3g})")
    names = [str(p) for p in args.specimen] + [spec.name for spec in setup.specimens]
    for finding in fitted.findings:
        if finding.severity in ("warning", "failure"):
            prefix = "error" if finding.severity == "failure" else "warning"
            named = any(finding.text.startswith(f"{n}: ") for n in names)  # a joint fit's file names itself
            print(f"{prefix}: {finding.text}" if named else f"{prefix}: {where}: {finding.text}", file=sys.stderr)
        elif finding.text != setup.formulation_reason:  # said first, above
            print(f"  {finding.line}")
    if not fitted.ok:
        print(f"  the fit failed: {out} written{' with null values' if not fitted.success else ''}, exit status 1")
        return 1
    return 0


def _nrmse_text(row: dict) -> str:
    """Both NRMSEs of a file's row, the literature's named (``fit_result.NRMSE_DEFINITIONS``)."""
    from bwbench.problems.hysteresis.fit_result import nrmse_text

    return nrmse_text(row["nrmse"], row["nrmse_max_F"])


def _plot(problem, fitted, path, synthetic: bool) -> None:
    """One fit: the loops, force and residual of ``plot_fit``; a joint fit: one row per file."""
    if len(fitted.files) == 1:
        from bwbench.problems.hysteresis.report.record_fit_figure import plot_fit  # not report.figures: scipy.stats

        plot_fit(problem, fitted.result, path, synthetic=synthetic)
        return
    from bwbench.problems.hysteresis.report.prediction_figures import plot_predictions

    model = fitted.model
    predictions = [model.predict(spec) for spec in problem.specimens]
    plot_predictions(
        predictions,
        path,
        f"joint fit of {len(predictions)} tests: {model.describe()}\n"
        f"{fitted.result.optimizer}, {fitted.result.nfev} evaluations of every file",
        what="fitted",
        synthetic=synthetic,
    )


def add_list_arguments(parser: argparse.ArgumentParser) -> None:
    parser.set_defaults(func=list_backends)


def add_fit_arguments(parser: argparse.ArgumentParser) -> None:
    from bwbench.commands.simulate import add_fit_options, add_model_options

    parser.add_argument(
        "specimen",
        nargs="+",
        help="specimen CSV; several: one joint fit of them all (one parameter "
        "set; one evaluation simulates every file), or with --each one fit of each",
    )
    parser.add_argument(
        "--each",
        action="store_true",
        help="several specimens: fit each on its own, in this one process (the libraries' "
        "start-up paid once); --out (and --plot) then name folders, holding NAME.json (NAME.png) per file",
    )
    parser.add_argument(
        "--optimizer",
        default="lsq-trf",
        help="backend name (default lsq-trf, as bwbench.fit; see `bwbench optimizers`)",
    )
    parser.add_argument(
        "--budget",
        type=int,
        default=4100,
        help="evaluations (default 4100, the paper's GA); one evaluation simulates every file once",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed, a non-negative integer (default 0)")
    parser.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="backend option, repeatable; VALUE is read as JSON (3, 0.5, true, null, [0.5, 1]), "
        "else as a string (see `bwbench optimizers` for each backend's options and ranges)",
    )
    add_model_options(
        parser,
        formulation_advice="; for data that are not the paper's, use identifiable: the "
        "paper's box fits no other amplitudes or force levels",
    )
    add_fit_options(parser)
    parser.add_argument(
        "--weighting",
        choices=["equal", "samples"],
        default="equal",
        help="joint fit: equal (default) gives each file's MSE the same weight whatever its length; "
        "samples gives every sample the same weight",
    )
    parser.add_argument(
        "--bounds",
        metavar="FILE.json",
        help="a JSON object of name -> [lower, upper]: searched "
        "parameters set the search box (names left out keep the default range), solved coefficients "
        "(m, c+, f-, c1, ...) bound the linear solve",
    )
    parser.add_argument(
        "--stop",
        choices=["agreed", "budget"],
        default="agreed",
        help="agreed (default): a backend that restarts local searches (lsq-trf) stops before the "
        "budget once 3 of them (after at least 9) ended at the best optimum (MSE within 1%%, and the "
        "parameters within 2%% of the box or the fitted curves within 5%% of the residual RMS), "
        "and says so; budget: spend the whole budget, as a study does",
    )
    parser.add_argument("--out", required=True, help="result JSON (with --each: a folder)")
    parser.add_argument(
        "--plot", help="PNG of measured and fitted hysteresis loops and force over time (with --each: a folder)"
    )
    parser.add_argument(
        "--threads", type=int, default=1, help="numba/BLAS threads (default 1: many more are slower on a busy machine)"
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=1,
        help="threads for the independent parts of one evaluation: the files of a joint fit, "
        "else the points of a batch (a Jacobian by differences); the result is the same "
        "as with 1 (default 1: on a busy machine more are slower)",
    )
    from bwbench.commands import control_fit

    control_fit.add_arguments(parser)
    parser.set_defaults(func=fit)
