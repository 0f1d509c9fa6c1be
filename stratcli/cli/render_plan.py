"""The plan's summary as `plan`, `compare-sequences` and `show` print it: the header, a row
per leg, the totals and the energy search's line, read from result.json alone (`plan_summary`);
and `show`'s lines on the record around it (`run_record`)."""

from __future__ import annotations

from rich.markup import escape

from ..wording import counted, method_words
from . import render
from .render import fmt, fmt_error, number_column, say, table, text_column
from .render_limits import broken, limit_margins, limits_asked

__all__ = ["MORE_STARTS", "plan_summary", "run_record", "start_kind"]


def plan_summary(doc: dict) -> None:
    """Header, one row per leg, total energy beside the paper's: from result.json alone."""
    extras = [x for x in ("soft_start", "full_stop") if doc.get(x)]
    if doc.get("time_scale", 1.0) != 1.0:
        extras.append(f"time scale {doc['time_scale']:g}")
    with_pieces = [leg for leg in doc["legs"] if leg["pieces"]]
    basis = with_pieces[0]["pieces"][0]["basis"] if with_pieces else None
    render.out_console.print(
        f"[bold]{doc['scenario']}[/] · model {doc['model']} · {doc['continuity']} · "
        f"objective {doc.get('objective', 'newton')}"
        f"{' · ' + ', '.join(x.replace('_', ' ') for x in extras) if extras else ''} · "
        f"tolerance {doc['tolerance']:g}"
        + (f" · H = {basis['harmonics']}, P = {basis['period']:g}" if basis else ""),
        highlight=False,
    )
    # Per-leg Newton iterations and starts describe the plan only when legs are planned one
    # by one; the energy objective optimises all legs together (its line below says how).
    per_leg = not (doc.get("optimisation") or {}).get("starts")
    legs = table()
    number_column(legs, "leg")
    for col in ("stratum", "method", "evaluator"):
        text_column(legs, col)
    for col in ("iterations", "starts") if per_leg else ():
        number_column(legs, col)
    number_column(legs, "final error")
    number_column(legs, "energy")
    number_column(legs, "status", justify="left")

    margins = (doc.get("constraints") or {}).get("legs") or []
    for i, leg in enumerate(doc["legs"]):
        off = i < len(margins) and broken(margins[i])
        joint = "*" if leg.get("strategy") == "constrained" else ""  # the search's, all legs
        legs.add_row(
            str(i + 1),
            leg["stratum"],
            method_words(leg["method"], leg.get("strategy")),
            leg["evaluator"],
            *((f"{leg['iterations']}{joint}", f"{leg['attempts']}{joint}") if per_leg else ()),
            fmt_error(leg["error"]),
            fmt(leg["energy"]),
            "[red]failed[/]"
            if not leg["converged"]
            else ("[red]off limits[/]" if off else "[green]ok[/]"),
        )
    for i in range(len(doc["legs"]), doc.get("planned_legs") or 0):  # after a failed leg
        legs.add_row(str(i + 1), *["–"] * (7 if per_leg else 5), "[dim]not planned[/]")
    render.out_console.print(legs)
    if per_leg and any(leg.get("strategy") == "constrained" for leg in doc["legs"]):
        say("* the constrained search's iterations and starts, over all legs together")
    line = f"total energy [bold]{fmt(doc['total_energy'])}[/]"
    if len(doc["legs"]) < (doc.get("planned_legs") or 0):
        k = len(doc["legs"])
        line += f" ({'leg 1' if k == 1 else f'legs 1–{k}'} of {doc['planned_legs']} only)"
    ref = doc.get("reference_energy")
    scale = doc.get("time_scale", 1.0)
    if doc["total_energy"] is None or len(doc["legs"]) < (doc.get("planned_legs") or 0):
        ref = None  # no energy to compare (a numerical failure), or only some legs'
    if ref and scale != 1.0:  # the paper's legs last 1 s: compare the path at its own speed
        own = doc["total_energy"] / scale
        line += f" (at time scale 1: {fmt(own)}; paper: {fmt(ref)}, ratio {own / ref:.2f})"
    elif ref:
        line += f" (paper: {fmt(ref)}, ratio {doc['total_energy'] / ref:.2f})"
    if doc["switches"]:
        jumps = [abs(v) for sw in doc["switches"] for v in sw["jump"].values() if v is not None]
        worst = max(jumps, default=0.0)  # null: a jump that is not a number (a failed leg)
        line += f" · largest control jump at a switch {worst:.1e}"
    if scale != 1.0 and doc.get("duration") is not None:  # slowed or sped up: its new length
        line += f" · duration {doc['duration']:.4g} s"
    status = "[green]ok[/]" if doc["status"] == "ok" else "[red]failed[/]"
    render.out_console.print(f"{line} · status {status}", highlight=False)
    opt = doc.get("optimisation")
    if opt and opt.get("best") is not None:
        best = opt["starts"][opt["best"]]
        energies = ", ".join(_start_energy(s, opt["starts"]) for s in opt["starts"])
        # a constrained search went on from the free optimum: say that this line is before it
        total = doc["total_energy"]  # the starts' energies are before any time scaling
        free = None if total is None else total / doc.get("time_scale", 1.0)
        moved = free is not None and not _close(best["energy"], free)
        from ..constraints import KEPT_FREE  # (after planning: numpy is loaded)
        from ..planners.energy import NO_HESSIANS

        # a search without second derivatives that ran from no seeded Newton plan: more are
        # asked for so (the lowest legs are a start of their own, not a seeded plan)
        newtons = sum(s["from"] == "newton" for s in opt["starts"])
        alone = opt.get("no_loop_start") == NO_HESSIANS and newtons <= 1

        kept = KEPT_FREE in (doc.get("message") or "")  # a stalled search keeps the free plan
        head = "without the constraints, " if (moved or kept) and doc.get("constraints") else ""
        # else the final pass re-chained the legs from the configurations they reach (a leg
        # off by more than the tolerance is polished by Newton): the plan's own energy
        # (a stalled search keeps the free plan: its own energy, re-chained, as without)
        rechained = f"; re-chained: {fmt(free)}" if moved and (kept or not head) else ""
        render.out_console.print(
            f"{head}energy-optimal over all legs together: start {best['index'] + 1} of "
            f"{len(opt['starts'])} ({start_kind(best, opt['starts'])}: "
            f"{counted(best['iterations'], 'SQP iteration')}"
            f"{', ' + best['stopped'] if best.get('stopped') else ''}, "
            f"projected gradient {best['projected_gradient']:.0e}); the starts ended at "
            f"{energies}{rechained}; plain Newton: {fmt(opt['newton_energy'])}"
            + (" (energies before time scaling)" if scale != 1.0 else "")
            + (f"; no loop start: {opt['no_loop_start']}" if opt.get("no_loop_start") else "")
            + (f"; {MORE_STARTS}" if alone else ""),
            highlight=False,
        )
    failure = (doc.get("message") or "") if doc["status"] != "ok" else ""
    for note in doc.get("notes") or []:
        if note not in failure:  # (the failure line below says it: once is enough)
            render.out_console.print(f"note: {escape(note)}", highlight=False)
    if doc.get("constraints") and (
        asked := limits_asked(doc["constraints"], doc.get("model") == "urdf")
    ):
        render.out_console.print(escape(asked), highlight=False)
        if margins := limit_margins(doc["constraints"]):
            render.out_console.print(margins, highlight=False)
    for i, leg in enumerate((doc.get("attitude") or {}).get("legs") or []):  # URDF robots
        if leg.get("audit"):
            a, err = leg["audit"], leg.get("goal_error")
            render.out_console.print(
                f"leg {i + 1} on SO(3): attitude error "
                f"{_attitude_error(leg.get('goal'), err)} · audit: momentum "
                f"{a['max_momentum']:.1e}, CoM drift {a['com_drift']:.1e} m, "
                f"|RᵀR − I| {a['orthogonality']:.1e}",
                highlight=False,
            )
    lie = [
        (i + 1, leg)
        for i, leg in enumerate(doc["legs"])
        if leg["method"] == "lie" and leg["pieces"]
    ]
    for i, leg in lie:
        render.out_console.print(
            f"leg {i}: {len(leg['pieces'])} Lie-algebraic steps of "
            f"{leg['pieces'][0]['duration']:g} s (one piece each in result.json), "
            f"{leg['duration']:g} s in all",
            highlight=False,
        )


