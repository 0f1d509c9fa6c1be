"""A plan run faster or slower (paper §6): for a driftless system the same path is followed
when every control is scaled, `u(t) → s·u(s·t)`, so a plan can be re-timed exactly, without
planning again (`planner.time_scale`, and the rate limits of `[constraints]`)."""

from __future__ import annotations

from dataclasses import replace

from .arguments import checked, instance, number
from .controls import FourierBasis, energy
from .results import Switch
from .sequence import SequencePlan
from .settings import MAX_TIME_SCALE

__all__ = ["scale_time", "time_scaled"]


@checked(
    plan=instance("a SequencePlan", SequencePlan),
    s=number(1.0 / MAX_TIME_SCALE, MAX_TIME_SCALE),  # as planner.time_scale
)
def time_scaled(plan: SequencePlan, s: float) -> SequencePlan:
    """The same path run `s` times faster (paper §6): `u(t) → s·u(s·t)`.

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
        a plan run faster than its rate limits allow is failed, naming the limit).
    """
    out = scale_time(plan, s)
    if plan.constraints is not None:  # its margins were measured at the old speed
        from .constraints import verified_again  # (imports this module)

        out = verified_again(out)
    return out


def scale_time(plan: SequencePlan, s: float) -> SequencePlan:
    """`time_scaled` without the check of `s` (`constraints.enforce` slows a plan by any
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
