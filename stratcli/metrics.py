"""What a candidate sequence's plan is measured by, besides its energy: the largest control
and the largest joint excursion (`peak_and_excursion`), and all of its numbers as the plan will
run under rate and acceleration limits (`as_run`), for the comparison's criteria."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .models.system import System
from .sequence import SequencePlan
from .time_scaling import rate_limited

__all__ = ["as_run", "joint_coordinates", "peak_and_excursion"]

SAMPLES_PER_LEG = 1001  # for peak |u| and joint excursions


def as_run(outcome, constraints):
    """A plan that reached its goals under rate or acceleration limits, measured as it will
    run: slowed by the s ≤ 1 that meets them (energy × s, duration / s, peak |u| × s; the
    path, so its excursion, and the energy at equal duration stay). Each candidate is slowed
    by its own s, so a ranking by duration or peak control must see it."""
    if constraints is None or outcome.plan is None or not outcome.plan.ok:
        return outcome
    s, _ = rate_limited(outcome.plan, constraints)  # 1 without rate or acceleration limits
    if s >= 1.0:
        return outcome
    return replace(
        outcome,
        energy=outcome.energy * s,
        duration=outcome.duration / s,
        peak_control=outcome.peak_control * s,
    )


def joint_coordinates(system: System, strata: Sequence[str]) -> tuple[int, ...]:
    """Coordinates that are closed-form integrals of the controls on every given stratum."""
    sets = [set(system.compiled(s).explicit) for s in strata]
    return tuple(sorted(set.intersection(*sets))) if sets else ()


def peak_and_excursion(plan: SequencePlan, system) -> tuple[float, float]:
    """max |u_k(t)| and the largest range max_t q_j − min_t q_j over the joints, sampled
    (each leg in its own basis: a plan retried with more harmonics has more than the
    settings')."""
    joints = joint_coordinates(system, [leg.stratum for leg in plan.legs])
    peak = 0.0
    lo = np.full(len(joints), np.inf)
    hi = np.full(len(joints), -np.inf)
    for leg in plan.legs:
        basis = leg.basis
        t = np.linspace(0.0, leg.duration, SAMPLES_PER_LEG)
        u = np.atleast_2d(basis.values(t)) @ leg.coefficients.T  # (samples, m_active)
        peak = max(peak, float(np.abs(u).max(initial=0.0)))
        if joints:
            cs = system.compiled(leg.stratum)
            rows = [cs.explicit.index(j) for j in joints]
            q = leg.start[list(joints)] + (basis.integrals(t) @ leg.coefficients.T) @ (
                cs.C_explicit[rows].T
            )
            lo = np.minimum(lo, q.min(axis=0))
            hi = np.maximum(hi, q.max(axis=0))
    excursion = float((hi - lo).max()) if joints and plan.legs else math.nan
    return peak, excursion
