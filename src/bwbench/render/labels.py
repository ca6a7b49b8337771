"""Run labels: ``"cmaes"`` or ``"cmaes [identifiable]"`` — a backend, and the variant of the problem
it ran on when a study compares variants side by side (formulations today; models could be the
same). Nothing here knows which variants exist: they are whatever the brackets hold.
"""

from __future__ import annotations

import re

BASELINE = "random"  # the backend that is the baseline in every variant: compared, never recommended

_LABEL = re.compile(r"^(?P<backend>.*?)\s*\[(?P<variant>[^\]]+)\]\s*$")


def split_label(label: str) -> tuple[str, str | None]:
    """``"cmaes [paper]"`` → ``("cmaes", "paper")``; ``"cmaes"`` → ``("cmaes", None)``."""
    match = _LABEL.match(str(label))
    return (match["backend"], match["variant"]) if match else (str(label), None)


def is_baseline(label: str) -> bool:
    """Whether the label ran the baseline backend (random search), in whichever variant."""
    return split_label(label)[0] == BASELINE


def variants(labels) -> list[str]:
    """The variants among ``labels``, in order of first appearance (empty when none has one)."""
    return list(dict.fromkeys(v for _, v in map(split_label, labels) if v is not None))


def variant_noun(settings: dict) -> str:
    """What the study's variants are called: the ``[study]`` key that lists them ("formulation",
    or e.g. "model"), else "variant"."""
    for key in ("formulation", "model"):
        if isinstance(settings.get(key), list) and len(settings[key]) > 1:
            return key
    return "variant"
