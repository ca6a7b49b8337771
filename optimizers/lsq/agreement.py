"""When lsq-trf's independent local searches agree on the optimum (a single fit's early stop): the
same place or the same fitted curve, after enough searches that a likely basin was not missed."""

from __future__ import annotations

import numpy as np

# How close (unit coordinates: a fraction of each parameter's search range, in log where the box is) the
# ends of local searches must lie to count as one optimum. The MSE alone is fooled by a plateau: starts
# where the hysteresis does nothing end at the same loss of a linear fit, far apart.
AGREE_UTOL = 0.02


# Searches to run before the fit may stop early: a basin that attracts at least 30 % of random starts is
# then missed by all of them with probability 0.7⁹ < 5 %.
MIN_SEARCHES = 9


# Searches to run before ends that agree only by their fitted curves may stop the fit. Such an optimum is
# a valley or a plateau (where the hysteresis does nothing, every start ends at one linear fit, far
# apart) that attracts starts broadly, and may not be the best: on the VPP specimen pc-abs-c12hf 0.05 MPa
# r3 (identifiable), 45 % of the starts end on a plateau 94× the best MSE, and 1 start in 6 in the best
# valley. After 18 searches a basin attracting 1 start in 6 is missed with probability 0.84¹⁸ < 5 %.
VALLEY_SEARCHES = 18


# How close the fitted curves (model − data, over the whole record) of two ends must be to count as one
# optimum when their parameters are not: RMS of the difference, as a fraction of the best end's residual
# RMS. On the switched model the searches that find the optimum end along a curved valley the data do not
# determine (VPP specimen pc-abs-c12hf 0.05 MPa r3, identifiable: MSE within 0.1 %, unit coordinates up to
# 0.33 apart, a straight segment between them up to 48 % worse in MSE): their fitted curves differ by
# 0.5–1.6 % of the residual RMS; the next optima (MSE +1 %) by 7.6–10 %.
AGREE_FTOL = 0.05


def agreement_rule(rtol: float, same_fit: bool) -> str:
    """The agreement rule in words (the message and ``extras["agreement"]``)."""
    place = f"every searched parameter within {AGREE_UTOL:.3g} of its box"
    if same_fit:
        place = (
            f"either {place} or the fitted curves within {AGREE_FTOL:.3g} of the residual RMS of each "
            f"other (RMS of their difference): one valley along a direction the data do not determine"
        )
        return (
            f"MSE within {rtol:.3g} relative, and {place}; after at least {MIN_SEARCHES} local searches "
            f"({VALLEY_SEARCHES} when ends agree by their fitted curves only)"
        )
    return f"MSE within {rtol:.3g} relative, and {place}; after at least {MIN_SEARCHES} local searches"


def same_optimum(end: tuple, best: tuple, bound: float, share: float = 1.0) -> str:
    """Whether ``end`` (MSE, u[, residuals]) lies at the optimum ``best``: MSE at most ``bound``, and
    "place" (unit coordinates within ``share`` × ``AGREE_UTOL``) or "fit" (both with residuals: the
    fitted curves within ``share`` × ``AGREE_FTOL`` of the best's residual RMS); "" if not."""
    if not end[0] <= bound:
        return ""
    if np.max(np.abs(end[1] - best[1])) <= share * AGREE_UTOL:
        return "place"
    r, r_best = (end[2] if len(end) > 2 else None), (best[2] if len(best) > 2 else None)
    if r is None or r_best is None or r.shape != r_best.shape:
        return ""
    return "fit" if np.mean((r - r_best) ** 2) <= (share * AGREE_FTOL) ** 2 * best[0] else ""


def how_agreed(ends: list[tuple], rtol: float, floor: float = 0.0) -> list[str]:
    """For each finite end, how it agrees with the best one: "place", "fit" or "" (``same_optimum``)."""
    finite = sorted((e for e in ends if np.isfinite(e[0])), key=lambda e: e[0])
    if not finite:
        return []
    best = finite[0]
    return [same_optimum(end, best, best[0] * (1.0 + rtol) + floor) for end in finite]


def agreed_searches(ends: list[tuple], needed: int, rtol: float, floor: float = 0.0) -> int:
    """How many local searches ended at the best optimum, when the search may stop there; else 0.

    Stop when at least ``needed`` (≥ 2) searches ended at the best one and at least ``MIN_SEARCHES``
    searches ran: three starts of three in one local optimum are no evidence that there is no better
    one. An end (MSE, u[, residual vector]) is at the best one (``same_optimum``) when its MSE is
    within ``rtol`` relative (or within ``floor`` for an exact fit, whose MSE is rounding) and either
    every unit coordinate is within ``AGREE_UTOL`` or, where both ends carry their residuals, the
    fitted curves are within ``AGREE_FTOL`` of the residual RMS: the same fit, reached along a
    direction the data do not determine. Two optima of equal MSE but different fits do not agree. When
    fewer than ``needed`` agree by place, the agreement by fit needs ``VALLEY_SEARCHES`` searches."""
    if needed < 2 or len(ends) < MIN_SEARCHES:
        return 0
    how = how_agreed(ends, rtol, floor)
    by_place, agreeing = how.count("place"), len(how) - how.count("")
    if by_place >= needed or (agreeing >= needed and len(ends) >= VALLEY_SEARCHES):
        return agreeing
    return 0
