"""`--help` laid out to read well from 80 columns up, in typer's look (panels, colours).

Typer's own layout gives the long name, short name, negative form and its short form and the
type a column each, sized to their widest entry; at 80 columns that left an option's help 20
columns, a word or two a line. Here an option is one name column and its help:

    --out <path>              Directory of run records.
                              [default: runs]
    --animation               Also write motion.gif (comparing: the best's); off
    --no-animation            by default, it takes longer than the planning.
                              [default: no-animation]
    --records                 Full run records written under OUT/records for
      <best|failed|all|none>  these tasks.

the type beside the name when the two fit in `NAME_WIDTH` columns (else on the next line),
the negative form below, the default, range and `required` after the help. The help column
gets the rest of the width (50 columns of 80) and starts at the same column in every command.

Version-robust: `_Command` and `_Group` (app.py) call `print_help` from click's public
`format_help` hook, and what is shown of a parameter comes from click's public
`Parameter.get_help_record(ctx)` (typer's parameters implement it for its plain-text help),
so it follows typer's own type, default and range strings; nothing of typer's private
`rich_utils` is used or patched. Help panels (`rich_help_panel`) are not used by stratplan:
every option is under Options.
"""

from __future__ import annotations

import inspect
import os
import re

from rich.console import Console, Group
from rich.markdown import Markdown
from rich.padding import Padding
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

NAME_WIDTH = 24  # the name column's widest: "--max-length <int range>"

_OPTION = "bold cyan"
_SHORT = "bold green"
_NEGATIVE = "bold magenta"
_TYPE = "bold yellow"
_EXTRA = "dim"
_BORDER = "dim"
# click ends a help record with `  [EXTRAS]` (the whole record if there is no help); typer
# 0.19 escapes the bracket for rich (`\\[`)
_EXTRAS = re.compile(r"(?s)^(?:(?P<text>.*?)  )?\\?\[(?P<extras>[^\[\]]*)\]$")


def print_help(command, ctx) -> None:
    """Print `command`'s help (usage, description, arguments, options, subcommands)."""
    width = os.environ.get("TERMINAL_WIDTH")  # as typer's console
    console = Console(width=int(width) if width else None, highlight=False)
    console.print(Padding(Text(command.get_usage(ctx), style="bold"), 1))
    if command.help:
        console.print(Padding(_description(command.help), (0, 1, 1, 1)))
    params = [p for p in command.get_params(ctx) if not getattr(p, "hidden", False)]
    for title, kind in (("Arguments", "argument"), ("Options", "option")):
        rows = [_row(p, ctx) for p in params if p.param_type_name == kind]
        _panel(console, title, [r for r in rows if r is not None])
    names = getattr(command, "list_commands", lambda ctx: [])(ctx)
    subcommands = [command.get_command(ctx, name) for name in names]
    rows = [
        (Text(sub.name or "", style=_OPTION), Markdown(_first_paragraph(sub)))
        for sub in subcommands
        if sub is not None and not sub.hidden
    ]
    _panel(console, "Commands", rows)
    if command.epilog:
        console.print(Padding(Markdown(inspect.cleandoc(command.epilog)), 1))


def _description(text: str) -> Group:
    """The docstring as typer shows it: the first paragraph plain, the rest dim (markdown)."""
    text = inspect.cleandoc(text).partition("\f")[0]
    first, _, rest = text.partition("\n\n")
    parts = [Markdown(first.strip())]
    if rest.strip():
        parts += [Text(""), Markdown(rest.strip(), style="dim")]
    return Group(*parts)


def _first_paragraph(command) -> str:
    if command.short_help:
        return command.short_help
    return inspect.cleandoc(command.help or "").partition("\f")[0].split("\n\n")[0]


def _row(param, ctx) -> tuple[Text, Group] | None:
    """The name cell and the help cell of one parameter, or None if it has no help record."""
    record = param.get_help_record(ctx)
    if record is None:
        return None
    shown, help_text = record
    # click writes `-s, --long TYPE[ / --no-long]` and `HELP  [EXTRAS]`: the type is what
    # follows the last name (names have no spaces)
    type_ = shown.split(" / ")[0].split(", ")[-1].partition(" ")[2]
    if param.param_type_name == "argument":
        names = [(shown.partition(" ")[0], _OPTION)]
    else:
        longs = [o for o in param.opts if o.startswith("--")]
        shorts = [o for o in param.opts if not o.startswith("--")]
        names = [(", ".join(longs + shorts), _OPTION if longs else _SHORT)]
        names += [(o, _NEGATIVE) for o in param.secondary_opts]
    cell = Text(no_wrap=True)
    first, style = names[0]
    cell.append(first, style=style)
    if type_:
        fits = len(first) + 1 + len(type_) <= NAME_WIDTH
        cell.append(" " if fits else "\n  ")
        cell.append(type_, style=_TYPE)
    for name, style in names[1:]:
        cell.append("\n" + name, style=style)
    return cell, _help_cell(help_text)


def _help_cell(help_text: str) -> Group:
    """The help (markdown) and, on a line of its own, click's `[default: ...; range]`."""
    found = _EXTRAS.match(help_text)
    text, extras = (found["text"] or "", f"[{found['extras']}]") if found else (help_text, "")
    parts = [Markdown(text)] if text else []
    return Group(*parts, *([Text(extras, style=_EXTRA)] if extras else []))


def _panel(console: Console, title: str, rows: list) -> None:
    if not rows:
        return
    table = Table.grid(padding=(0, 2), expand=True)
    # the same width in every panel and command: help starts at the same column throughout
    table.add_column(no_wrap=True, width=NAME_WIDTH, overflow="fold")
    table.add_column(ratio=1)
    for row in rows:
        table.add_row(*row)
    console.print(Panel(table, title=title, title_align="left", border_style=_BORDER))
