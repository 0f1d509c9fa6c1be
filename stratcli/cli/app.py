"""The `stratplan` typer app: its options and the commands it registers."""

from __future__ import annotations

from typing import Annotated

import typer

from .. import __version__
from . import commands

app = typer.Typer(
    name="stratplan",
    help="Motion planning for stratified nonholonomic systems (free-floating manipulators).",
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    add_completion=False,
)


def _version(value: bool) -> None:
    if value:
        print(f"stratplan {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool,
        typer.Option(
            "--version", metavar="", callback=_version, is_eager=True, help="Print the version."
        ),
    ] = False,
) -> None:
    pass


app.command()(commands.plan)
app.command()(commands.show)
app.command()(commands.runs)
app.command()(commands.models)
app.command()(commands.regress)
app.command("decompose")(commands.decompose)
app.command("compare-sequences")(commands.compare_sequences)
app.command()(commands.check)
