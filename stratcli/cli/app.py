"""The `stratplan` typer app: its options and the commands it registers."""

from __future__ import annotations

import atexit
import gc
from typing import Annotated

import typer
from typer.core import TyperCommand, TyperGroup

from .. import __version__
from . import analysis, commands, models, records, render
from . import sweep as sweep_command
from .usage import one_line

# Start-up speed: a command is a short process whose heap is mostly the module graphs of sympy,
# scipy and matplotlib, alive until it exits. The cyclic collector's default threshold (700
# allocations) walks them over and over while they are imported, and once more at exit; here it
# runs 14x less often and the heap is frozen at exit (plan: 0.25 s CPU of 1.9 s; memory is
# returned by the OS, and cyclic garbage left at exit is not finalised, as Python allows).
gc.set_threshold(10_000, 10, 10)
atexit.register(gc.freeze)


class _NoTypeOnHelp:
    """`--help` is a flag: no `<bool>` beside it in the help (as for every other flag)."""

    def get_help_option(self, ctx):
        option = super().get_help_option(ctx)
        if option is not None:
            option.metavar = ""
        return option


class _OneLineUsageErrors:
    """A bad option or argument (a value out of range, an unknown option) is one `error:` line
    and exit 2, like every other bad input (`usage.one_line`), not click's boxed panel."""

    def make_context(self, *args, **kwargs):
        with one_line():
            return super().make_context(*args, **kwargs)


class _ReadableHelp:
    """`--help` laid out for 80 columns up (`helpfmt`), through click's public `format_help`
    hook instead of typer's rich layout, which left an option's help 20 columns at 80."""

    def format_help(self, ctx, formatter):
        from . import helpfmt  # start-up speed: rich loads only for the help

        helpfmt.print_help(self, ctx)


class _Group(_ReadableHelp, _OneLineUsageErrors, _NoTypeOnHelp, TyperGroup):
    def resolve_command(self, ctx, args):
        with one_line():  # an unknown command
            return super().resolve_command(ctx, args)


class _Command(_ReadableHelp, _OneLineUsageErrors, _NoTypeOnHelp, TyperCommand):
    pass


app = typer.Typer(
    name="stratplan",
    cls=_Group,
    help="Motion planning for stratified nonholonomic systems (free-floating manipulators).",
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},  # (-h was "No such option")
    # Docstrings are prose: lines join into paragraphs (markdown), and [[legs]] or [u1,u2]
    # in them are text, not rich markup.
    rich_markup_mode="markdown",
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
    render.quiet(False)  # (a command with --quiet sets it again)


app.command(cls=_Command)(commands.plan)
app.command(cls=_Command)(records.show)
app.command(cls=_Command)(records.runs)
app.command(cls=_Command)(models.models)
app.command(cls=_Command)(commands.regress)
app.command("decompose", cls=_Command)(analysis.decompose)
app.command("compare-sequences", cls=_Command)(commands.compare_sequences)
app.command(cls=_Command)(analysis.check)
app.command("sweep", cls=_Command)(sweep_command.sweep)