def _start_energy(start: dict, starts: list[dict]) -> str:
    """`loop 404.03`, `newton 549.89 (abandoned)`: where a start began and where it ended,
    and why its search stopped there when not at a minimum of its own; one stopped on its way
    to a minimum another start reached names that start (the nearest below its energy: the
    energy only falls on the way) by its number on the line (`pulled 124.07 (heading for
    start 2's minimum), newton 124.07`: "(same minimum)" after the first of two starts read
    as if it were the second's)."""
    from ..planners.sqp import MINIMUM  # (after planning, or reading a record: numpy is loaded)

    stopped, energy = start.get("stopped"), start.get("energy")
    why = f" ({stopped})" if stopped and stopped not in MINIMUM else ""
    if stopped == "same minimum" and energy is not None:
        ends = [  # minima it may have been descending to: at its energy or below
            s for s in starts
            if s.get("stopped") in MINIMUM and s.get("energy") is not None
            and s["energy"] <= energy * (1 + 1e-9)
        ]  # fmt: skip
        if ends:
            other = min(ends, key=lambda s: energy - s["energy"])
            why = f" (heading for start {other['index'] + 1}'s minimum)"
    return f"{start_kind(start, starts)} {fmt(energy)}{why}"


# what the search line adds where a search without second derivatives ran from no seeded
# Newton plan (`plan_summary`)
MORE_STARTS = (
    "planner.starts = 5 adds three seeded Newton plans as starts (slower; at times far lower)"
)


