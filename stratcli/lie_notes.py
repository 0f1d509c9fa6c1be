"""The note of a Lie-algebraic leg that swings a joint far beyond the move it was asked for
(no I/O).

A Lie leg's steps are local loops planned where the system is (`planners.lie`): on the
paper's task they keep the arm close to where it is, but a motion only a bracket gives can
take loops that swing a joint through many radians (a leg asked to move q3 by 0.1 rad swung
it through 14, at 2397 where a Newton leg costs 18). The plan says so, with what to try.
"""

from __future__ import annotations

import numpy as np

from .metrics import joint_coordinates
from .sequence import SequencePlan
from .simulate import integrate_leg

__all__ = ["far_swings"]

SAMPLES = 400  # per Lie leg, on an independent integration (`simulate.integrate_leg`)
FAR = 10.0  # a joint's range this many times the leg's largest move is noted ...
AT_LEAST = 1.0  # ... if it is at least this (rad)


def far_swings(plan: SequencePlan, system) -> tuple[str, ...]:
    """A note per Lie leg that reached its goal and swung a joint through at least `FAR` times
    its largest joint move (and `AT_LEAST` rad)."""
    notes = []
    for leg in plan.legs:
        if leg.method != "lie" or not leg.converged or not leg.pieces:
            continue
        joints = list(joint_coordinates(system, [leg.stratum]))
        if not joints:
            continue
        q = integrate_leg(plan, leg, np.linspace(0.0, leg.duration, SAMPLES))[:, joints]
        if not np.all(np.isfinite(q)):
            continue
        spans = q.max(axis=0) - q.min(axis=0)
        move = float(np.abs(np.asarray(leg.end)[joints] - np.asarray(leg.start)[joints]).max())
        j = int(np.argmax(spans))
        if spans[j] >= max(FAR * move, AT_LEAST):
            notes.append(
                f"leg {leg.index + 1} (Lie-algebraic) swings {system.states[joints[j]]} "
                f"through {spans[j]:.3g} rad where its joints move by at most {move:.3g}: its "
                'steps are local loops; a Newton leg (method = "newton") may cost far less'
            )
    return tuple(notes)
