"""``bwbench optimizers`` (the registered backends) and ``bwbench fit`` (one specimen, one backend)."""

from __future__ import annotations

import argparse
import json

from bwbench.data.output_paths import check_outputs
from bwbench.errors import UserError


def list_backends(args) -> int:
    from bwbench.optimize import registry

    backends = registry.available()
    width = max(len(name) for name in backends)
    for backend in backends.values():
        defaults = ", ".join(f"{k}={v}" for k, v in backend.defaults.items()) or "-"
        asks = "populations per call" if backend.batched else "one point per call"
        print(f"{backend.name:<{width}}  {backend.family:<18}  {backend.description}")
        print(f"{'':<{width}}  {'':<18}  asks for {asks}; defaults: {defaults}")
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
    """Exit 0 with the result JSON (and plot); 1 when no evaluation gave a finite loss (the JSON is
    still written, with null for what is not finite); 2 for a mistake in the input."""
    import math
    import sys

    from bwbench.data import manifest
    from bwbench.optimize import fitting
    from bwbench.problems.switched_vpp.commands import problem_from_args

    if args.budget < 1:
        raise UserError(f"--budget must be a positive number of evaluations, got {args.budget}")
    check_outputs({"--out": args.out, "--plot": args.plot}, [args.specimen, getattr(args, "bounds", None)])
    problem = problem_from_args(args)
    options = dict(parse_option(o) for o in args.option)
    result = fitting.run(problem, args.optimizer, args.budget, args.seed, options)
    result.write_json(args.out)
    if not math.isfinite(result.mse):
        print(f"error: {args.specimen}: none of the {result.nfev} evaluations gave a finite force: the model blows "
              "up everywhere in the search box on these data (check the units: mm, N, s; and the bounds); "
              f"{args.out} written with null values", file=sys.stderr)
        return 1
    if args.plot:
        from bwbench.problems.switched_vpp.figures import plot_fit

        plot_fit(problem, result, args.plot, synthetic=manifest.is_synthetic(args.specimen))
    print(f"{args.optimizer}: MSE {result.mse:.4g} N² (F_err {result.f_err:.4g}, RMSE {result.rmse_N:.3g} N) "
          f"in {result.nfev} evaluations, {result.wall_s:.2f} s -> {args.out}")
    for note in getattr(problem, "notes", []):
        print(f"  linear solve: {note}")
    return 0


def add_list_arguments(parser: argparse.ArgumentParser) -> None:
    parser.set_defaults(func=list_backends)


def add_fit_arguments(parser: argparse.ArgumentParser) -> None:
    from bwbench.problems.switched_vpp.commands import add_model_options

    parser.add_argument("specimen", help="specimen CSV")
    parser.add_argument("--optimizer", required=True, help="backend name (see `bwbench optimizers`)")
    parser.add_argument("--budget", type=int, default=4100, help="evaluations (default 4100, the paper's GA)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                        help="backend option, repeatable (see `bwbench optimizers`)")
    add_model_options(parser)
    parser.add_argument("--bounds", metavar="FILE.json", help="search box: a JSON object of name -> [lower, upper] "
                                                             "(names left out keep the default range)")
    parser.add_argument("--out", required=True, help="result JSON")
    parser.add_argument("--plot", help="PNG of measured and fitted hysteresis loops and force over time")
    parser.set_defaults(func=fit)
