"""``bwbench models``: the registered hysteresis models, their formulations and parameters."""

from __future__ import annotations

import argparse


def list_models(args) -> int:
    import sys

    from bwbench.models import registry

    for line in registry.broken().values():  # the others are listed; this one is named with its error
        print(f"warning: {line}", file=sys.stderr)
    for name, model in registry.available().items():
        default = " (default)" if name == registry.DEFAULT else ""
        print(f"{name}{default}: {model.title}")
        print(f"  reference: {model.reference}")
        if model.states:
            print(f"  state conventions: {', '.join(model.states)} (default {model.states[0]})")
        formulations = ", ".join(
            f + (" (default)" if f == model.default_formulation else "") for f in model.formulations
        )
        print(f"  formulations: {formulations}")
        state = model.states[0] if model.states else None
        print(f"  {model.direct_name} parameters: " + ", ".join(p.text for p in model.direct_parameters(state)))
        if model.has_linear_part:
            layout = model.linear_layout(state)
            print(
                "  identifiable: searched "
                + ", ".join(p.text for p in model.hysteretic_parameters(state))
                + "; solved "
                + ", ".join(f"{n} ({layout.units[n]})" for n in layout.names)
                + (" per branch (ẋ ≥ 0, ẋ < 0)" if layout.branched else "")
            )
        # the keys a --bounds file, --law and a result JSON use
        names = f"  names: {model.direct_name} " + " ".join(p.name for p in model.direct_parameters(state))
        if model.has_linear_part:
            from bwbench.problems.hysteresis.linear.columns import coefficient_names

            names += "; identifiable " + " ".join(p.name for p in model.hysteretic_parameters(state))
            names += ", solved " + " ".join(coefficient_names(model.linear_layout(state)))
        print(names)
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.set_defaults(func=list_models)
