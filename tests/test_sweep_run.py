"""Running sweeps: the same rows on 1 or 2 local processes, a Dask cluster and any executor;
rows written as tasks finish, so a sweep killed mid-way and resumed ends with the same table;
a task whose worker died is missing (not a row) and planned by --resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor

import pytest
from sweep_files import AUTO, GRID, strip, write

import stratcli
from stratcli.errors import InputError
from stratcli.records.sweepdir import ROWS, TABLE, read_rows
from stratcli.sweep import load_sweep, run_sweep

KILLED_GRID = """[sweep.grid]
"goal.q1" = { linspace = ["-pi/2", 0, 5] }
"goal.theta" = [-0.3, -0.2, "-pi/12"]
"""


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The small grid planned on 2 local processes."""
    tmp = tmp_path_factory.mktemp("reference")
    return run_sweep(load_sweep(write(tmp, GRID)), tmp / "out", jobs=2)


def _table(out) -> list[dict]:
    """results.csv without the timing columns, as text cells."""
    import csv

    with open(out / TABLE) as fh:
        rows = list(csv.DictReader(fh))
    return [{k: v for k, v in r.items() if k not in stratcli.sweep.TIMING_COLUMNS} for r in rows]


def test_rows_are_identical_on_one_and_two_processes(reference, tmp_path):
    one = run_sweep(load_sweep(write(tmp_path, GRID)), tmp_path / "one", jobs=1)
    assert reference.complete and one.complete
    assert all(r["status"] == "ok" for r in one.rows.values())
    assert strip(one.rows) == strip(reference.rows)  # bit for bit: floats compared exactly
    assert _table(tmp_path / "one") == _table(reference.out)
    assert one.summary["executor"] == {"kind": "process-pool", "workers": 1, "address": None}
    assert reference.summary["executor"]["workers"] == 2


def test_any_executor_gives_the_same_rows(reference, tmp_path):
    with ThreadPoolExecutor(2) as pool:
        threads = run_sweep(load_sweep(write(tmp_path, GRID)), tmp_path / "t", executor=pool)
    assert strip(threads.rows) == strip(reference.rows)
    assert threads.summary["executor"]["kind"] == "ThreadPoolExecutor"
    assert list(threads.rows) == list(range(len(threads.rows)))  # in task order, as the table


