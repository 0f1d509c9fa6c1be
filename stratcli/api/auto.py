"""Auto-mode glue: the scenario's [decompose] table with command-line overrides, the
decomposition it asks for, and planning every candidate of it (`compare.compare`)."""

from __future__ import annotations

from dataclasses import dataclass

from ..compare import SCREEN_TOP, Comparison, compare, compile_strata
from ..decomposition import STRATEGIES, Decomposition, decompose
from ..errors import InputError, Problem
from ..frozen_json import FrozenDict
from ..scenario import Task
from ..settings import DecomposeSettings
from ..values import MadeAgainOnUnpickling
from ..wording import counted

UNUSED_LEGS = (
    "the scenario's [[legs]] are not used here: its task.start -> task.goal is decomposed "
    "afresh (`stratplan plan`, or `stratcli.plan`, plans the legs)"
)


@dataclass(frozen=True)
class AutoSettings(MadeAgainOnUnpickling):
    """What the decomposer is asked, and where each value came from (for error messages)."""

    max_length: int
    strategies: tuple[str, ...]
    criterion: str
    strata: tuple[str, ...] | None
    # field -> "decompose.<field>" (the file) or the argument's name (given, or the default;
    # the command line shows it as its flag: `cli.render.reported`)
    origin: dict[str, str]
    notes: tuple[str, ...] = ()  # for the user: the scenario's [[legs]] are not used here

    def __post_init__(self) -> None:  # a frozen value: `origin` read-only (`FrozenDict`)
        object.__setattr__(self, "origin", FrozenDict(self.origin))


def auto_settings(
    task: Task,
    *,
    max_length: int | None = None,
    strategy: str | None = None,
    criterion: str | None = None,
) -> AutoSettings:
    """The scenario's [decompose] table (or the defaults), overridden by command-line values."""
    spec = task.scenario.decompose
    defaults = DecomposeSettings()  # the one place the defaults live
    origin = {}
    values = {}
    for name, given in (
        ("max_length", max_length),
        ("strategy", strategy),
        ("criterion", criterion),
    ):
        default = getattr(defaults, name)
        if given is not None:
            values[name], origin[name] = given, name
        elif spec is not None:
            values[name], origin[name] = getattr(spec, name), f"decompose.{name}"
        else:
            values[name], origin[name] = default, name
    strata = None if spec is None or spec.strata is None else tuple(spec.strata)
    origin["strata"] = "decompose.strata" if strata is not None else "task.goal"
    strategy_value = values["strategy"]
    strategies = STRATEGIES if strategy_value == "both" else (strategy_value,)
    notes = () if task.scenario.legs is None else (UNUSED_LEGS,)
    return AutoSettings(
        values["max_length"], strategies, values["criterion"], strata, origin, notes
    )


def decompose_task(task: Task, auto: AutoSettings) -> Decomposition:
    """Decompose the scenario's task; InputError problems name the field or option to change."""
    try:
        return decompose(
            task.system,
            task.start,
            task.goal,
            max_length=auto.max_length,
            strategies=auto.strategies,
            strata=auto.strata,
            duration=task.scenario.planner.leg_duration,
        )
    except InputError as exc:
        where = {"": "task.goal", "max_length": auto.origin["max_length"]}
        where["strata"] = auto.origin["strata"]
        raise InputError(
            [Problem(where.get(p.path, p.path), p.message) for p in exc.problems], task.source
        ) from None


def compare_decomposition(
    task,
    auto,
    decomposition,
    *,
    jobs: int = 1,
    progress=None,
    exhaustive: bool = False,
    executor=None,
) -> tuple[Comparison, float]:
    """Compile the candidates' strata, then plan and rank every candidate of `decomposition`
    by `auto.criterion`; returns the comparison and the compile time. InputError when no
    candidate could even be planned (all were rejected before planning).

    With the energy objective and criterion the candidates are screened (`compare.compare`,
    `screen=SCREEN_TOP`, branch and bound: `stratcli.screen`) unless `exhaustive`: every
    candidate searched to its minimum.
    `executor` (any concurrent.futures.Executor, e.g. a Dask cluster's: `sequences._cluster`):
    plan there instead of in `jobs` forked processes."""
    compile_time = compile_strata(task.system, decomposition.candidates_strata)

    def ranked(screen):
        return compare(
            task.system,
            task.start,
            decomposition.candidates,
            task.settings,
            criterion=auto.criterion,
            jobs=jobs,
            progress=progress,
            screen=screen,
            executor=executor,
            constraints=task.constraints,
            more_harmonics=not harmonics_given(task),
        )

    comparison = ranked(None if exhaustive else SCREEN_TOP)
    best = comparison.best
    if not exhaustive and (best is None or best.plan is None) and decomposition.candidates:
        # the screen left no candidate searched (each has a leg with no plan even alone):
        # searched after all, so that the failure is the one --exhaustive reports, with its
        # furthest plan and record, not bad input naming one candidate
        comparison = ranked(None)
        best = comparison.best
    if best is None or best.plan is None:
        raise InputError(
            [Problem("decompose", best.message if best else "no candidate sequences")],
            task.source,
        )
    return comparison, compile_time


def harmonics_given(task) -> bool:
    """Whether the scenario itself sets `planner.basis.harmonics` (then it is kept, and a
    search that stalls within the limits is not tried again with more)."""
    from ..tomlread import parse_toml  # (the text the task was loaded from: it parses)

    basis = parse_toml(task.text, task.source).get("planner", {}).get("basis", {})
    return not isinstance(basis, dict) or "harmonics" in basis


def auto_choice(outcome) -> str:
    """What auto mode compared and chose, one sentence (a `ComparisonOutcome`): the command
    line prints it, and `stratcli.plan` adds it to the chosen plan's notes."""
    auto, outcomes = outcome.settings, outcome.comparison.outcomes
    bounded = any(o.status == "bounded" for o in outcomes)
    scale = outcome.best.result.time_scale  # the chosen plan was then run this much faster
    return (
        f"auto mode: {counted(len(outcomes), 'candidate sequence')} (max length {auto.max_length}, "
        f"{' + '.join(auto.strategies)}) {'compared' if bounded else 'planned'}; "
        + ("chose " if outcome.ok else "")
        + outcome.comparison.choice()
        + (f" (as planned, before time scaling by {scale:g})" if scale != 1.0 else "")
    )
