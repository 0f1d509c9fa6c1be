"""A process that draws a record's figures while the command plans (the command line's runs).

A command that writes a record used to import matplotlib (0.3-0.5 s) and draw the figures
(0.3-0.4 s; a comparison's ranking.png as much again) after the plan was done, when nothing
else runs. `start()`, called by the command once it knows it will write a record, forks a
process that imports the figure modules meanwhile and waits. `ask()` hands it the plan and
its samples; it draws the figures in two processes (itself and a fork of itself, the work
shared by its expected cost) while this process builds the record's other files, and sends
back their bytes: the same bytes as drawn here (`plots.draw`, `ranking.ranking_png`; tested).

Nothing changes where it cannot help or is not there: no fork (not Linux/macOS), one core,
matplotlib already loaded in this process (a notebook, the tests), `start()` not called (the
library), the process gone or failed, or ended because a record asked and never took the
answer (it failed meanwhile; the next job could not be sent while the answer is). `ask()`
then returns None and the figures are drawn here as before; a failure of drawing itself is
then raised here, as it always was.

The process dies with this one and leaves SIGINT to it (`trie.worker_init`); a signal that
comes while it starts waits until its own handlers are set, not those of this process it
was forked with (a traceback, or a SIGTERM lost and the exit's wait for it never ending).
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

from ..interrupts import checkpoint, signals_held

__all__ = ["ask", "beside", "running", "start"]

# expected drawing time relative to a time plot, to share the figures out between two processes
COST = {"ranking": 1.4, "motion": 30.0, "stroboscope": 1.2}

# The drawing process's niceness where it yields: loading matplotlib beside a comparison's two
# workers took their CPU (the search 1.34 -> 1.22 s median wall with it, compare-sequences on
# Sim 4, 10 alternating runs); drawing happens when the planner is done, and the figures are
# the same. Beside one planning process (`plan` with legs) it does not yield: nothing of the
# command's competes with it on a second core, and on a busy machine a niced drawer got a
# tenth of a core while the command waited for its figures (a URDF plan of 0.1-0.25 s beside
# two busy processes on 2 cores: the plots 17-19 s against 2.3-3.6 s un-niced, the command
# 21-23 s against 6.4-7.9 s)
NICE = 10

_DRAWER: dict[str, Any] = {}  # "process", "connection", "owner" (its pid) once started


def start(yielding: bool = True) -> bool:
    """Fork the drawing process (at most once per process), at `NICE` if `yielding`; True if
    it runs."""
    if _DRAWER:
        return running()
    if "matplotlib" in sys.modules or not _beside_possible():
        return False
    context = multiprocessing.get_context("fork")
    here, there = context.Pipe()
    process = context.Process(
        target=_serve,
        args=(there, here, os.getpid(), NICE if yielding else 0),
        name="stratplan-drawing",
        daemon=True,
    )
    with signals_held():  # none reaches it before it sets its own handlers (`_serve`)
        process.start()
    there.close()
    _DRAWER.update(process=process, connection=here, owner=os.getpid())
    return True


def running() -> bool:
    """Whether this process started a drawing process that still runs (not: a process
    forked from the one that did, which cannot ask it: False there)."""
    return bool(_DRAWER) and _DRAWER["owner"] == os.getpid() and _DRAWER["process"].is_alive()


def ask(
    plan, traj, title: str, animation: bool, fmt: str, ranking: dict | None = None
) -> Callable[[], tuple[dict[str, bytes], float] | None]:
    """Have the drawing process draw `plots.render_plots(plan, traj, title, animation, fmt)`
    and, with a comparison's document `ranking`, its ranking chart.

    Returns a function that waits for ({file name: bytes}, CPU seconds the drawing took) and
    gives None where the figures must be drawn here (no process, or it failed)."""
    if not running():
        return lambda: None
    if _DRAWER.get("pending"):  # a record asked and failed before taking the answer
        _stop()  # which it may be sending: both would wait on a full pipe for ever
        return lambda: None
    connection = _DRAWER["connection"]
    number = _DRAWER["asked"] = _DRAWER.get("asked", 0) + 1
    try:  # pickled whole before a byte is written: a failure leaves the pipe as it was
        connection.send((number, (plan, traj, title, animation, fmt, ranking)))
    except Exception:  # gone, or something in the plan that does not pickle: drawn here
        return lambda: None
    _DRAWER["pending"] = number
    return lambda: _taken(connection, _DRAWER["process"], number)


def _taken(connection, process, number: int) -> tuple[dict[str, bytes], float] | None:
    """`_answer`, the job no longer pending once it is read (not if waiting is interrupted)."""
    answer = _answer(connection, process, number)
    _DRAWER["pending"] = None
    return answer


def _stop() -> None:
    """End the drawing process (its fork dies with it): the figures are drawn here."""
    process = _DRAWER["process"]
    process.terminate()
    process.join(timeout=5.0)
    if process.is_alive():  # pragma: no cover - SIGTERM is not ignored there
        process.kill()
        process.join()
    _DRAWER["connection"].close()


def _answer(connection, process, number: int) -> tuple[dict[str, bytes], float] | None:
    """Wait for the drawing process's answer to job `number` (as long as it lives: a GIF
    can take a while); answers to earlier jobs nobody waited for are dropped."""
    try:
        while True:
            while not connection.poll(0.2):
                checkpoint()
                if not process.is_alive():
                    return None
            answered, kind, *value = connection.recv()
            if answered == number:
                return (value[0], value[1]) if kind == "ok" else None
    except Exception:  # gone mid-answer, or an answer that does not unpickle: drawn here
        return None


def _beside_possible() -> bool:
    """Whether a process can work beside this one: fork, a second core (else it would take
    the planner's only one), and a process allowed children (a Dask worker is daemonic:
    starting one there raised, and a sweep's task lost its record)."""
    from ..trie import default_jobs

    if multiprocessing.current_process().daemon:
        return False
    return "fork" in multiprocessing.get_all_start_methods() and default_jobs() >= 2


def beside(func: Callable, *args) -> tuple[Callable[[], Any], Callable[[], None]]:
    """Start `func(*args)` in a forked process (one that dies with this one and leaves
    SIGINT to it, `trie.worker_init`); returns (a function that waits for its value, one
    that ends the process). Where there is no fork (or only one core), `func` runs when its
    value is asked for."""
    from concurrent.futures import ProcessPoolExecutor

    from ..trie import stop_workers, submit, worker_init

    if not _beside_possible():
        return (lambda: func(*args)), (lambda: None)
    pool = ProcessPoolExecutor(
        max_workers=1,
        mp_context=multiprocessing.get_context("fork"),
        initializer=worker_init,
        initargs=(os.getpid(),),
    )
    future = submit(pool, func, *args)
    return future.result, lambda: stop_workers(pool, [future])


# --------------------------------------------------------------------------------------------
# In the drawing process
# --------------------------------------------------------------------------------------------


def _serve(connection, parents_end, parent: int, nice: int) -> None:
    """Import the figure modules, then draw what is asked until the command ends."""
    from ..trie import worker_init

    worker_init(parent)  # which lets in the signals held since the fork (`start`)
    parents_end.close()
    try:  # it yields to the planner's processes (a comparison's workers); alone, it runs
        if nice:
            os.nice(nice)
    except (AttributeError, OSError):  # pragma: no cover - no nice here
        pass
    _warm_up()
    while True:
        try:
            number, job = connection.recv()
        except Exception:  # the command gone, or a job that does not unpickle here: ended
            return  # quietly (no traceback), and the command draws the figures itself
        cpu = time.process_time()
        try:
            files, other = _draw_shared(*job)
            answer = (number, "ok", files, time.process_time() - cpu + other)
        except Exception:  # drawn again in the command, which reports it as it always did
            answer = (number, "error", traceback.format_exc())
        try:
            connection.send(answer)
        except (OSError, ValueError):
            return


def _warm_up() -> None:
    """Import what drawing needs and draw a small figure (fonts, the Agg canvas loaded)."""
    from matplotlib.figure import Figure

    from . import plots, ranking  # noqa: F401 - imported for the figures to come
    from .figure_common import save_figure

    fig = Figure(figsize=(1.0, 1.0))
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_title("stratplan")
    save_figure(fig)


def _makers(plan, traj, title, animation, fmt, ranking) -> list[tuple[str, Callable, bool]]:
    """(file name, function drawing it, whether a ValueError leaves the figure out)."""
    from .plots import plot_makers
    from .ranking import ranking_png

    plotted = plot_makers(plan, traj, title, animation, fmt)
    makers = [(name, make, True) for name, make in plotted.items()]
    if ranking is not None:
        makers.append((f"ranking.{fmt}", lambda: ranking_png(ranking, fmt), False))
    return makers


def _draw_shared(*job) -> tuple[dict[str, bytes], float]:
    """Draw the job's figures in this process and a fork of it; returns the files (in the
    order `render_plots` gives them) and the fork's CPU seconds."""
    makers = _makers(*job)
    mine, theirs = _share(makers)
    reader, child = (None, 0) if not theirs else _fork(theirs)
    files = _draw(mine)
    other_files, other_cpu = _collect(reader, child) if theirs else ({}, 0.0)
    if theirs and other_files is None:  # the fork failed: draw its part here
        other_files, other_cpu = _draw(theirs), 0.0
    drawn = {**files, **other_files}
    order = [name for name, _, _ in makers]
    return {name: drawn[name] for name in order if name in drawn}, other_cpu


def _share(makers: list) -> tuple[list, list]:
    """Split the figures between two processes by expected cost, largest first."""

    def cost(name: str) -> float:
        return next((c for key, c in COST.items() if name.startswith(key)), 1.0)

    parts: tuple[list, list] = ([], [])
    loads = [0.0, 0.0]
    for maker in sorted(makers, key=lambda m: -cost(m[0])):
        k = 0 if loads[0] <= loads[1] else 1
        parts[k].append(maker)
        loads[k] += cost(maker[0])
    return parts


def _draw(makers: list) -> dict[str, bytes]:
    from .plots import draw

    files = draw({name: make for name, make, skip in makers if skip})
    files.update({name: make() for name, make, skip in makers if not skip})
    return files


def _fork(makers: list) -> tuple[int, int]:
    """Draw `makers` in a forked process that writes (files, its CPU) to a pipe."""
    reader, writer = os.pipe()
    server = os.getpid()
    child = os.fork()
    if child == 0:  # pragma: no cover - runs in the fork (its result is what is tested)
        code = 1
        try:
            os.close(reader)
            from ..trie import worker_init

            worker_init(server)
            cpu = time.process_time()
            data = pickle.dumps((_draw(makers), time.process_time() - cpu))
            with os.fdopen(writer, "wb") as out:
                out.write(data)
            code = 0
        finally:
            os._exit(code)
    os.close(writer)
    return reader, child


def _collect(reader: int, child: int) -> tuple[dict[str, bytes] | None, float]:
    """The fork's (files, CPU seconds), or (None, 0) when it failed."""
    with os.fdopen(reader, "rb") as answer:
        data = answer.read()
    _, status = os.waitpid(child, 0)
    if status != 0 or not data:
        return None, 0.0
    try:
        return pickle.loads(data)
    except Exception:
        return None, 0.0
