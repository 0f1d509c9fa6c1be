"""The `result.json` document (schema "stratplan.result/1"): the planned controls, per leg.

A contract: with it alone anyone can rebuild every control
`u_k(t) = λ0 + Σ_i λi sin(2iπt/P) + λ_{i+H} cos(2iπt/P)` (leg-local time `t ∈ [0, duration]`)
and re-integrate the model from `start`. Coordinates not prescribed by a goal are `null`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..stratified import PlanResult

SCHEMA = "stratplan.result/1"


def _vec(x: np.ndarray) -> list[float | None]:
    return [None if math.isnan(v) else float(v) for v in np.asarray(x, dtype=float)]


def _optimisation(plan: PlanResult) -> dict[str, Any] | None:
    """Every start of the energy-optimal search (the record keeps them all)."""
    opt = plan.optimisation
    if opt is None:
        return None
    return {
        "method": "feasible SQP, exact Hessian of the Lagrangian",
        "best": opt.best,
        "newton_energy": opt.newton_energy,
        "starts": [
            {
                "index": o.index,
                "from": o.kind,
                "energy": o.energy,
                "goal_error": o.goal_error,
                "projected_gradient": o.projected_gradient,
                "iterations": o.iterations,
                "converged": o.converged,
                "stopped": o.stopped,
                "seconds": o.seconds,
            }
            for o in opt.outcomes
        ],
    }


def result_document(
    plan: PlanResult, scenario: str, model: str, reference_energy: float | None = None
) -> dict[str, Any]:
    """The JSON-ready result of a planned (or failed) sequence."""
    system, settings, basis = plan.system, plan.settings, plan.settings.basis
    legs = []
    for leg in plan.legs:
        legs.append(
            {
                "stratum": leg.stratum,
                "method": leg.method,
                "evaluator": leg.evaluator,
                "active_inputs": [system.inputs[k] for k in leg.active],
                "locked": [system.states[k] for k in leg.locked],
                "t0": leg.t0,
                "duration": leg.duration,
                "start": _vec(leg.start),
                "goal": _vec(leg.goal),
                "end": _vec(leg.end),
                "error": leg.error,
                "converged": leg.converged,
                "iterations": leg.iterations,
                "attempts": leg.attempts,
                "free_coefficients": leg.free_coefficients,
                "energy": leg.energy,
                "pieces": [  # a Newton leg is one piece; a Lie leg one piece per step
                    {
                        "t0": t0,
                        "duration": duration,
                        "basis": {
                            "kind": "fourier",
                            "harmonics": basis.harmonics,
                            "period": basis.period,
                        },
                        "coefficients": {
                            system.inputs[k]: np.asarray(coefficients)[a].tolist()
                            for a, k in enumerate(leg.active)
                        },
                    }
                    for t0, duration, coefficients in leg.piece_list()
                ],
            }
        )
    switches = [
        {
            "time": sw.time,
            "after_leg": sw.after_leg,
            "jump": {u: float(sw.jump[k]) for k, u in enumerate(system.inputs)},
            "jump_derivative": {
                u: float(sw.jump_derivative[k]) for k, u in enumerate(system.inputs)
            },
        }
        for sw in plan.switches
    ]
    return {
        "schema": SCHEMA,
        "scenario": scenario,
        "status": "ok" if plan.ok else "failed",
        "message": plan.message,
        "model": model,
        "coordinates": list(system.states),
        "inputs": list(system.inputs),
        "start": _vec(plan.start),
        "goal": _vec(plan.goal),
        "end": _vec(plan.legs[-1].end) if plan.legs else None,
        "total_energy": plan.total_energy,
        "reference_energy": reference_energy,
        "duration": plan.duration,
        "continuity": settings.continuity,
        "soft_start": settings.soft_start,
        "full_stop": settings.full_stop,
        "tolerance": settings.tolerance,
        "seed": settings.seed,
        "objective": settings.objective,
        "time_scale": plan.time_scale,
        "notes": list(getattr(plan, "notes", [])),  # e.g. how the objective was applied
        "optimisation": _optimisation(plan),
        "legs": legs,
        "switches": switches,
    }
