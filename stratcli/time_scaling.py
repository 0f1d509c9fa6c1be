"""A plan run faster or slower (paper §6): for a driftless system the same path is followed
when every control is scaled, `u(t) → s·u(s·t)`, so a plan can be re-timed exactly, without
planning again (`planner.time_scale`, and the rate limits of `[constraints]`)."""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace

import numpy as np

from .arguments import checked, instance, number
from .controls import FourierBasis, energy
from .results import Switch
from .sequence import SequencePlan
from .settings import MAX_TIME_SCALE

__all__ = ["peaks", "rate_limited", "retimed", "scale_time", "time_scaled"]

PEAK_SAMPLES = 40_000  # per leg: where the peak controls and their derivatives are sought


@checked(
    plan=instance("a SequencePlan", SequencePlan),
    s=number(1.0 / MAX_TIME_SCALE, MAX_TIME_SCALE),  # as planner.time_scale
)
def time_scaled(plan: SequencePlan, s: float) -> SequencePlan:
    """The same path run `s` times faster (paper §6): `u(t) → s·u(s·t)`.

    The plan's settings and scenario text say `planner.time_scale` multiplied by `s`, so
    that its record re-plans to it (a record of it said 2 in result.json and 1 in its
    scenario.toml and resolved.json, and re-planned to the plan before).

    Durations and switch times are divided by `s`, the basis period too (so every piece is
    still a Fourier series of the documented form), coefficients are multiplied by `s`;
    energies grow by `s`, value jumps by `s` and derivative jumps by `s²`.

    Parameters
    ----------
    plan : SequencePlan
        A plan (at any time scale).
    s : float
        The speed-up, from 0.001 to 1000 (as `planner.time_scale`); below 1 the path runs
        slower.

    Returns
    -------
    SequencePlan
        The same path in 1/s of the time; `time_scale` multiplied by `s`. A plan planned
        under [constraints] has its limits verified again at the new speed (not slowed back:
        a plan run faster than its rate limits allow is failed, naming the limit); a note of
        where the legs leave a URDF's joint limits is made again at the new times.
    """
    out = retimed(plan, s)
    scale = plan.settings.time_scale * s
    return replace(
        out,
        settings=replace(out.settings, time_scale=scale),
        scenario_text=_with_time_scale(plan.scenario_text, scale),
    )


def _with_time_scale(text: str, scale: float) -> str:
    """Scenario TOML `text` with `planner.time_scale = scale` ("" stays "")."""
    if not text:
        return text
    from .tomlwrite import dumps

    tables = tomllib.loads(text)
    if tables.get("planner", {}).get("time_scale", 1.0) == scale:
        return text  # (as it was: plans compare their scenarios' text)
    planner = tables.setdefault("planner", {})
    planner["time_scale"] = float(scale)
    if scale == 1.0:  # back at the default: as a scenario that never set it
        del planner["time_scale"]
        if not planner:
            del tables["planner"]
    return dumps(tables)


def retimed(plan: SequencePlan, s: float) -> SequencePlan:
    """`time_scaled` of a plan whose settings already say its time scale (`plan_run`: the
    planned path run at `planner.time_scale`): the limits verified again, notes at the new
    times; settings and scenario text as they are."""
    out = scale_time(plan, s)
    if plan.constraints is not None:  # its margins were measured at the old speed
        from .limit_timing import verified_again  # (imports this module)

        out = verified_again(out, s)
        if plan.constraints.duration_set_by:  # its "slowed ...x to meet ..." note is history
            note = f"then time-scaled by {s:g}: its duration is this call's, not a limit's"
            out = replace(out, notes=(*out.notes, note))
    else:  # a note of when the legs leave a URDF's joint limits: at the new times
        from .urdf_limits import with_legs_noted_again

        out = with_legs_noted_again(out)
    return out


def scale_time(plan: SequencePlan, s: float) -> SequencePlan:
    """`time_scaled` without the check of `s` (`limit_timing.enforce` slows a plan by any
    factor its rate limits need)."""
    old = plan.settings.basis
    basis = FourierBasis(old.harmonics, old.period / s)
    legs = []
    for leg in plan.legs:
        pieces = tuple(
            replace(p, t0=p.t0 / s, duration=p.duration / s, coefficients=p.coefficients * s)
            for p in leg.pieces
        )
        legs.append(
            replace(
                leg,
                t0=leg.t0 / s,
                duration=leg.duration / s,
                pieces=pieces,
                basis=basis,
                energy=float(sum(energy(basis, p.duration, p.coefficients) for p in pieces)),
            )
        )
    switches = [
        Switch(sw.time / s, sw.after_leg, sw.jump * s, sw.jump_derivative * s * s)
        for sw in plan.switches
    ]
    out = replace(
        plan,
        legs=tuple(legs),
        switches=tuple(switches),
        settings=replace(plan.settings, basis=basis),
        time_scale=plan.time_scale * s,
    )
    return out.with_system(plan._system) if plan._system is not None else out


# Rate and acceleration limits (`[constraints]`): met exactly by running the plan slower


def _peak(values: np.ndarray) -> np.ndarray:
    """Per column, the largest |value|, refined by a parabola through an interior sampled
    maximum and its neighbours (a sampled peak of a Fourier series is low by O(h²)); a
    maximum at either end is exact."""
    a = np.abs(values)
    k = a.argmax(axis=0)
    interior = (k > 0) & (k < len(a) - 1)
    k = np.clip(k, 1, len(a) - 2)
    cols = np.arange(a.shape[1])
    y0, y1, y2 = a[k - 1, cols], a[k, cols], a[k + 1, cols]
    curve = y0 - 2 * y1 + y2
    refine = interior & (curve < 0)
    vertex = y1 - (y2 - y0) ** 2 / np.where(refine, 8 * curve, -np.inf)
    return np.maximum(a.max(axis=0), np.where(refine, vertex, 0.0))


def peaks(plan, samples: int = PEAK_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """Largest |u_j| and |du_j/dt| over the plan, per input (controls only: no integration)."""
    m = len(plan.inputs)
    u_peak, du_peak = np.zeros(m), np.zeros(m)
    for leg in plan.legs:
        tau = np.linspace(0.0, float(leg.duration), samples)
        u_peak = np.maximum(u_peak, _peak(leg.controls(tau)))
        du_peak = np.maximum(du_peak, _peak(leg.controls(tau, derivative=True)))
    return u_peak, du_peak


def rate_limited(plan, constraints) -> tuple[float, str]:
    """The speed-up s ≤ 1 that makes the plan meet the rate and acceleration limits of
    `constraints` (`constraints.Constraints`) exactly (1 when it meets them already) and
    which limit sets it ("" when none does)."""
    if (constraints.max_rate is None and constraints.max_acceleration is None) or not plan.legs:
        return 1.0, ""
    u_peak, du_peak = peaks(plan)
    options = [(1.0, "")]
    for j, name in enumerate(plan.inputs):
        if constraints.max_rate is not None and u_peak[j] > 0:
            limit = constraints.max_rate[j]
            options.append((limit / u_peak[j], f"the rate limit of {name} ({limit:g} rad/s)"))
        if constraints.max_acceleration is not None and du_peak[j] > 0:
            limit = constraints.max_acceleration[j]
            options.append(
                (
                    math.sqrt(limit / du_peak[j]),
                    f"the acceleration limit of {name} ({limit:g} rad/s²)",
                )
            )
    return min(options, key=lambda o: o[0])
