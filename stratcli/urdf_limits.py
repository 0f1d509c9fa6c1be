"""A URDF's joint limits where the scenario has no `[constraints]` table: noted, not enforced.

With a `[constraints]` table, a URDF model's joint limits default to the URDF's and are
verified like any other (`constraints.resolve`, `verify`): a plan that leaves them fails,
and its message says that the limit came from the URDF and what can help there
(`violation_advice`; the constrained search keeps URDF legs within joint limits as it does
planar ones: their joints are closed-form too). Without one, the
plan is left as it is (its status unchanged) and gets a note instead (`with_limit_notes`):
where its start, vias or goal lie outside the URDF's limits (`outside_limits`, which
`stratplan check` prints as a warning), and which legs leave them, how far and when (made
again for a re-timed plan: `with_legs_noted_again`). The
joints of a URDF model are closed-form integrals of the Fourier controls
(`FourierBasis.integrals`), so the check integrates nothing: it evaluates them at `SAMPLES`
instants per piece. URDF velocity limits (`<limit velocity>`) are not used (rate limits
are `[constraints] max_rate`).
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from .status import Status

__all__ = [
    "URDF_LIMIT",
    "outside_limits",
    "violation_advice",
    "wider_than_urdf",
    "with_legs_noted_again",
    "with_limit_notes",
]

SAMPLES = 2000  # per piece of a leg (a Newton leg has one)
URDF_LIMIT = "the URDF's joint limits of"  # how `constraints.verify` names one it breaks
VERIFIED = "add a [constraints] table (even an empty one) to have the plan kept within them"
REFUSED = "with a [constraints] table, even an empty one, that is an error"
URDF_ADVICE = (
    "reached its goals but violates a joint limit of the URDF; try via configurations that "
    "keep the joint away from the limit, another stratum sequence, more harmonics, the other "
    "objective, or wider limits in [constraints].joint_limits"
)


DURATIONS_ADVICE = (
    "reached its goals but violates a limit of [constraints]; try more harmonics, via "
    "configurations that keep the robot away from the limit, another stratum sequence, or "
    "another total_duration (with the basis period unchanged, another path)"
)


def stalled_too(first: int, tried: str) -> str:
    """What `objectives.with_more_harmonics` appends to a stall message when the plan was
    planned again with more harmonics (`tried`, e.g. "5 and 8") and stalled each time;
    `violation_advice` reads the largest count back (`_STALLED_TOO`) to ask for more."""
    return f" (with {first} harmonics; it stalled with {tried} too)"


_STALLED_TOO = re.compile(r"; it stalled with [\d, and]*?(\d+) too\)")


def violation_advice(plan, violated: str) -> str:
    """What to try after `violated` (a `constraints.verify` violation): for optimised
    durations the status' advice without the other objective (refused with them), for a
    URDF's limits the status' advice and wider limits in the table, else the status' own advice."""
    if plan.settings.durations == "optimise":
        advice = DURATIONS_ADVICE
    elif URDF_LIMIT in violated:
        advice = URDF_ADVICE
    else:
        advice = Status.CONSTRAINT_VIOLATED.value
    tried = _STALLED_TOO.search(plan.message or "")
    if tried:  # retried with more harmonics already (`stalled_too`)
        advice = advice.replace(
            "more harmonics", f"more than {tried[1]} harmonics (planner.basis.harmonics)"
        )
    return advice


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def _fmt_beyond(x: float, bound: float) -> str:
    """`x`, a value beyond `bound`, with the digits that show it is (2.002, not 2, past 2)."""
    for digits in range(3, 13):
        if f"{x:.{digits}g}" != f"{bound:.{digits}g}":
            return f"{x:.{digits}g}"
    return f"{x:.12g}"


def outside_limits(task) -> list[str]:
    """One sentence per start, via or goal coordinate of a URDF scenario without
    [constraints] that lies outside the URDF's limits (what `stratplan check` warns of)."""
    limits = _unverified_limits(task)
    found = _configurations(task, *limits) if limits else []
    return [f"{'; '.join(found)}; {REFUSED}"] if found else []


def wider_than_urdf(task) -> list[str]:
    """A sentence naming the joints whose [constraints] limits reach past the URDF's own (the
    table overrides them, so a plan may drive a joint past its hardware stop)."""
    robot = getattr(task.system, "spatial", None)
    c = task.constraints
    if robot is None or c is None:
        return []
    wider = [
        f"{name} [{_fmt(c.lower[j])}, {_fmt(c.upper[j])}] (the URDF's "
        f"[{_fmt(robot.lower[j])}, {_fmt(robot.upper[j])}])"
        for j, name in enumerate(robot.joint_names)
        if j not in c.from_urdf and (c.lower[j] < robot.lower[j] or c.upper[j] > robot.upper[j])
    ]
    if not wider:
        return []
    return [
        f"constraints.joint_limits: wider than the URDF's own, which they override: "
        f"{', '.join(wider)}"
    ]


