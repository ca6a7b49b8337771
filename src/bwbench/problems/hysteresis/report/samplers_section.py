"""The report's "Posterior samplers" section: when a study's ``[posterior]`` runs several samplers
(``optimizer = ["nested", "emcee"]``) on the same specimen and budget, each is judged like an optimiser
against the reference posterior, nested sampling's: does it find every mode, with which mass
(``bwbench.analysis.sampler_comparison``), does it pass its own R̂/ESS verdict, in how many evaluations
and how much wall time.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import sampler_comparison
from bwbench.render.labels import split_label

REFERENCE = "nested"


def groups(chains) -> dict:
    """{(specimen, variant): {backend: PosteriorChain}} of the posteriors run by more than one sampler."""
    found: dict = {}
    for pc in chains:
        backend, variant = split_label(pc.chain.optimizer)
        found.setdefault((pc.chain.specimen, variant), {}).setdefault(backend, pc)
    return {key: by_backend for key, by_backend in found.items() if len(by_backend) > 1}


def unit_draws(pc) -> np.ndarray:
    """Every kept draw of a posterior (unit coordinates, (m, d)): all walkers or runs, not one mode."""
    samples = pc.chain.samples[pc.burn :]
    return samples.reshape(-1, samples.shape[2])


def verdict_text(pc) -> str:
    """The sampler's own R̂/ESS verdict: "converged (R̂ 1.003, ESS 812)" or "not converged (…)"."""
    diagnostics = pc.assessment["diagnostics"] if pc.nested is None else [pc.nested.diagnostics]
    r_hat = [float(np.nanmax(d["r_hat"])) for d in diagnostics if d is not None and len(d)]
    ess = [float(np.nanmin(d["ess_bulk"])) for d in diagnostics if d is not None and len(d)]
    numbers = (
        f"worst R̂ {max(r_hat):.3f}, least bulk ESS {min(ess):,.0f}" if r_hat and np.isfinite(max(r_hat)) else "no R̂"
    )
    return f"{'converged' if pc.converged else 'not converged'} ({numbers})"


def comparison_table(by_backend: dict) -> pd.DataFrame:
    """One row per sampler of one (specimen, variant), the reference first."""
    reference = by_backend[REFERENCE]
    rows = []
    for backend in [REFERENCE, *[b for b in by_backend if b != REFERENCE]]:
        pc = by_backend[backend]
        shares = sampler_comparison.mode_shares(reference.chain.samples, reference.nested, unit_draws(pc))
        nfev, wall = pc.run.get("nfev"), pc.run.get("wall_s")
        rows.append(
            {
                "sampler": backend + (" (reference)" if backend == REFERENCE else ""),
                "finds every mode": sampler_comparison.found_text(shares),
                "mass in each mode": sampler_comparison.mass_text(shares),
                "R̂/ESS verdict": verdict_text(pc),
                "evaluations": f"{int(nfev):,}" if _finite(nfev) else "–",
                "wall time (s)": f"{float(wall):,.1f}" if _finite(wall) else "–",
            }
        )
    return pd.DataFrame(rows)


def _finite(value) -> bool:
    try:
        return bool(np.isfinite(float(value)))
    except (TypeError, ValueError):
        return False


def section(report, chains) -> None:
    """The section, when some specimen has posteriors by several samplers; nothing otherwise."""
    compared = groups(chains)
    if not compared:
        return
    doc = report.doc
    doc.h(3, "Posterior samplers")
    doc.p(
        "The samplers of the [posterior] ran on the same specimens with the same budget, and are judged like "
        "optimisers against the reference posterior, nested sampling's (it holds every mode with its mass). A "
        "sampler's draw lies in a reference mode when its nearest reference draw does and is within the "
        "distance that separates the reference's modes; a mode is found when the sampler gives it at least "
        f"{sampler_comparison.FOUND_SHARE:.0%} of its reference mass. The R̂/ESS verdict is each sampler's own "
        "(a sampler stuck in one mode can pass it)."
    )
    for (specimen, variant), by_backend in compared.items():
        title = specimen + (f" [{variant}]" if variant else "")
        if REFERENCE not in by_backend:
            doc.p(f"{title}: no nested-sampling posterior to compare {', '.join(by_backend)} against.")
            continue
        doc.table(comparison_table(by_backend), f"{title}: every sampler against the reference posterior")
        if not by_backend[REFERENCE].nested["converged"]:
            doc.p(
                f"{title}: the reference posterior itself is not converged "
                f"({'; '.join(by_backend[REFERENCE].nested['failed'])}): the masses it gives are provisional."
            )
