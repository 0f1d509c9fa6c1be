"""Rich rendering: tables and messages of the commands; nothing here plans or validates.

Tables never cut a number or an id: numeric and id columns (`number_column`) are never
wrapped and never shortened with "…", text columns (`text_column`) wrap. Output that is not a
terminal is not wrapped at all (`Stream`): a pipe or a file gets each line whole.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import typer
from rich.console import Console, ConsoleDimensions
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from ..errors import InputError, NotControllableError, Problem, RecordError

PIPE_WIDTH = 10_000  # not a terminal: lines are as long as their text, never wrapped


class Stream(Console):
    """A console that wraps to the terminal's width, and not at all when it is no terminal.

    It prints no emoji: messages quote user text, where `:-1:` (as in `localhost:-1`) is
    text, not a thumbs-down.
    """

    def __init__(self, *args: Any, emoji: bool = False, **kwargs: Any) -> None:
        super().__init__(*args, emoji=emoji, **kwargs)

    @property
    def size(self) -> ConsoleDimensions:
        """The terminal's size; `PIPE_WIDTH` columns when the output is not a terminal."""
        size = Console.size.fget(self)
        return size if self.is_terminal else ConsoleDimensions(PIPE_WIDTH, size.height)

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        Console.size.fset(self, new_size)

    def print(self, *objects: Any, **kwargs: Any) -> None:
        """`Console.print`; a table that does not fit the terminal even with its text
        columns wrapped word by word is printed whole, as to a pipe, the terminal wrapping
        its lines: at 40 or 60 columns Rich shrank text columns to nothing ("spanning at q"
        and the verdict vanished, their headers blank), below their words' widths."""
        tables = [o for o in objects if isinstance(o, Table)]
        if tables and self.is_terminal and "width" not in kwargs:
            from rich.measure import Measurement

            wide = self.options.update_width(PIPE_WIDTH)  # (else clamped to the terminal)
            sizes = [Measurement.get(self, wide, t) for t in tables]
            if max(size.minimum for size in sizes) > self.width:  # (print's own `width`
                kept = self._width  # is clamped to the console's)
                self.width = max(size.maximum for size in sizes)
                try:
                    return super().print(*objects, crop=False, **kwargs)
                finally:
                    self._width = kept
        super().print(*objects, **kwargs)


out_console = Stream()
err_console = Stream(stderr=True)


def table() -> Table:
    """An empty table in the commands' style (no outer edge)."""
    return Table(show_edge=False)


def number_column(table: Table, header: str, justify: str = "right", **kw: Any) -> None:
    """A column of numbers, ids or one-word values: never wrapped or cut with "…" (folded only
    on a terminal too narrow for the cell itself). A long header should break with "\\n"."""
    table.add_column(header, justify=justify, no_wrap=True, overflow="fold", **kw)


def text_column(table: Table, header: str, **kw: Any) -> None:
    """A column of words: wrapped at spaces to fit, a word longer than the column folded."""
    table.add_column(header, overflow="fold", **kw)


def say(text: str) -> None:
    """One line on stdout; rich markup allowed, no highlighting. A word wider than the
    terminal (a record's path in 40 columns) is left to the terminal to wrap: rich broke it
    with a newline, which a path copied from the screen then held."""
    widest = max(map(len, Text.from_markup(text).plain.split()), default=0)
    out_console.print(text, highlight=False, soft_wrap=widest > out_console.width)


def error(label: str, message: str) -> None:
    """`label: message` on stderr, label in bold red (message is plain text)."""
    err_console.print(f"[bold red]{label}:[/] {escape(message)}", highlight=False, soft_wrap=True)


_QUIET = {"on": False}  # --quiet of the command running (`quiet`)


def quiet(on: bool) -> None:
    """Whether `notes` prints nothing (--quiet: "Print nothing but errors"); every command
    sets it (the app's callback: False), so a command run after another in one process
    (tests, a notebook's CliRunner) does not inherit it."""
    _QUIET["on"] = bool(on)


def warning(message: str) -> None:
    """One `warning:` line on stderr (a leg that may be ill-conditioned, a joint limit
    past a full turn): the `warn` callback the commands give the library."""
    error("warning", message)


def notes(texts: Iterable[str], always: bool = False) -> None:
    """One `note:` line each on stderr (not in the way of --json on stdout); none under
    --quiet unless `always` (how to resume an interrupted sweep)."""
    if _QUIET["on"] and not always:
        return
    for text in texts:
        err_console.print(f"note: {escape(text)}", highlight=False, soft_wrap=True)


