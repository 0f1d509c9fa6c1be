"""The commands that analyse without planning: `decompose` (the candidate sequences) and
`check` (controllability). Parse, call `stratcli.api`, render (`render_analysis`), exit."""

from __future__ import annotations

from typing import Annotated

import typer

from ..errors import Problem
from . import render
from .commands import legs_as_notes, load_task
from .options import Json, MaxLength, Strategy, TaskScenario, name_or_file
from .render_analysis import check_report, decomposition

__all__ = ["check", "decompose"]


def decompose(
    file: TaskScenario,
    max_length: MaxLength = None,
    strategy: Strategy = None,
    json_output: Json = False,
) -> None:
    """List the candidate sequences of strata and their via configurations, without planning.

    Essential coordinates are those whose goal differs from the start; a sequence qualifies
    when its strata together move all of them (no stratum twice in a row). `conservative`
    sets every essential coordinate a leg can move to its goal value; `postponed` leaves it to
    the last leg that can move it. Coordinates a leg's stratum locks keep their value.
    """
    from .. import api  # start-up speed

    task = load_task(file)
    with render.reported(), legs_as_notes():
        outcome = api.decompose(task, max_length=max_length, strategy=strategy)
    render.notes([*outcome.settings.notes, *outcome.notes])
    if json_output:
        render.print_json(outcome.document)
    else:  # the options asked, so that its hint ranks these candidates
        given = (("--max-length", max_length), ("--strategy", strategy))
        decomposition(outcome, file, tuple(f"{o} {v}" for o, v in given if v is not None))


def check(
    target: Annotated[
        str,
        typer.Argument(
            metavar="NAME|FILE",
            help="A preset model's name, a scenario file or a URDF file.",
            parser=name_or_file,
        ),
    ],
    at: Annotated[
        str | None,
        typer.Option(
            help='Configuration, e.g. "0, pi/3, 0, 0" (default: the scenario start, or zeros '
            "for a preset or a URDF)."
        ),
    ] = None,
    samples: Annotated[
        int,
        typer.Option(min=0, max=100_000, help="Random configurations checked besides --at."),
    ] = 100,
    degree: Annotated[int, typer.Option(min=1, max=3, help="Lie bracket degree (1-3).")] = 2,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the sampled configurations.")] = 0,
    all_strata: Annotated[
        bool,
        typer.Option(
            "--all-strata",
            help="For a scenario, every stratum of its model, not only those its legs use.",
        ),
    ] = False,
    json_output: Json = False,
) -> None:
    """Controllability of every stratum (paper eq. 4) and of the strata together (eq. 2).

    Per stratum: the rank of its generators and Lie brackets (up to DEGREE, on its free
    coordinates) and their smallest singular value, at the configuration and at SAMPLES
    sampled ones; where DEGREE falls short, third-order brackets are tried. For a scenario,
    the strata its legs use (every one with --all-strata), and whether each leg's stratum
    spans the coordinates the leg steers. Exits 0, 2 on bad
    input, 3 when the scenario's strata cannot do their legs (or the strata of a model or an
    auto-mode scenario do not reach every direction together), naming stratum and
    configuration.
    """
    from .. import api  # start-up speed

    with render.reported():
        report = api.check_controllability(
            target, at, samples=samples, degree=degree, seed=seed, all_strata=all_strata
        )
    if json_output:
        render.print_json(report.document)
    else:
        check_report(report)
    for problem in report.document.get("model_problems", ()):  # as `plan` says it
        render.error("error", Problem("model.fields", problem).render(target))
    for problem in report.problems:
        render.error("not controllable", problem)
    for warning in report.document.get("warnings", ()):
        render.warning(warning)
    if report.document.get("model_problems"):
        raise typer.Exit(2)
    raise typer.Exit(0 if report.controllable else 3)
