"""The drawing process (`records.drawing`) draws the same figures, and its failures fall back."""

from __future__ import annotations

import json
import multiprocessing
import os
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from stratcli.records import drawing
from stratcli.records.plots import render_plots
from stratcli.records.ranking import ranking_png
from stratcli.records.trajectory import sample

ROOT = Path(__file__).resolve().parents[1]
AUTO = ROOT / "scenarios" / "sim4_auto.toml"
TWO_CORES = len(os.sched_getaffinity(0)) >= 2 if hasattr(os, "sched_getaffinity") else False


def _python(script: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """`script` (dedented) run by a fresh interpreter with this checkout on its path: a
    process where matplotlib is not loaded yet, as the command's."""
    command = [sys.executable, "-c", textwrap.dedent(script), *args]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def comparison():
    import stratcli

    outcome = stratcli.compare_sequences(stratcli.load_scenario(AUTO), max_length=2, jobs=1)
    plan = outcome.best.result
    return plan, sample(plan), outcome.document


def _here(plan, traj, doc) -> dict[str, bytes]:
    files = render_plots(plan, traj, "sim4_auto", animation=False)
    return {**files, "ranking.png": ranking_png(doc)}


def test_figures_shared_between_two_processes_are_the_ones_drawn_here(comparison):
    plan, traj, doc = comparison
    files, fork_cpu = drawing._draw_shared(plan, traj, "sim4_auto", False, "png", doc)
    assert list(files) == ["configuration.png", "controls.png", "stroboscope.png", "ranking.png"]
    assert files == _here(plan, traj, doc)
    assert fork_cpu > 0  # the other process drew a part of them


def test_a_fork_that_fails_leaves_its_figures_to_the_drawing_process(comparison, monkeypatch):
    plan, traj, doc = comparison

    def failing_fork(makers):
        reader, writer = os.pipe()
        child = os.fork()
        if child == 0:  # pragma: no cover - the fork dies without an answer
            os._exit(1)
        os.close(writer)
        return reader, child

    monkeypatch.setattr(drawing, "_fork", failing_fork)
    files, fork_cpu = drawing._draw_shared(plan, traj, "sim4_auto", False, "png", doc)
    assert files == _here(plan, traj, doc) and fork_cpu == 0.0


def test_without_a_live_drawing_process_the_figures_are_drawn_here(comparison, monkeypatch):
    plan, traj, _ = comparison

    class Gone:
        def is_alive(self):
            return False

    here, _ = multiprocessing.Pipe()
    monkeypatch.setattr(
        drawing, "_DRAWER", {"process": Gone(), "connection": here, "owner": os.getpid()}
    )
    assert not drawing.running()
    assert drawing.ask(plan, traj, "x", False, "png")() is None
    # one that dies while it is waited for
    assert drawing._answer(here, Gone(), 1) is None


def test_an_answer_nobody_waited_for_is_not_taken_for_the_next_one():
    here, there = multiprocessing.Pipe()

    class Alive:
        def is_alive(self):
            return True

    there.send((1, "ok", {"controls.png": b"old"}, 0.1))  # a record that failed after asking
    there.send((2, "ok", {"controls.png": b"new"}, 0.2))
    assert drawing._answer(here, Alive(), 2) == ({"controls.png": b"new"}, 0.2)


def test_a_plan_that_cannot_be_handed_over_is_drawn_here(comparison, monkeypatch):
    plan, traj, _ = comparison

    class Alive:
        def is_alive(self):
            return True

    class Unpicklable:
        def send(self, job):
            raise TypeError("cannot pickle 'pinocchio.Model' object")

    monkeypatch.setattr(
        drawing, "_DRAWER", {"process": Alive(), "connection": Unpicklable(), "owner": os.getpid()}
    )
    assert drawing.running()
    assert drawing.ask(plan, traj, "x", False, "png")() is None


SCRIPT = """
import pickle, sys
import stratcli
from stratcli import api
task = stratcli.load_scenario(sys.argv[1])
assert api.draw_ahead()
outcome = stratcli.compare_sequences(task, max_length=2, jobs=1)
run = api.write_record(sys.argv[2], outcome, argv=["test"])
assert "matplotlib" not in sys.modules  # every figure was drawn by the drawing process
import os
from stratcli.records import drawing
mine = os.getpriority(os.PRIO_PROCESS, 0)  # it yields to the planner's processes
theirs = os.getpriority(os.PRIO_PROCESS, drawing._DRAWER["process"].pid)
assert theirs == min(mine + drawing.NICE, 19)
with open(sys.argv[3], "wb") as f:
    pickle.dump((str(run), outcome.best.result, outcome.document), f)
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_record_drawn_by_the_drawing_process_has_the_figures_drawn_here(tmp_path):
    dumped = tmp_path / "plan.pkl"
    done = _python(SCRIPT, str(AUTO), str(tmp_path / "runs"), str(dumped), timeout=300)
    assert done.returncode == 0, done.stderr
    run_dir, plan, doc = pickle.loads(dumped.read_bytes())
    expected = _here(plan, sample(plan), doc)
    for name, data in expected.items():
        assert (Path(run_dir) / name).read_bytes() == data, name
    phases = json.loads((Path(run_dir) / "manifest.json").read_text())["phases"]
    assert phases["plots"]["cpu_s"] > 0  # the drawing processes' CPU, not this one's


BESIDE_ONE = """
import os, time
from stratcli import api
from stratcli.records import drawing
assert api.draw_ahead(yielding=False)
mine, pid = os.getpriority(os.PRIO_PROCESS, 0), drawing._DRAWER["process"].pid
for _ in range(200):  # 2 s: a niced one sets its niceness first thing, before its imports
    theirs = os.getpriority(os.PRIO_PROCESS, pid)
    if theirs != mine:
        break
    time.sleep(0.01)
print(mine, theirs)
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_beside_one_planning_process_the_drawing_process_is_not_niced():
    """On a busy machine a niced drawer got a tenth of a core while `plan` waited for it."""
    done = _python(BESIDE_ONE)
    assert done.returncode == 0, done.stderr
    mine, theirs = map(int, done.stdout.split())
    assert theirs == mine


@pytest.mark.parametrize("legs", [True, False])
def test_plan_nices_the_drawing_process_only_beside_a_comparisons_workers(
    tmp_path, monkeypatch, legs
):
    from typer.testing import CliRunner

    from stratcli import api
    from stratcli.cli import app

    asked = []
    monkeypatch.setattr(api, "draw_ahead", lambda yielding=True: asked.append(yielding))
    scenario = ROOT / "scenarios" / ("sim4_task_d.toml" if legs else "sim4_auto.toml")
    if not legs:  # auto mode, kept short
        text = AUTO.read_text().replace("max_length = 3", "max_length = 2")
        scenario = tmp_path / "auto.toml"
        scenario.write_text(text)
    result = CliRunner().invoke(app, ["plan", str(scenario), "--out", str(tmp_path / "runs")])
    assert result.exit_code in (0, 1), result.output
    assert asked == [not legs]


STARTING = """
import signal, sys
from stratcli.__main__ import _on_signal
for sig in (signal.SIGINT, signal.SIGTERM):  # the command line's handlers
    signal.signal(sig, _on_signal)
from stratcli.records import drawing
for _ in range(5):
    drawing._DRAWER.clear()
    assert drawing.start()
    process = drawing._DRAWER["process"]
    process.terminate()  # as the exit does (multiprocessing's atexit), however soon it comes
    process.join(timeout=5)
    print(process.exitcode)
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_signal_while_the_drawing_process_starts_ends_it_quietly():
    done = _python(STARTING)
    # not the command line's handler raising in it (a traceback), nor a SIGTERM lost in it
    # (alive: the exit's join waits for ever)
    assert done.stdout.split() == ["-15"] * 5, done.stdout
    assert "Traceback" not in done.stderr, done.stderr


FORKED = """
import os
from stratcli.records import drawing
assert drawing.start() and drawing.running()
child = os.fork()
if child == 0:  # a worker forked later (a pool's): not the drawing process's owner
    code = 1
    try:
        code = 3 if drawing.running() or drawing.start() else 0
    finally:
        os._exit(code)
print(os.waitstatus_to_exitcode(os.waitpid(child, 0)[1]), drawing.running())
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_process_forked_from_the_command_does_not_take_its_drawing_process_for_its_own():
    done = _python(FORKED)
    # multiprocessing's is_alive() asserted in the fork: an AssertionError there (exit 1)
    assert done.stdout.split() == ["0", "True"], done.stdout + done.stderr


UNTAKEN = """
import sys
import stratcli
from stratcli import api
from stratcli.records import drawing
from stratcli.records.trajectory import sample
assert api.draw_ahead()
outcome = stratcli.compare_sequences(stratcli.load_scenario(sys.argv[1]), max_length=2, jobs=1)
plan = outcome.best.result
traj = sample(plan)
doc = dict(outcome.document, padding="x" * 4_000_000)  # a job larger than the pipe holds
drawing.ask(plan, traj, "t", False, "png", doc)  # a record that failed after asking
assert drawing._DRAWER["connection"].poll(120)  # its answer is drawn, being sent
print(drawing.ask(plan, traj, "t", False, "png", doc)(), drawing.running())
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_record_after_one_that_left_its_answer_is_drawn_here_not_deadlocked():
    # both processes sent into a full pipe, neither reading: the next record waited for ever
    done = _python(UNTAKEN, str(AUTO), timeout=90)
    assert done.stdout.split() == ["None", "False"], done.stdout + done.stderr


UNPICKLING = """
import os
from stratcli.records import drawing

HERE = os.getpid()


def rebuilt():
    if os.getpid() != HERE:  # as a C extension's object that does not unpickle elsewhere
        raise RuntimeError("cannot rebuild this object in another process")


class Plan:
    def __reduce__(self):
        return rebuilt, ()


assert drawing.start()
answer = drawing.ask(Plan(), None, "t", False, "png")()
process = drawing._DRAWER["process"]
process.join(timeout=30)  # it ends: the command draws the figures itself
print(answer, process.exitcode)
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_job_the_drawing_process_cannot_unpickle_is_drawn_here_without_a_traceback():
    done = _python(UNPICKLING)
    assert done.stdout.split() == ["None", "0"], done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr


BESIDE = """
import signal, time
from stratcli.__main__ import _on_signal
for sig in (signal.SIGINT, signal.SIGTERM):  # the command line's handlers
    signal.signal(sig, _on_signal)
from stratcli.records import drawing
for _ in range(5):
    get, stop = drawing.beside(time.sleep, 30)
    stop()  # at once: the worker may not have set its own handlers yet
print("stopped")
"""


@pytest.mark.skipif(not TWO_CORES or sys.platform != "linux", reason="forks on two cores")
def test_a_worker_stopped_as_it_starts_ends_quietly():
    done = _python(BESIDE)
    assert done.stdout.split() == ["stopped"], done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr  # the parent's handler raised in it


def _beside_in_this_process(queue) -> None:
    value, stop = drawing.beside(abs, -3)
    try:
        queue.put(value())
    finally:
        stop()


def test_a_daemonic_process_such_as_a_dask_worker_computes_beside_work_itself():
    # A daemonic process may not start children: a Dask worker writing a sweep task's
    # comparison record (ranking.png is drawn beside the other figures) lost the record.
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    process = context.Process(target=_beside_in_this_process, args=(queue,), daemon=True)
    process.start()
    process.join(60)
    assert process.exitcode == 0
    assert queue.get(timeout=5) == 3