def print_json(doc: Any) -> None:
    print(json.dumps(doc, indent=2))


# The library names a use case's Python argument (`at: needs 4 values`); the command line
# shows the flag that passed it (`--at: needs 4 values`). A scenario's or sweep file's field
# path is dotted or a table's name, never one of these.
FLAGS = {
    name: "--" + name.replace("_", "-")
    for name in ("at", "max_length", "strategy", "criterion", "time_scale", "degree", "samples",
                 "seed", "jobs", "records", "dask", "out", "resume")
} | {"fmt": "--format"}  # fmt: skip


def flagged(problem: Problem) -> Problem:
    """`problem` naming the command-line flag where it names a use case's argument: `--out
    sweeps/x: ...` where Python reads `out='sweeps/x': ...`, in the command line's words
    where they differ (`Problem.flag_message`: `add --resume`, not `add resume=True`)."""
    path = FLAGS.get(problem.path, problem.path)
    if problem.given is not None:
        path = f"{path} {problem.given}"
    return Problem(path, problem.flag_message or problem.message)


SHOWN_PROBLEMS = 50  # lines of bad input printed, at most (the library's error keeps them all)


@contextmanager
def reported(scenario: Path | None = None) -> Iterator[None]:
    """Map errors to exit codes: bad input 2 (a planner of one's own that raised or broke its
    contract too: its traceback, then one line), not controllable 3 (naming `scenario`), a
    record that could not be written 4."""
    try:
        yield
    except InputError as exc:
        for problem in exc.problems[:SHOWN_PROBLEMS]:
            error("error", flagged(problem).render(exc.source))
        if (more := len(exc.problems) - SHOWN_PROBLEMS) > 0:  # a 20,000-row table's
            where = f"{exc.source}: " if exc.source else ""
            error("error", f"{where}and {more:,} more problems (the first {SHOWN_PROBLEMS} shown)")
        raise typer.Exit(2) from None
    except NotControllableError as exc:
        for problem in exc.problems:
            error(
                "not controllable",
                f"{problem} (stratplan check {scenario} shows the ranks; --no-check skips this)",
            )
        raise typer.Exit(3) from None
    except RecordError as exc:
        error("error", str(exc))  # it says what could not be written, and where
        raise typer.Exit(4) from None
    except Exception as exc:  # a planner of one's own (STRATPLAN_PLANNERS) that broke
        from ..planner_contract import fault

        tb = exc.__traceback__  # its own frames only (stratplan's are no help to its author)
        while tb is not None and tb.tb_frame.f_globals.get("__name__", "").startswith(
            ("stratcli", "typer", "click", "contextlib")
        ):
            tb = tb.tb_next
        line = fault(exc, traceback_shown=tb is not None)
        if line is None:
            raise
        if tb is not None:
            import traceback

            text = "".join(traceback.format_exception(type(exc), exc, tb))
            err_console.print(escape(text.rstrip()), highlight=False)
        error("error", line)
        raise typer.Exit(2) from None


def fmt(x: float | None) -> str:
    """An energy for a table: grouped digits, scientific when large or when two decimals
    would read 0.00 (a short Lie leg's), "–" when unknown."""
    if x is None or x != x:
        return "–"
    if 0 < abs(x) < 0.005:
        return f"{x:.2e}"
    return f"{x:,.2f}" if abs(x) < 1e6 else f"{x:.3e}"


def fmt_error(x: float | None) -> str:
    """A goal error for a table ("–" when a numerical failure left none)."""
    return "–" if x is None else f"{x:.2e}"


def plan_footer(outcome, run_dir: Path) -> None:
    total = outcome.phases.get("total", {}).get("wall_s")  # since stratplan started
    checked = outcome.check_time  # None: planned without the check (--no-check)
    say(
        f"planned in {outcome.planning_time * 1e3:.0f} ms (model compiled in "
        f"{outcome.compile_time * 1e3:.0f} ms"
        f"{'' if checked is None else f', checked in {checked * 1e3:.0f} ms'})"
        f"{'' if total is None else f' · {total:.2f} s in all'} · {record(run_dir)}"
    )


def record(run_dir: Path) -> str:
    """`record: DIR` for a footer, and the animation when one was written (--animation)."""
    gif = Path(run_dir) / "motion.gif"
    animation = f" · animation: {gif}" if gif.is_file() else ""
    return escape(f"record: {run_dir}{animation}")
