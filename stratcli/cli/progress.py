"""Progress of long work on stderr: a bar or a spinner on a terminal, plain lines in a log
(a CI job's, a file), nothing under --quiet or --json. Refreshed by hand, never by a thread
while workers fork."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TextColumn,
    TimeElapsedColumn,
)

from .render import err_console

__all__ = [
    "description_column",
    "phase_lines",
    "phases",
    "progress_bar",
    "progress_lines",
    "shown",
    "until_first_update",
]


def description_column() -> TextColumn:
    """A progress column showing the task's description as it is: no markup, no emoji (the
    description may quote user text, a scheduler address for one)."""
    return TextColumn("{task.description}", markup=False)


@contextmanager
def progress_bar(enabled: bool, waiting: str | None = None) -> Iterator[Any]:
    """A `progress(done, total)` callback drawing a bar on stderr (None when disabled; plain
    lines where stderr is no terminal, `progress_lines`), refreshed by hand: no refresh
    thread while workers fork. The bar appears with the first call; until then `waiting` is
    shown, if given (`until_first_update`)."""
    if not enabled or not err_console.is_terminal:
        yield progress_lines("planning sequences") if enabled else None
        return
    columns = (TextColumn("planning sequences"), BarColumn(), MofNCompleteColumn())
    bar = Progress(
        *columns, TimeElapsedColumn(), console=err_console, auto_refresh=False, transient=True
    )
    job = bar.add_task("plan", total=None)
    with until_first_update(bar, waiting) as show:

        def update(done: int, total: int) -> None:
            bar.update(job, completed=done, total=total)
            show()
            bar.refresh()

        yield update


@contextmanager
def until_first_update(bar: Progress, waiting: str | None) -> Iterator[Callable[[], None]]:
    """Yield `show()`, which starts `bar` (not started yet) the first time it is called.
    Until then nothing is drawn, or `waiting` beside a spinner and the time taken (refreshed
    by a thread, which `show` stops): connecting to a cluster is not progress at 0."""
    note = None
    if waiting is not None:
        columns = (SpinnerColumn(), description_column(), TimeElapsedColumn())
        note = Progress(*columns, console=err_console, transient=True)
        note.add_task(waiting, total=None)
        note.start()

    def show() -> None:
        nonlocal note
        if note is not None:
            note.stop()
            note = None
        if not bar.live.is_started:
            bar.start()

    try:
        yield show
    finally:
        if note is not None:
            note.stop()
        if bar.live.is_started:
            bar.stop()


@contextmanager
def phases(enabled: bool, log: bool = False) -> Iterator[Callable[[str], None] | None]:
    """A `progress(phase)` callback showing the phase of long work on stderr, with the time
    it has taken so far (None when disabled); the line goes away when the work is done.
    Where stderr is no terminal: nothing, or with `log` plain lines (`phase_lines`).

    Refreshed only when the phase changes: no refresh thread (planning may fork workers).
    """
    if not enabled or not err_console.is_terminal:
        yield phase_lines() if enabled and log else None
        return
    columns = (SpinnerColumn(), description_column(), TimeElapsedColumn())
    with Progress(*columns, console=err_console, auto_refresh=False, transient=True) as bar:
        jobs = []

        def update(phase: str) -> None:
            if jobs:
                bar.update(jobs[0], description=phase)
            else:
                jobs.append(bar.add_task(phase, total=None))
            bar.refresh()

        yield update


def phase_lines() -> Callable[[str], None]:
    """A `progress(phase)` callback for a log: each phase that begins once the work has run
    `LOG_FIRST` s is one plain line on stderr, `phase (elapsed)`, so that a minute of a
    constrained search shows in a CI log what it is doing; a short run prints nothing."""
    started = time.monotonic()

    def update(phase: str) -> None:
        now = time.monotonic() - started
        if now >= LOG_FIRST:
            err_console.print(
                f"{phase} ({_elapsed(now)})", highlight=False, soft_wrap=True, markup=False
            )

    return update


def _elapsed(seconds: float) -> str:
    minutes, seconds = divmod(int(seconds), 60)
    return f"{minutes} min {seconds} s" if minutes else f"{seconds} s"


def shown(quiet: bool, json_output: bool) -> bool:
    """Show progress at all: neither --quiet nor --json asked for silence (a bar on a
    terminal, plain lines in a log: `progress_bar`)."""
    return not (quiet or json_output)


LOG_FIRST, LOG_EVERY = 10.0, 30.0  # s: a log's first progress line, then at most one per


def progress_lines(label: str, unit: str = "") -> Callable[[int, int], None]:
    """A `progress(done, total)` callback for a log: one plain line on stderr, `label: done
    of total (elapsed)`, once the work has run `LOG_FIRST` s and then at most every
    `LOG_EVERY` s, so that a long run shows in a CI log that it is alive (a bar drawn there
    would be nothing, or escape codes) and a short one prints nothing."""
    started, last = time.monotonic(), [-math.inf]

    def update(done: int, total: int) -> None:
        now = time.monotonic()
        if now - started < LOG_FIRST or now - last[0] < LOG_EVERY:
            return
        last[0] = now
        err_console.print(
            f"{label}: {done} of {total}{unit} ({_elapsed(now - started)})",
            highlight=False,
            soft_wrap=True,
        )

    return update
