"""bwbench: hysteresis models (the switched Bouc-Wen of Zalewski et al., Spencer's MR-damper model, the
classic Bouc-Wen) identified from force–displacement tests, and a fair comparison of optimisers.

The Python API (``bwbench.api``; imported on first use, so ``import bwbench`` stays cheap):

- ``bwbench.fit(*files, optimizer=..., budget=..., model=..., formulation=...)`` → ``FitResult``:
  one fit, or a joint fit of several files (one parameter set);
- ``FitResult.model`` / ``bwbench.load_fit(path)`` → ``FittedModel``: ``.predict(file)`` (a
  ``Prediction``: RMSE in N, NRMSE, forces) and ``.simulate(file)``, every coefficient as stored;
- ``FitResult.summary()`` / ``.report()`` / ``.correlation()`` / ``.plot()``: standard errors, a text
  report like lmfit's, correlations, a matplotlib Figure; the fit's findings as ``FitWarning`` warnings;
- ``bwbench.compare(config=... | specimens=[...], optimizers=[...], ...)`` / ``bwbench.load_study(db)``
  → ``Study``: ``.runs``, ``.traces``, ``.ranking()``, ``.recommendation``, ``.report(out_dir)``,
  ``.posterior(specimen)``, ``.to_inference_data(specimen)``;
- ``bwbench.UserError``: every bad input, with the command line's one-line message.
"""

from bwbench.version import __version__

__all__ = [
    "fit",
    "load_fit",
    "load_study",
    "compare",
    "FitResult",
    "FittedModel",
    "Prediction",
    "Study",
    "UserError",
    "FitWarning",
    "FitNote",
    "FitFinding",
    "FitBoxWarning",
    "FitFailure",
    "__version__",
]
_API = {
    "fit",
    "load_fit",
    "load_study",
    "compare",
    "FitResult",
    "FittedModel",
    "Prediction",
    "Study",
    "UserError",
    "FitWarning",
    "FitNote",
    "FitFinding",
    "FitBoxWarning",
    "FitFailure",
}


def __getattr__(name):
    if name in _API:
        from bwbench import api

        return getattr(api, name)
    raise AttributeError(f"module 'bwbench' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | _API)
