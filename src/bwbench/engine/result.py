"""One frozen result type for every backend, with a flat ``to_record()`` for pandas."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from bwbench.data import strict_json


@dataclass(frozen=True)
class Result:
    """What one run found. ``params`` in physical units; MSE in N², RMSE in N."""

    optimizer: str
    seed: int
    budget: int
    nfev: int
    params: dict
    mse: float
    success: bool
    message: str
    wall_s: float
    options: dict
    trace_nfev: tuple = ()
    trace_mse: tuple = ()
    problem: dict = field(default_factory=dict)  # e.g. specimen, state, excitation
    extras: dict = field(default_factory=dict)  # backend-specific (emcee chain, ...)
    units: dict = field(default_factory=dict)  # unit of each entry of params the problem knows
    at_bound: dict = field(default_factory=dict)  # searched parameter -> "lower"/"upper" edge it ended on

    @property
    def f_err(self) -> float:
        """The paper's fitness, eq 6: the negative mean squared error."""
        return -self.mse

    @property
    def rmse_N(self) -> float:
        return math.sqrt(self.mse) if math.isfinite(self.mse) else math.inf

    def to_record(self) -> dict:
        """A flat dict of scalars: one row of a tidy results table."""
        record = {
            "optimizer": self.optimizer,
            "seed": self.seed,
            "budget": self.budget,
            "nfev": self.nfev,
            "mse": self.mse,
            "f_err": self.f_err,
            "rmse_N": self.rmse_N,
            "success": self.success,
            "message": self.message,
            "wall_s": self.wall_s,
            **self.problem,
        }
        record.update({name: self.params.get(name, math.nan) for name in self.params})
        return record

    def to_json_dict(self) -> dict:
        """The result JSON of docs/design.md#data-formats (plus the trace and options)."""
        out = {
            "params": self.params,
            "mse": self.mse,
            "f_err": self.f_err,
            "rmse_N": self.rmse_N,
            "nfev": self.nfev,
            "budget": self.budget,
            "optimizer": self.optimizer,
            "seed": self.seed,
            "wall_s": self.wall_s,
            "success": self.success,
            "message": self.message,
            "options": self.options,
            **self.problem,
            "trace": {"nfev": list(self.trace_nfev), "mse": list(self.trace_mse)},
        }
        scalars = {k: v for k, v in self.extras.items() if isinstance(v, (int, float, str, bool))}
        if scalars:
            out["extras"] = scalars
        if self.units:
            out["units"] = self.units
        out["at_bound"] = self.at_bound
        return out

    def write_json(self, path, extra: dict | None = None) -> None:
        """The result as strict JSON (``bwbench.data.strict_json``), with ``extra`` entries added (e.g.
        the checks of a fit): a value that is not finite (a fit that never found a finite loss) is
        written as null, and ``"not_finite"`` says which and why, never NaN or Infinity."""
        strict_json.write(path, {**self.to_json_dict(), **(extra or {})}, why=self.not_finite_reasons())

    def not_finite_reasons(self) -> dict | None:
        """{key: why} of the losses that are not finite, for ``strict_json.write``; None when finite."""
        if math.isfinite(self.mse):
            return None
        nothing = "no evaluation gave a finite loss (the model blows up wherever it was evaluated)"
        return {**dict.fromkeys(("mse", "f_err", "rmse_N"), nothing), "params": f"no best point: {nothing}"}