def _unverified_limits(task) -> tuple[np.ndarray, np.ndarray, tuple] | None:
    """(lower, upper, joint names) of a URDF model in a scenario without [constraints] (which
    would verify them); None for every other scenario."""
    robot = getattr(task.system, "spatial", None)
    if robot is None or task.constraints is not None:
        return None
    lower, upper = np.asarray(robot.lower, float), np.asarray(robot.upper, float)
    return lower, upper, robot.joint_names


def _configurations(task, lower, upper, names) -> list[str]:
    """One phrase per start, via or goal coordinate outside the URDF's limits."""
    k = len(names)
    places = [("task.start", task.start)]
    places += [(f"legs[{i}].goal", leg.goal) for i, leg in enumerate(task.legs[:-1])]
    places += [("task.goal", task.goal)]
    out = []
    for where, q in places:
        if q is None:
            continue
        q = np.asarray(q, dtype=float)[:k]
        for j in np.flatnonzero(np.isfinite(q) & ((q < lower) | (q > upper))):
            bound = lower[j] if q[j] < lower[j] else upper[j]
            out.append(
                f"{where} has {names[j]} = {_fmt_beyond(q[j], bound)}, outside the URDF's limits "
                f"[{_fmt(lower[j])}, {_fmt(upper[j])}]"
            )
    return out


def joint_paths(leg, k: int, samples: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """(leg-local times, joints (N, k)) of a URDF leg, in closed form from its controls."""
    times, joints = [], []
    q0 = np.asarray(leg.start, dtype=float)[:k].copy()
    active = [i for i in leg.active if i < k]
    for piece in leg.pieces:
        tau = np.linspace(0.0, float(piece.duration), samples)
        q = np.repeat(q0[None, :], samples, axis=0)
        moved = leg.basis.integrals(tau) @ np.atleast_2d(piece.coefficients).T
        q[:, active] += moved[:, : len(active)]
        times.append(piece.t0 + tau)
        joints.append(q)
        q0 = q[-1].copy()
    if not joints:
        return np.zeros(0), np.zeros((0, k))
    return np.concatenate(times), np.concatenate(joints)


def _legs(plan, lower, upper, names) -> list[str]:
    """Per joint, the legs that go outside its limits, and the farthest point: its value and
    time on the plan's axis."""
    k = len(names)
    legs: dict[int, list[int]] = {}
    worst: dict[int, tuple[float, float, float]] = {}  # joint -> (beyond, value, t)
    for leg in plan.legs:
        t, q = joint_paths(leg, k)
        if not len(q) or not np.isfinite(q).all():
            continue
        beyond = np.maximum(lower - q, q - upper)  # > 0 outside
        for j in np.flatnonzero(beyond.max(axis=0) > 0):
            i = int(np.argmax(beyond[:, j]))
            legs.setdefault(j, []).append(leg.index + 1)
            if j not in worst or beyond[i, j] > worst[j][0]:
                worst[j] = (float(beyond[i, j]), float(q[i, j]), leg.t0 + float(t[i]))
    out = []
    for j in sorted(legs):
        numbers = legs[j]
        which = (
            f"leg {numbers[0]} leaves"
            if len(numbers) == 1
            else f"legs {', '.join(map(str, numbers[:-1]))} and {numbers[-1]} leave"
        )
        _, value, when = worst[j]
        bound = lower[j] if value < lower[j] else upper[j]
        out.append(
            f"{which} the URDF's limits of {names[j]} [{_fmt(lower[j])}, {_fmt(upper[j])}] "
            f"(reach{'es' if len(numbers) == 1 else ''} {_fmt_beyond(value, bound)} at "
            f"t = {when:.3f} s)"
        )
    return out


def _legs_note(plan, lower, upper, names) -> str | None:
    """The note of the legs that leave the URDF's limits, at the plan's timing (or None)."""
    left = _legs(plan, lower, upper, names)
    return f"{'; '.join(left)}; {VERIFIED}" if left else None


def with_limit_notes(plan, task):
    """`plan` with a note for each way it or its task leaves the URDF's joint limits (only
    for a URDF model in a scenario without [constraints]; else `plan` itself)."""
    limits = _unverified_limits(task)
    if limits is None:
        return plan
    notes = outside_limits(task)
    if note := _legs_note(plan, *limits):
        notes.append(note)
    return replace(plan, notes=(*plan.notes, *notes)) if notes else plan


def with_legs_noted_again(plan):
    """`plan`, re-timed (`time_scaling.time_scaled`), with its note of the legs that leave
    the URDF's limits (`with_limit_notes`, which timed them at its old speed) made again at
    its own timing, in the same place; `plan` itself when it has no such note."""
    old = [k for k, note in enumerate(plan.notes) if note.endswith(f"; {VERIFIED}")]
    if not old:
        return plan
    robot = plan.system.spatial
    lower, upper = np.asarray(robot.lower, float), np.asarray(robot.upper, float)
    note = _legs_note(plan, lower, upper, robot.joint_names)  # (the path is the same)
    notes = list(plan.notes)
    for k in reversed(old):
        del notes[k]
    if note is not None:
        notes.insert(old[0], note)
    return replace(plan, notes=tuple(notes))
