"""Custom models' legs planned on the quadrature path, checked against an ODE integration
(no I/O).

The quadrature end point integrates a leg's vector fields at Gauss nodes: exact for the smooth
fields of a robot, but a custom model's fields may blow up along the path (`1/(x - 0.5)` with x
crossing 0.5), where the quadrature sums across the pole as if it were not there and reports
the goal reached while no motion gets there. Each such leg that reached its goal is
integrated once more with DOP853 (`simulate.integrate_leg`, a bounded integration that fails
on a blow-up): where that fails, or ends elsewhere than the quadrature, the leg failed
numerically and the plan says why (the first such leg; the legs after it are kept as
planned). Robots (planar and URDF) have smooth fields and are not integrated again here.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .leg_failures import failure_message
from .sequence import SequencePlan
from .simulate import RTOL, integrate_leg
from .status import Status

__all__ = ["ode_checked"]

AGREEMENT = 1e3 * RTOL  # relative to the configuration's size: the ODE's own error, and more


def ode_checked(plan: SequencePlan, system) -> SequencePlan:
    """`plan` with each quadrature leg of a custom model that reached its goal integrated
    again; the first whose end that integration does not reach fails the plan."""
    if getattr(system, "robot", None) is not None or getattr(system, "spatial", None) is not None:
        return plan
    legs = list(plan.legs)
    for k, leg in enumerate(legs):
        if leg.evaluator != "quadrature" or not leg.converged:
            continue
        end = integrate_leg(plan, leg, np.array([leg.duration]))[0]
        gap = float(np.abs(end - leg.end).max()) if np.all(np.isfinite(end)) else np.inf
        if gap <= max(plan.settings.tolerance, AGREEMENT * (1.0 + np.abs(leg.end).max())):
            continue
        found = (
            "an ODE integration of its controls breaks down on the way: the fields blow up "
            "along the path, which the quadrature summed across"
            if not np.isfinite(gap)
            else f"an ODE integration of its controls ends {gap:.3g} away from the quadrature's "
            "end point: the fields blow up between its nodes"
        )
        legs[k] = replace(leg, status=Status.NUMERICAL_FAILURE, message=found)
        failed = replace(plan, legs=tuple(legs), message=failure_message(legs[k], plan.settings))
        return failed.with_system(system)
    return plan
