"""Options more than one command takes, declared once (`Annotated` aliases).

Flags get an empty metavar: typer would otherwise print `<bool>` beside a flag that takes no
value.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Literal

import typer

Json = Annotated[
    bool,
    typer.Option("--json", metavar="", help="Print JSON to stdout instead of tables."),
]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", metavar="", help="Print nothing but errors.")]


def _non_empty(give: str):
    """A path parser that refuses an empty value (`--out ""`, `plan ""`, an unset shell
    variable) as empty: Path("") is the current directory, not what was meant. A leading `~`
    is the home directory, as in a scenario's model path: the shell leaves it as it is in
    `--out=~/runs` and in quotes, and a folder named `~` was made in the current one."""

    def parse(value: str) -> Path:
        if not str(value).strip():
            raise typer.BadParameter(f"empty: give {give}")
        return Path(value).expanduser()

    return parse


directory_value = _non_empty("a directory (e.g. runs)")  # --out
file_value = _non_empty("a file")  # a scenario or sweep file argument


def name_or_file(value: str) -> str:
    """A preset's name or a file (`check`, `models`): a leading `~` is the home directory,
    as in the other path arguments (no name begins with one)."""
    return os.path.expanduser(value) if value.startswith("~") else value


Out = Annotated[
    Path, typer.Option(help="Directory of run records.", parser=directory_value, metavar="<path>")
]
Animation = Annotated[
    bool,
    typer.Option(
        "--animation/--no-animation",
        metavar="",
        help="Also write motion.gif (comparing: the best's; planar robots, a URDF robot's "
        "motion is in run.mcap); off by default, it takes longer than the planning.",
    ),
]


Scenario = Annotated[Path, typer.Argument(help="Scenario file (TOML).", parser=file_value)]
TaskScenario = Annotated[
    Path, typer.Argument(help="Scenario file (TOML); its start and goal.", parser=file_value)
]
MaxLength = Annotated[
    int | None,
    typer.Option(
        "--max-length",
        help="Longest sequence of strata (default: decompose table, else 3).",
        min=1,
        max=8,  # as the [decompose] table allows (settings.DecomposeSettings)
    ),
]
Strategy = Annotated[
    str | None,
    typer.Option(
        help="conservative | postponed | both (default: decompose table, else conservative).",
        metavar="NAME",
    ),
]

# `settings.Search`, spelt here for start-up speed (--help imports no settings); a test keeps
# the two the same
SearchChoice = Literal["loops", "starts", "legwise"]
Objective = Annotated[
    Literal["energy", "newton"] | None,
    typer.Option(
        metavar="energy|newton",
        help="Plan with this objective instead of the scenario's planner.objective: newton "
        "(the paper's method, leg by leg) or energy (least energy over all legs).",
    ),
]
Search = Annotated[
    SearchChoice | None,
    typer.Option(
        metavar="loops|starts|legwise",
        help="The energy objective's search instead of the scenario's planner.search: loops "
        "(its starts, then loop starts on the base's curvature peaks; the default), starts "
        "(without loop starts) or legwise (also each leg's own minimum, joined; slower).",
    ),
]
AutoJobs = Annotated[
    int | None,
    typer.Option(
        help="Auto mode: worker processes comparing the sequences (default: all cores).", min=1
    ),
]


def jobs_notes(jobs: int | None, dask: str | None) -> list[str]:
    """What the command says of a `--jobs` it will not honour as given: with --dask (the
    cluster's workers plan; it was ignored without a word), or beyond the most worker
    processes a local pool here starts (`trie.most_workers`)."""
    if jobs is None:
        return []
    if dask:
        return [f"--jobs {jobs} is for local worker processes: with --dask the cluster's "
                "workers plan"]  # fmt: skip
    from ..trie import PER_CORE, default_jobs, most_workers  # start-up speed

    if jobs <= most_workers():
        return []
    return [f"--jobs {jobs}: at most {most_workers()} worker processes here ({PER_CORE} a core "
            f"on {default_jobs()} cores; planning is CPU work), and no more than there is "
            "work for"]  # fmt: skip