def _attitude_error(goal, err) -> str:
    """A URDF leg's attitude error as its SO(3) line says it (`spatialdoc.group_error`)."""
    if err is None:
        return "(free)"
    return f"{err:.1e} rad" + (" (partly free: its given components)" if goal is None else "")


def start_kind(start: dict, starts: list[dict]) -> str:
    """Where a start began, as the search line says it: result.json's `from`, but a Newton
    plan after the first is `seed k`, the k-th seeded Newton plan (`planner.starts`): four
    starts all called "newton" did not say which one won."""
    if start["from"] != "newton":
        return start["from"]
    earlier = sum(s["from"] == "newton" for s in starts[: start["index"]])
    return f"seed {earlier}" if earlier else "newton"


def _close(a: float | None, b: float | None) -> bool:
    return a is not None and b is not None and abs(a - b) <= 1e-9 * max(1.0, abs(b))


def run_record(record, log: dict | None) -> None:
    """`show`: the summary read back from result.json, the MCAP log, the manifest, files."""
    plan_summary(record.result)
    if record.result.get("status") != "ok":
        message = record.result.get("message") or "no message recorded"
        render.out_console.print(f"[bold red]failed:[/] {escape(message)}", highlight=False)
    if record.comparison is not None:  # the plan is the best of a comparison: which and why
        rows = record.comparison.get("rows", [])
        scale = record.result.get("time_scale", 1.0)  # its rows are as planned (as `plan` says)
        scaled = f", as planned, before time scaling by {scale:g}" if scale != 1.0 else ""
        say(
            f"best of {counted(len(rows), 'candidate sequence')}: "
            f"{escape(record.comparison.get('choice', '?'))} (all of them: comparison.json"
            f"{scaled})"
        )
    if log:
        topics = ", ".join(f"{t} {n}" for t, n in log["topics"].items())
        say(f"run.mcap: {log['messages']} messages over {log['duration_s']:.2f} s ({topics})")
    m = record.manifest
    planning = m.get("planning_time_s")
    planning = "?" if planning is None else f"{1e3 * planning:.0f}"
    code = m.get("exit_code")  # optional fields: "?" where a record lacks them
    say(
        f"run {record.path.resolve().name} · started {m.get('started', '?')} · "
        f"planning {planning} ms · "
        f"stratplan {m.get('stratplan', '?')} · exit code {'?' if code is None else code}"
    )
    files = sorted(p.name for p in record.path.iterdir())
    say(f"files: {', '.join(files)}")
