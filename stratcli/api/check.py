"""The controllability check as users read it: a JSON document and one sentence per problem.

`stratcli.controllability` computes the ranks (paper eq. 2 and 4); this module turns them
into what `stratplan check --json` prints and into the problems that stop `plan` (exit 3).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..controllability import (
    RANK_RTOL,
    leg_reports,
    sample_configurations,
    sequence_report,
    stratum_report,
)
from ..liealgebra import MAX_DEGREE
from ..models.system import System
from ..reachability import Reach, better_strata, reach

__all__ = ["check_document"]


def _number(x: float) -> float | None:
    """A float for JSON: None where it is not finite (NaN is not JSON)."""
    return float(x) if np.isfinite(x) else None


def _where(q: np.ndarray, sampled: bool) -> str:
    return f"q = ({', '.join(f'{x:.4g}' for x in q)})" + (
        ", a sampled configuration" if sampled else ""
    )


def _not_finite(stratum: str, q: np.ndarray, sampled: bool) -> str:
    """The model problem of a stratum whose fields or brackets are not finite at q."""
    return (
        f"the fields of stratum {stratum} or their brackets are not finite (an overflow or a "
        f"division by zero) at {_where(q, sampled)}; check the expressions"
    )


MAX_SAMPLES = 100_000  # configurations `check` samples at most (1e6 took 1 GB and 13 s)


def _vec(q: np.ndarray) -> list[float]:
    return [float(x) for x in np.asarray(q, dtype=float)]


@np.errstate(all="ignore")  # a model that overflows is told in model_problems
def check_document(
    system: System,
    strata: Sequence[str],
    at: np.ndarray,
    *,
    samples: int = 100,
    degree: int = 2,
    seed: int = 0,
    legs=None,
) -> dict:
    """Eq. 4 per stratum, eq. 2 for the strata together and, given a scenario's legs, whether
    each leg's stratum spans the coordinates it steers. `controllable` decides exit code 3:
    for legs, every leg must be spanned; without legs, every stratum strongly controllable.
    Each spanned leg also gets a reachability estimate (`reach`, `stratcli.reachability`);
    a leg that may be ill-conditioned adds a sentence to `warnings` (no exit code)."""
    at = np.asarray(at, dtype=float)
    sampled = sample_configurations(system.n, samples, seed)
    Q = np.vstack([at, sampled])
    reports = [stratum_report(system, s, Q, degree) for s in strata]
    seq = sequence_report(system, strata, Q, degree)
    strata_doc = []
    for r in reports:
        worst = r.worst
        strata_doc.append(
            {
                "stratum": r.stratum,
                "dimension": r.dimension,
                "inputs": r.generators,
                "basis_size": r.basis_size,
                "rank_at": int(r.rank[0]),
                "sigma_min_at": _number(r.sigma[0]),
                "degree_at": int(r.degree_used[0]),
                "rank_at_requested_degree": int(r.rank_requested[0]),
                "min_rank": int(r.rank.min()),
                "min_sigma": _number(r.sigma[worst]),
                "worst_configuration": _vec(r.configurations[worst]),
                "third_order_needed": r.escalated,
                "spanning_at": r.spanning,
                "strong": r.strong,
            }
        )
    doc = {
        "model": system.name,
        "coordinates": list(system.states),
        "degree": degree,
        "samples": samples,
        "seed": seed,
        "at": _vec(at),
        "strata": strata_doc,
        "eq2": {
            "strata": seq.strata,
            "sum_rank_at": int(seq.sum_rank[0]),
            "sum_min_rank": int(seq.sum_rank.min()),
            "holds": seq.eq2,
            "cross_rank_at": None if seq.cross_rank is None else int(seq.cross_rank[0]),
            "cross_min_rank": None if seq.cross_rank is None else int(seq.cross_rank.min()),
            "cross_spanning_at": seq.cross_spanning,
            "by_switching": seq.by_switching,
            "n": system.n,
        },
        "strongly_controllable": all(r.strong for r in reports),
        "stratified_controllable": seq.controllable,
        "legs": None,
        "problems": [],
    }
    problems: list[str] = []
    # the model cannot be evaluated (its fields overflow): bad input, not a rank
    model_problems = [
        _not_finite(r.stratum, Q[k], k > 0)
        for r in reports
        for k in [int(np.argmax(~np.isfinite(r.sigma)))]
        if not np.all(np.isfinite(r.sigma))
    ]
    warnings: list[str] = []
    if legs is not None:
        doc["legs"] = []
        vias = [np.full(system.n, 0.0), *(np.asarray(s.goal, dtype=float) for s in legs[:-1])]
        for leg, spec, via in zip(
            leg_reports(system, at, legs, sampled, degree), legs, vias, strict=True
        ):
            names = [system.states[j] for j in leg.targets]
            estimate = None
            if leg.ok:  # a coordinate the via before leaves free starts where it is not known:
                # not a distance to steer (θ free at a via read as 0 warned of a leg at 1.2e4)
                unknown = np.isnan(via) & ~np.isnan(spec.goal)
                aim = np.where(unknown, leg.configuration, spec.goal)
                estimate = reach(system, leg.stratum, leg.configuration, aim, spec.duration)
            if estimate is not None and estimate.weak:
                warnings.append(_weak_leg(system, leg.index, estimate, leg.configuration, spec))
            doc["legs"].append(
                {
                    "leg": leg.index + 1,
                    "stratum": leg.stratum,
                    "steers": names,
                    "configuration": _vec(leg.configuration),
                    "rank": leg.rank,
                    "sigma_min": _number(leg.sigma),
                    "ok": leg.ok,
                    "failure_configuration": None if leg.ok else _vec(leg.failure),
                    "failure_sampled": leg.failure_sampled,
                    "reach": None if estimate is None else _reach_doc(system, estimate),
                }
            )
            where = _where(leg.failure, leg.failure_sampled) if not leg.ok else ""
            if not leg.ok and not leg.failure_finite:  # not a rank: bad input (exit 2)
                message = _not_finite(leg.stratum, leg.failure, leg.failure_sampled)
                if message not in model_problems:
                    model_problems.append(message)
            elif not leg.ok:
                problems.append(
                    f"leg {leg.index + 1} on {leg.stratum}: its generators and brackets (up to "
                    f"degree {MAX_DEGREE}) span only {leg.failure_rank} of the {len(names)} "
                    f"coordinates it steers ({', '.join(names)}) at {where}; steer fewer "
                    'coordinates on this leg (goal "*"'
                    + _pinned(system, legs, leg.index, leg.targets)
                    + ") or use another stratum"
                    + _inert(system, leg.stratum)
                    + (_huge(system, leg.stratum, leg.failure) or _scaled(leg))
                )
    elif not seq.controllable and not model_problems:
        worst = int(np.argmin(seq.cross_rank if seq.cross_rank is not None else seq.sum_rank))
        q = Q[worst]
        rank = (seq.cross_rank if seq.cross_rank is not None else seq.sum_rank)[worst]
        problems.append(
            f"the strata {', '.join(seq.strata)} together reach only {int(rank)} of "
            f"{system.n} directions at q = ({', '.join(f'{x:.4g}' for x in q)}), even with "
            "brackets across strata (up to degree 3): not stratified controllable (eq. 2)"
        )
    doc["problems"] = problems
    doc["model_problems"] = model_problems
    doc["warnings"] = warnings
    doc["controllable"] = not problems and not model_problems
    return doc


HUGE = 1e12  # a field this large where a rank falls short is near a singularity of it


def _huge(system: System, stratum: str, q) -> str:
    """Where the fields themselves are huge (tan(phi) at phi = pi/2: 1.6e16), the rank falls
    short because one field dwarfs the others, not for want of brackets: say so."""
    try:
        G = system.compiled(stratum).G(np.asarray(q, dtype=float)[None])[0]
    except Exception:  # (a failure to evaluate is reported as a model problem elsewhere)
        return ""
    largest = float(np.abs(G).max(initial=0.0))
    if not np.isfinite(largest) or largest < HUGE:
        return ""
    return (
        f"; its fields reach {largest:.2g} there: a singularity of the model (start or pass "
        "away from it)"
    )


SMALL = 1e-12  # a smallest singular value above this is no rounding of O(1) fields


def _scaled(leg) -> str:
    """Where the leg fails at its start with a smallest singular value that is small but no
    rounding (fields of 1 and 1e-9: a badly scaled model reads as rank-deficient, the rank
    being relative to the largest, `RANK_RTOL`): say so, and how to plan it anyway."""
    if leg.failure_sampled or not SMALL < leg.sigma < np.inf:
        return ""
    return (
        f"; its smallest singular value there is {leg.sigma:.1e}, not zero: at or below "
        f"{RANK_RTOL:g} of the largest it counts as zero, as in a model whose fields differ "
        "that much in scale (rescale its coordinates, or plan with --no-check)"
    )


def _pinned(system: System, legs, index: int, targets) -> str:
    """Which steered coordinates "*" cannot free: the next leg locks them, so this leg must
    end them at the value they keep there (a new user's "*" was there already)."""
    if index + 1 >= len(legs) or legs[index + 1].stratum not in system.strata:
        return ""
    locked = set(system.stratum(legs[index + 1].stratum).locked)
    pinned = [system.states[j] for j in targets if j in locked]
    if not pinned:
        return ""
    them = "it" if len(pinned) == 1 else "them"
    return (
        f"; not {', '.join(pinned)}, whatever its goal says: leg {index + 2} locks {them}, so "
        f"this leg ends {them} where {them} must stay"
    )


def _inert(system: System, stratum: str) -> str:
    """Why a URDF robot's stratum may not turn its base: joints of it that move no mass
    (links without <inertial>), as a clause of the problem; '' if none."""
    robot = getattr(system, "spatial", None)
    inert = set(getattr(robot, "inert_joints", ()))
    names = [system.states[j] for j in system.stratum(stratum).active if system.states[j] in inert]
    if not names:
        return ""
    return (
        f" ({', '.join(names)} {'moves' if len(names) == 1 else 'move'} no mass: the links "
        "it moves have no <inertial> in the URDF, so it cannot turn the base)"
    )


def _reach_doc(system: System, r: Reach) -> dict:
    """A leg's reachability estimate (`stratcli.reachability`) as the check document has it."""
    return {
        "degree": r.degree,
        "hard_coordinate": system.states[r.hard],
        "displacement": r.displacement,
        "leverage": r.leverage,
        "predicted_energy": r.energy,
        "weak": r.weak,
    }


def _weak_leg(system: System, index: int, r: Reach, q: np.ndarray, spec) -> str:
    """The warning of a leg that may be ill-conditioned: why, and what to try instead."""
    why = (
        f"it needs third-order brackets at its start, σ_min {r.sigma:.2g}, and "
        f"|δ|/σ_min = {r.leverage:.3g} along that direction"
        if r.degree >= MAX_DEGREE
        else f"σ_min {r.sigma:.2g}, |δ|/σ_min = {r.leverage:.3g}"
    )
    better = better_strata(system, q, spec.goal, spec.duration, r)
    instead = (
        f"try stratum {better[0].stratum} (predicted energy ~{better[0].energy:.2g}) or auto mode"
        if better
        else "try a via configuration away from the start, or auto mode"
    )
    return (
        f"leg {index + 1} on {r.stratum} may be ill-conditioned: at its start "
        f"{system.states[r.hard]} is hard to move ({why}; energy ~{r.energy:.2g} if it stayed "
        f"that hard: an estimate at the start, which the plan may beat by moving away from "
        f"it); {instead}"
    )
