"""The controllability check as users read it: a JSON document and one sentence per problem.

`stratcli.controllability` computes the ranks (paper eq. 2 and 4); this module turns them
into what `stratplan check --json` prints and into the problems that stop `plan` (exit 3).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..controllability import (
    leg_reports,
    sample_configurations,
    sequence_report,
    stratum_report,
)
from ..liealgebra import MAX_DEGREE
from ..models.system import System

__all__ = ["check_document"]


def _vec(q: np.ndarray) -> list[float]:
    return [float(x) for x in np.asarray(q, dtype=float)]


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
    for legs, every leg must be spanned; without legs, every stratum strongly controllable."""
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
                "sigma_min_at": float(r.sigma[0]),
                "degree_at": int(r.degree_used[0]),
                "rank_at_requested_degree": int(r.rank_requested[0]),
                "min_rank": int(r.rank.min()),
                "min_sigma": float(r.sigma[worst]),
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
    if legs is not None:
        doc["legs"] = []
        for leg in leg_reports(system, at, legs, sampled, degree):
            names = [system.states[j] for j in leg.targets]
            doc["legs"].append(
                {
                    "leg": leg.index + 1,
                    "stratum": leg.stratum,
                    "steers": names,
                    "configuration": _vec(leg.configuration),
                    "rank": leg.rank,
                    "sigma_min": leg.sigma,
                    "ok": leg.ok,
                    "failure_configuration": None if leg.ok else _vec(leg.failure),
                }
            )
            if not leg.ok:
                problems.append(
                    f"leg {leg.index + 1} on {leg.stratum}: its generators and brackets (up to "
                    f"degree {MAX_DEGREE}) span only {leg.failure_rank} of the {len(names)} "
                    f"coordinates it steers ({', '.join(names)}) at q = "
                    f"({', '.join(f'{x:.4g}' for x in leg.failure)}); steer fewer coordinates "
                    'on this leg (goal "*") or use another stratum'
                )
    elif not seq.controllable:
        worst = int(np.argmin(seq.cross_rank if seq.cross_rank is not None else seq.sum_rank))
        q = Q[worst]
        rank = (seq.cross_rank if seq.cross_rank is not None else seq.sum_rank)[worst]
        problems.append(
            f"the strata {', '.join(seq.strata)} together reach only {int(rank)} of "
            f"{system.n} directions at q = ({', '.join(f'{x:.4g}' for x in q)}), even with "
            "brackets across strata: not stratified controllable (eq. 2)"
        )
    doc["problems"] = problems
    doc["controllable"] = not problems
    return doc
