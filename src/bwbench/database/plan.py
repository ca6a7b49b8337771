"""How many runs a stored study configuration plans (the ranking, the posterior and the held-out
predictions), for a report of a study that is still running or was stopped."""

from __future__ import annotations


def planned_from_config(config: dict) -> int | None:
    """The number of runs of a stored configuration (``config_json``), if it lists its specimens."""
    try:
        study, optimizers, specimens = config["study"], config["optimizers"], config["specimens"]
        # {"files": [names]} (older studies, the benchmark) or {name: SHA-256}
        files = specimens["files"] if "files" in specimens else [s for s, h in specimens.items() if isinstance(h, str)]
        if not files:
            return None
        formulation = study.get("formulation", "paper")
        model = study.get("model")
        models = len(set(model)) if isinstance(model, list) else 1
        variants = (len(formulation) if isinstance(formulation, list) else 1) * models
        planned = _count(study["seeds"]) * len(files) * len(optimizers) * variants
        posterior = config.get("posterior")
        if posterior:
            samplers = posterior.get("optimizer")
            planned += (
                _count(posterior["seeds"])
                * len(posterior["specimens"])
                * models
                * (len(samplers) if isinstance(samplers, list) else 1)
            )
    except (KeyError, TypeError, ValueError):
        return None
    return planned


def _count(value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"not a count: {value!r}")
    return value