@pytest.mark.slow
def test_a_dask_cluster_gives_the_same_rows(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        path = write(tmp_path, GRID)
        scheduler = tmp_path / "scheduler.json"  # as `dask scheduler --scheduler-file` writes
        scheduler.write_text(
            json.dumps({"type": "Scheduler", "address": cluster.scheduler_address})
        )
        outcome = stratcli.run_sweep(path, tmp_path / "d", dask=str(scheduler))
        with distributed.Client(cluster) as client:  # workers' BLAS is single-threaded
            blas = client.run(lambda: os.environ.get("OPENBLAS_NUM_THREADS"))
    assert set(blas.values()) == {"1"}
    assert outcome.summary["executor"]["kind"] == "dask"
    assert outcome.summary["executor"]["workers"] == 2
    assert strip(outcome.rows) == strip(reference.rows)


@pytest.mark.slow
def test_a_dask_worker_writes_an_auto_mode_tasks_record(tmp_path):
    """A Dask worker is daemonic: drawing ranking.png beside the other figures started a
    process there, which raised, and the task's record was lost without a word."""
    distributed = pytest.importorskip("distributed")
    body = '[[sweep.task]]\n"goal.theta" = -0.2\n'
    path = write(tmp_path, body, scenario=AUTO, mode="auto", name="auto1")
    with distributed.LocalCluster(
        n_workers=1, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        outcome = stratcli.run_sweep(
            path, tmp_path / "d", dask=cluster.scheduler_address, records="all"
        )
    assert outcome.rows[0]["status"] == "ok"
    record = tmp_path / "d" / "records" / "task-000000"
    assert {"result.json", "comparison.json", "ranking.png"} <= {p.name for p in record.iterdir()}


class _DyingWorker(ThreadPoolExecutor):
    """Task 2's worker dies (its future fails, as with a killed process or KilledWorker),
    each time it is submitted (`deaths`: how many times at most)."""

    deaths = 10**9

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.submitted = []

    def submit(self, fn, payload, *args, **kwargs):
        self.submitted.append(payload["index"])
        if payload["index"] == 2 and self.submitted.count(2) <= self.deaths:
            future: Future = Future()
            future.set_exception(RuntimeError("worker died"))
            return future
        return super().submit(fn, payload, *args, **kwargs)


class _DyingOnce(_DyingWorker):
    deaths = 1


def test_a_task_whose_worker_died_is_submitted_once_more(reference, tmp_path):
    """A Dask worker killed under a task: the task runs again on another worker, and the
    sweep is complete (as a killed Dask worker's task is, where Dask reschedules it)."""
    with _DyingOnce(2) as pool:
        outcome = run_sweep(load_sweep(write(tmp_path, GRID)), tmp_path / "o", executor=pool)
    assert pool.submitted.count(2) == 2 and outcome.complete and not outcome.missing
    assert strip(outcome.rows) == strip(reference.rows)


def test_a_dead_worker_leaves_its_task_missing_and_resume_plans_it(reference, tmp_path):
    path = write(tmp_path, GRID)
    with _DyingWorker(2) as pool:
        first = run_sweep(load_sweep(path), tmp_path / "o", executor=pool)
    assert pool.submitted.count(2) == 2  # submitted once more, then left missing
    assert first.missing == [2] and not first.complete and 2 not in first.rows
    assert first.summary["missing"] == 1
    with pytest.raises(InputError, match="already holds a sweep"):
        run_sweep(load_sweep(path), tmp_path / "o", jobs=1)
    again = run_sweep(load_sweep(path), tmp_path / "o", jobs=1, resume=True)
    assert again.planned == 1 and again.resumed == 5 and again.complete
    assert strip(again.rows) == strip(reference.rows)


class _BreakingPool(ThreadPoolExecutor):
    """Refuses work after 3 tasks, as a process pool does once a worker was killed."""

    submitted = 0

    def submit(self, fn, *args, **kwargs):
        self.submitted += 1
        if self.submitted > 3:
            raise RuntimeError("pool broken")
        return super().submit(fn, *args, **kwargs)


def test_a_broken_pool_leaves_the_rest_missing_and_resume_plans_it(reference, tmp_path):
    path = write(tmp_path, GRID)
    with _BreakingPool(1) as pool:
        first = run_sweep(load_sweep(path), tmp_path / "o", executor=pool)
    assert sorted(first.rows) == [0, 1, 2] and first.missing == [3, 4, 5]
    again = run_sweep(load_sweep(path), tmp_path / "o", jobs=2, resume=True)
    assert again.planned == 3 and strip(again.rows) == strip(reference.rows)


def test_an_executor_that_refuses_the_first_task_is_an_error_naming_it(reference, tmp_path):
    """One shut down (a call after its `with` block) returned an empty outcome, every task
    missing, and said nothing; the directory stays as an interrupted sweep's."""
    path = write(tmp_path, GRID)
    pool = ThreadPoolExecutor(1)
    pool.shutdown()
    refused = r"^executor: refused the sweep's first task \(RuntimeError: cannot schedule new"
    with pytest.raises(RuntimeError, match=refused):
        run_sweep(load_sweep(path), tmp_path / "o", executor=pool)
    again = run_sweep(load_sweep(path), tmp_path / "o", jobs=1, resume=True)
    assert strip(again.rows) == strip(reference.rows)


def test_a_ctrl_c_a_finaliser_swallowed_stops_the_sweep_where_its_rows_are_kept(
    reference, tmp_path, monkeypatch
):
    """A Ctrl-C raised inside a finaliser is swallowed (kept by `interrupts`' hook); the
    sweep loop had no checkpoint, so it ran on and the command ended on `interrupted` alone,
    without the note of the rows kept and how to resume (1 run in 25)."""
    from stratcli import interrupts

    monkeypatch.setattr(interrupts, "_swallowed", [])

    def progress(done, total):
        if done >= 2:  # as the hook does with an Interrupted no one could raise
            interrupts._swallowed.append(signal.SIGINT)

    path = write(tmp_path, GRID)
    with pytest.raises(interrupts.Interrupted):  # (workers in threads would see it too)
        run_sweep(load_sweep(path), tmp_path / "o", jobs=1, progress=progress)
    kept = read_rows(tmp_path / "o" / ROWS)
    assert 2 <= len(kept) < 6
    interrupts._swallowed.clear()
    again = run_sweep(load_sweep(path), tmp_path / "o", jobs=1, resume=True)
    assert again.planned == 6 - len(kept) and strip(again.rows) == strip(reference.rows)


def test_resume_refuses_another_sweep(reference, tmp_path):
    other = write(tmp_path, GRID.replace("-0.2", "-0.1"))
    with pytest.raises(InputError, match="another sweep file"):
        run_sweep(load_sweep(other), reference.out, jobs=1, resume=True)


def _kill_after(command, out, rows: int, signum: int, times: int = 1) -> tuple[int, str]:
    """Run the sweep command until `rows` rows are written, then send it `signum` (`times`,
    1 ms apart); its exit code and what it printed on stderr."""
    # SIGINT as a terminal's Ctrl-C delivers it, even where this test was started ignoring it
    proc = subprocess.Popen(
        command,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while len(read_rows(out / ROWS)) < rows and time.monotonic() < deadline:
        assert proc.poll() is None, "the sweep ended before it could be killed"
        time.sleep(0.01)
    for i in range(times):  # (two at the same instant would be one pending signal)
        time.sleep(0.001 if i else 0.0)
        proc.send_signal(signum)
    return proc.wait(), proc.stderr.read()


@pytest.mark.slow
def test_one_interrupt_delivered_twice_still_says_how_to_resume(tmp_path):
    """`timeout -s INT` signals the command and then its process group: two SIGINTs at once,
    the second read as "leave now", so the --resume line was skipped and OUT/.writer left."""
    path = write(tmp_path, KILLED_GRID, objective="energy")
    out = tmp_path / "twice"
    command = [sys.executable, "-m", "stratcli", "sweep", str(path), "--out", str(out)]
    code, err = _kill_after([*command, "--jobs", "1"], out, 1, signal.SIGINT, times=2)
    assert code == 130 and err.endswith("interrupted\n"), err
    kept = len(read_rows(out / ROWS))
    assert f"sweep: {kept} of 15 tasks kept in {out}; stratplan sweep" in err, err
    assert not (out / ".writer").exists()


@pytest.mark.slow
def test_a_sweep_killed_mid_way_resumes_to_the_same_table(tmp_path):
    path = write(tmp_path, KILLED_GRID, objective="energy")
    whole = run_sweep(load_sweep(path), tmp_path / "whole", jobs=2)
    out = tmp_path / "killed"
    command = [sys.executable, "-m", "stratcli", "sweep", str(path), "--out", str(out)]
    code, err = _kill_after([*command, "--jobs", "1", "-q"], out, 2, signal.SIGINT)
    first = read_rows(out / ROWS)
    # how many rows it keeps and how to go on, before the one word (it stood alone)
    assert code == 130 and err.endswith("interrupted\n"), err
    again = f"stratplan sweep {path} --out {out} --resume --jobs 1 plans the rest"  # as given
    assert f"sweep: {len(first)} of 15 tasks kept in {out}; {again}" in err
    code, _ = _kill_after(
        [*command, "--jobs", "1", "-q", "--resume"], out, len(first) + 2, signal.SIGKILL
    )
    assert code == -signal.SIGKILL
    done = read_rows(out / ROWS)
    assert len(first) + 2 <= len(done) < 15  # killed mid-way: some rows, not all
    with open(out / ROWS, "ab") as fh:  # and as if killed while writing a row
        fh.write(b'{"index": 14, "status": "ok", "ener')
    resumed = subprocess.run([*command, "--resume", "--jobs", "2", "--json"], capture_output=True)
    assert resumed.returncode == 0, resumed.stderr.decode()
    summary = json.loads(resumed.stdout)
    assert summary["resumed_rows"] == len(done) and summary["done"] == 15
    assert _table(out) == _table(whole.out)
    assert strip(read_rows(out / ROWS)) == strip(whole.rows)


@pytest.mark.slow
def test_a_dead_dask_worker_loses_no_task(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        pids = list(client.run(os.getpid).values())
        killed = []

        def kill_one(done: int, total: int) -> None:  # SIGKILL a worker once 2 rows are in
            if done >= 2 and not killed:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])

        path = write(tmp_path, GRID)
        outcome = stratcli.run_sweep(
            path, tmp_path / "d", dask=cluster.scheduler_address, progress=kill_one
        )
    assert killed and outcome.complete  # Dask ran the dead worker's task again elsewhere
    assert strip(outcome.rows) == strip(reference.rows)


@pytest.mark.slow
def test_an_interrupted_dask_sweep_stops_as_interrupted_with_its_rows_kept(tmp_path):
    """Ctrl-C during a sweep on Dask ended on a TypeError (Dask's ClientExecutor.shutdown
    takes no cancel_futures), which hid the interrupt, so no resume note was printed."""
    distributed = pytest.importorskip("distributed")
    from stratcli.interrupts import Interrupted

    def interrupt(done: int, total: int) -> None:
        if done >= 1:
            raise Interrupted(signal.SIGINT)

    with distributed.LocalCluster(
        n_workers=1, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        with pytest.raises(Interrupted):
            stratcli.run_sweep(
                write(tmp_path, GRID), tmp_path / "d", dask=cluster.scheduler_address,
                progress=interrupt,
            )  # fmt: skip
    assert len(read_rows(tmp_path / "d" / ROWS)) >= 1


def test_a_bad_dask_scheduler_file_is_bad_input(tmp_path):
    (tmp_path / "scheduler.json").write_text("{}")
    with pytest.raises(InputError, match="not a readable Dask scheduler file"):
        stratcli.run_sweep(
            write(tmp_path, GRID), tmp_path / "o", dask=str(tmp_path / "scheduler.json")
        )


def test_local_workers_run_blas_single_threaded(monkeypatch):
    """A spawned worker's BLAS is single-threaded (a forked one's is this process's, which
    `_fork_is_safe` requires to be); the caller's environment is left as it was: a
    notebook's sweep set the variables in it for every process it started later."""
    variables = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    for var in variables:
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(stratcli.sweep.executors, "_fork_is_safe", lambda: False)
    with stratcli.sweep.local_executor(1) as pool:
        assert _start_method(pool) == "spawn"
        seen = pool.submit(os.getenv, "OPENBLAS_NUM_THREADS").result()
        assert pool.submit(stratcli.blas.limited).result()
    assert seen == "1" and not any(var in os.environ for var in variables)


def _start_method(pool) -> str:
    return pool._mp_context.get_start_method()


def test_workers_fork_only_when_no_thread_runs_and_blas_was_already_single(monkeypatch):
    """Forked workers start with this process's imports (fast); another thread here, or BLAS
    not limited before this process loaded numpy (`stratcli.blas.limited`), or a platform
    other than Linux, means fresh (spawned) interpreters."""
    run_module = stratcli.sweep.executors
    monkeypatch.setattr(run_module.blas, "limited", lambda: True)
    monkeypatch.setattr(run_module.threading, "active_count", lambda: 1)
    monkeypatch.setattr(run_module.sys, "platform", "linux")
    with stratcli.sweep.local_executor(1) as pool:
        assert _start_method(pool) == "fork"
    monkeypatch.setattr(run_module.blas, "limited", lambda: False)
    with stratcli.sweep.local_executor(1) as pool:
        assert _start_method(pool) == "spawn"
    monkeypatch.setattr(run_module.blas, "limited", lambda: True)
    monkeypatch.setattr(run_module.threading, "active_count", lambda: 2)
    with stratcli.sweep.local_executor(1) as pool:
        assert _start_method(pool) == "spawn"
    monkeypatch.setattr(run_module.threading, "active_count", lambda: 1)
    monkeypatch.setattr(run_module.sys, "platform", "darwin")
    with stratcli.sweep.local_executor(1) as pool:
        assert _start_method(pool) == "spawn"


def test_forked_and_spawned_workers_give_the_same_rows(monkeypatch, tmp_path):
    run_module = stratcli.sweep.executors
    rows = {}
    for how in (True, False):
        monkeypatch.setattr(run_module, "_fork_is_safe", lambda how=how: how)
        with stratcli.sweep.local_executor(2) as pool:
            assert _start_method(pool) == ("fork" if how else "spawn")
            out = run_sweep(load_sweep(write(tmp_path, GRID)), tmp_path / str(how), executor=pool)
        rows[how] = strip(out.rows)
    assert rows[True] == rows[False]  # bit for bit


PLANNER_MODULE = """
from stratcli.planners import NewtonPlanner


class Patient(NewtonPlanner):
    method = "patient-spawned"
"""
OWN_PLANNER_SCRIPT = """
import sys, threading, time
threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
import stratcli
{define}
outcome = stratcli.run_sweep(sys.argv[1], sys.argv[2], jobs=2, records="none")
for row in outcome.rows.values():
    print(row["status"], row["message"], flush=True)
"""


@pytest.mark.parametrize("where", ["module", "main"])
def test_spawned_workers_know_the_callers_own_leg_planners(tmp_path, where):
    """A user's own `LegPlanner` (README "Your own leg planner") was unknown to spawned and
    Dask workers: every task `invalid`. Its module is now imported there; a class defined in
    the main script cannot be, and the row says so, naming the leg."""
    from sweep_files import TASK_A

    (tmp_path / "my_planner.py").write_text(PLANNER_MODULE)
    legs = TASK_A.read_text().replace("[[legs]]\n", '[[legs]]\nmethod = "patient-spawned"\n')
    (tmp_path / "patient.toml").write_text(legs)
    sweep = write(tmp_path, TWO_TASKS, scenario=tmp_path / "patient.toml")
    define = "import my_planner" if where == "module" else PLANNER_MODULE
    (tmp_path / "script.py").write_text(OWN_PLANNER_SCRIPT.format(define=define))
    done = subprocess.run(
        [sys.executable, str(tmp_path / "script.py"), str(sweep), str(tmp_path / "out")],
        capture_output=True, text=True, cwd=tmp_path, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = done.stdout.splitlines()
    assert len(rows) == 2
    if where == "module":
        assert all(row.startswith("ok") for row in rows)
    else:
        said = "invalid legs[0].method: leg planner 'patient-spawned' is defined in its main"
        assert all(row.startswith(f"{said} script, which this worker") for row in rows)


# Another thread runs, so the workers are spawned (`_fork_is_safe`); the script has no
# `if __name__ == "__main__":` guard, and prints "main" once: no worker runs it again.
SCRIPT = """
import sys, threading, time
threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
import stratcli
from stratcli.sweep import executors
assert not executors._fork_is_safe()
print("main", flush=True)
outcome = stratcli.run_sweep(sys.argv[1], sys.argv[2], jobs=2, records="none")
print(outcome.complete, outcome.summary["counts"]["ok"], flush=True)
"""
TWO_TASKS = """[[sweep.task]]
"goal.q1" = -0.5

[[sweep.task]]
"goal.q1" = -0.4
"""


@pytest.mark.parametrize("how", ["stdin", "-c", "file"])
def test_spawned_workers_do_not_need_the_callers_main_module(tmp_path, how):
    """A script read from standard input (`python - <<EOF`: its __file__ is "<stdin>", no
    file a spawned worker could import), a notebook-like `python -c`, a script file."""
    args = [str(write(tmp_path, TWO_TASKS)), str(tmp_path / "out")]
    if how == "stdin":
        command, given = [sys.executable, "-", *args], SCRIPT
    elif how == "-c":
        command, given = [sys.executable, "-c", SCRIPT, *args], None
    else:
        (tmp_path / "script.py").write_text(SCRIPT)
        command, given = [sys.executable, str(tmp_path / "script.py"), *args], None
    done = subprocess.run(
        command, input=given, capture_output=True, text=True, cwd=tmp_path, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["main", "True 2"]
    assert "Traceback" not in done.stderr and "Error" not in done.stderr


def test_records_that_cannot_be_made_are_counted_and_shown(tmp_path, monkeypatch):
    """A record asked for that cannot be made loses no row, and is not lost without a word
    (a Dask worker's records were): sweep.json lists it with the reason, `show` says so."""
    from typer.testing import CliRunner

    import stratcli.api
    from stratcli.cli.app import app

    def broken(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(stratcli.api, "write_record", broken)
    with ThreadPoolExecutor(1) as pool:  # in this process: the patch applies
        outcome = run_sweep(load_sweep(write(tmp_path, GRID)), tmp_path / "o", executor=pool,
                            records="all")  # fmt: skip
    assert outcome.complete and all(r["status"] == "ok" for r in outcome.rows.values())
    lost = outcome.summary["records_lost"]
    assert [x["task"] for x in lost] == list(range(len(outcome.rows)))
    assert all(x["reason"] == "RuntimeError: disk on fire" for x in lost)
    assert json.loads((tmp_path / "o" / "sweep.json").read_text())["records_lost"] == lost
    shown = CliRunner().invoke(app, ["show", str(tmp_path / "o")])
    assert f"records  {len(lost)} asked for could not be made (task 0: RuntimeError" in (
        shown.output
    )


def test_records_an_earlier_run_could_not_make_stay_reported_after_resume(tmp_path, monkeypatch):
    """A resumed sweep rewrites sweep.json: the lost records of the tasks it keeps (not
    planned again) stay listed; those it plans now and makes are not."""
    import stratcli.api

    path, working = write(tmp_path, GRID), stratcli.api.write_record

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(stratcli.api, "write_record", broken)
    with _BreakingPool(1) as pool:  # tasks 0-2 planned, their records lost; 3-5 missing
        first = run_sweep(load_sweep(path), tmp_path / "o", executor=pool, records="all")
    assert [x["task"] for x in first.summary["records_lost"]] == [0, 1, 2]
    monkeypatch.setattr(stratcli.api, "write_record", working)
    with ThreadPoolExecutor(1) as pool:
        again = run_sweep(load_sweep(path), tmp_path / "o", executor=pool, records="all",
                          resume=True)  # fmt: skip
    assert again.complete and again.planned == 3
    assert again.summary["records_lost"] == first.summary["records_lost"]
    made = sorted(p.name for p in (tmp_path / "o" / "records").iterdir())
    assert made == ["task-000003", "task-000004", "task-000005"]


def test_the_best_tasks_record_made_on_resume_is_no_longer_reported_lost(tmp_path, monkeypatch):
    import stratcli.api

    path, working = write(tmp_path, GRID), stratcli.api.write_record
    monkeypatch.setattr(stratcli.api, "write_record", lambda *a, **k: 1 / 0)
    with ThreadPoolExecutor(1) as pool:
        first = run_sweep(load_sweep(path), tmp_path / "o", executor=pool, records="best")
    (lost,) = first.summary["records_lost"]
    rows = tmp_path / "o" / ROWS  # another task's row lost (a killed run): resume plans it
    kept = [x for x in rows.read_text().splitlines() if json.loads(x)["index"] != 5 - lost["task"]]
    rows.write_text("\n".join(kept) + "\n")
    monkeypatch.setattr(stratcli.api, "write_record", working)
    with ThreadPoolExecutor(1) as pool:
        again = run_sweep(load_sweep(path), tmp_path / "o", executor=pool, records="best",
                          resume=True)  # fmt: skip
    assert again.planned == 1 and again.summary["records_lost"] == []
    assert (tmp_path / "o" / "records" / f"task-{lost['task']:06d}").is_dir()


def test_a_sweep_directory_has_one_writer_at_a_time(tmp_path):
    """A second sweep (or --resume) into a directory a running sweep writes is refused: two
    at once (a CI retry beside the first) both planned every task, each row twice. A killed
    sweep's claim is taken over; a finished sweep leaves none."""
    from stratcli.records.rundir import _host_tag
    from stratcli.records.sweeplock import CLAIM

    path, out = write(tmp_path, TWO_TASKS), tmp_path / "out"
    out.mkdir()
    (out / CLAIM).write_text(f"{os.getpid()}@{_host_tag()}\n")  # a live writer's claim
    with ThreadPoolExecutor(1) as pool:
        with pytest.raises(InputError, match=r"out='.*': another sweep is writing into it \("):
            stratcli.run_sweep(path, out, executor=pool)
        assert sorted(p.name for p in out.iterdir()) == [CLAIM]  # nothing planned
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        (out / CLAIM).write_text(f"{dead.pid}@{_host_tag()}\n")  # a killed sweep's claim
        done = stratcli.run_sweep(path, out, executor=pool)
    assert done.complete and len(read_rows(out / ROWS)) == 2
    assert not (out / CLAIM).exists() and not list(out.glob(".writer*"))


def test_rows_read_back_are_in_task_order_with_the_tables_columns(reference, tmp_path):
    """rows.jsonl holds the rows as their tasks finished: read back (and from a finished
    sweep resumed) they are by task index, each with results.csv's columns in its order, so
    that a DataFrame of them is the table (two sweeps' frames compared unequal unsorted)."""
    import csv
    import shutil

    out = tmp_path / "out"
    shutil.copytree(reference.out, out)
    lines = (out / ROWS).read_text().splitlines()
    (out / ROWS).write_text("\n".join(reversed(lines)) + "\n")  # as if they finished so
    with open(out / TABLE) as fh:
        header = next(csv.reader(fh))
    resumed = run_sweep(load_sweep(write(tmp_path, GRID)), out, resume=True)
    for rows in (stratcli.read_sweep(out).rows, resumed.rows):
        assert list(rows) == sorted(rows) == list(range(len(lines)))
        for row in rows.values():
            assert list(row) == [c for c in header if c in row]


def test_a_local_pool_starts_no_more_workers_than_tasks_or_four_a_core(monkeypatch, tmp_path):
    """`--jobs 1000` had forked 816 processes for a sweep of 4 tasks on 2 cores."""
    from stratcli import trie

    monkeypatch.setattr(trie, "default_jobs", lambda: 2)
    assert trie.workers_for(1000, 4) == 4
    assert trie.workers_for(1000, 100) == trie.most_workers() == 8
    assert trie.workers_for(3, 100) == 3
    sweep = load_sweep(write(tmp_path, GRID))
    outcome = run_sweep(sweep, tmp_path / "o", jobs=1000)
    assert outcome.summary["executor"]["workers"] == min(sweep.count, 8)
