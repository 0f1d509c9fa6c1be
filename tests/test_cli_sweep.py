"""`stratplan sweep` and `stratplan show SWEEPDIR`: the summary, --json, records, plots."""

from __future__ import annotations

import csv
import json

import pytest
from conftest import plan_record
from sweep_files import AUTO, GRID, RANDOM, write
from typer.testing import CliRunner

import stratcli
from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.records.store import read_record

runner = CliRunner()


def test_sweep_writes_table_summary_plots_and_the_records_asked_for(tmp_path):
    path = write(tmp_path, GRID, scenario=AUTO, mode="auto")
    out = tmp_path / "grid"
    result = runner.invoke(
        app, ["sweep", str(path), "--out", str(out), "--jobs", "2", "--records", "best", "--json"]
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["done"] == summary["tasks"] == 6 and summary["counts"]["ok"] == 6
    assert summary["success_rate"] == 1.0 and summary["executor"]["workers"] == 2
    assert summary["wall_time_s"] > 0 and sum(summary["sequences"].values()) == 6
    assert summary["plots"] == ["energy_map.png", "sequence_map.png"]
    for name in summary["plots"]:
        assert (out / name).read_bytes().startswith(b"\x89PNG")
    with open(out / "results.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [int(r["index"]) for r in table] == list(range(6))
    best = min(table, key=lambda r: float(r["energy"]))
    assert summary["best"]["index"] == int(best["index"])
    records = list((out / "records").iterdir())  # only the best task's
    assert [p.name for p in records] == [f"task-{int(best['index']):06d}"]
    record = read_record(records[0])
    assert record.result["total_energy"] == float(best["energy"])

    shown = runner.invoke(app, ["show", str(out)])
    assert shown.exit_code == 0, shown.output
    assert "6 of 6 tasks done" in shown.output and "success 100.0 %" in shown.output
    assert "results.csv" in shown.output and "records  1" in shown.output
    as_json = json.loads(runner.invoke(app, ["show", str(out), "--json"]).output)
    assert as_json["best"] == summary["best"]


def test_random_sweep_histogram_and_records_of_all_tasks(tmp_path):
    path = write(tmp_path, RANDOM)
    out = tmp_path / "random"
    result = runner.invoke(
        app, ["sweep", str(path), "--out", str(out), "--jobs", "1", "--records", "all"]
    )
    assert result.exit_code == 0, result.output
    assert "4 of 4 tasks done" in result.output and "process-pool, 1 worker:" in result.output
    assert (out / "energy_hist.png").read_bytes().startswith(b"\x89PNG")
    assert len(list((out / "records").iterdir())) == 4


def test_show_of_an_unfinished_sweep_counts_its_rows(tmp_path):
    path = write(tmp_path, GRID)
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "-q"]).exit_code == 0
    summary = json.loads((out / "sweep.json").read_text())
    (out / "sweep.json").write_text(json.dumps({**summary, "missing": 2}))  # interrupted
    shown = " ".join(runner.invoke(app, ["show", str(out)]).output.split())
    # the sweep file to resume with is named (it said "stratplan sweep FILE ...")
    assert f"missing 2 tasks (stratplan sweep {path} --out {out} --resume)" in shown
    (out / "sweep.json").unlink()  # as if killed before the end
    lines = (out / "rows.jsonl").read_text().splitlines()
    (out / "rows.jsonl").write_text("\n".join(lines[:4]) + "\n")
    shown = runner.invoke(app, ["show", str(out)])
    assert shown.exit_code == 0 and "4 of 6 tasks done" in shown.output
    assert "not finished" in shown.output
    jsonschema = pytest.importorskip("jsonschema")  # its --json is a sweep.json by its schema
    doc = json.loads(runner.invoke(app, ["show", str(out), "--json"]).stdout)
    jsonschema.validate(doc, stratcli.record_schema("sweep"))  # ('executor' was missing)
    assert doc["done"] == 4 and doc["executor"] is None and doc["records_lost"] == []
    resumed = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    text = " ".join(resumed.output.split())
    assert "2 tasks in" in text and "; 4 more from an earlier run (--resume)" in text


def test_the_resume_hint_of_show_names_the_sweep_file_from_where_show_runs(tmp_path, monkeypatch):
    """Swept as `sweep small.toml` in its folder, `show` from elsewhere said `stratplan sweep
    small.toml --out ... --resume`, which cannot read the file from there."""
    (tmp_path / "my").mkdir()
    write(tmp_path / "my", GRID)
    monkeypatch.chdir(tmp_path / "my")
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", "small.toml", "--out", str(out), "-q"]).exit_code == 0
    summary = json.loads((out / "sweep.json").read_text())
    (out / "sweep.json").write_text(json.dumps({**summary, "missing": 2}))  # interrupted
    shown = " ".join(runner.invoke(app, ["show", str(out)]).output.split())
    assert f"(stratplan sweep small.toml --out {out} --resume)" in shown  # from its folder
    monkeypatch.chdir(tmp_path)
    shown = " ".join(runner.invoke(app, ["show", "o"]).output.split())
    assert "(stratplan sweep my/small.toml --out o --resume)" in shown
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    shown = " ".join(runner.invoke(app, ["show", str(out)]).output.split())
    file = (tmp_path / "my" / "small.toml").resolve()
    assert f"(stratplan sweep {file} --out {out} --resume)" in shown


def test_a_finished_sweep_is_not_run_again_and_resume_only_reprints_it(tmp_path):
    path = write(tmp_path, GRID)
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "-q"]).exit_code == 0
    written = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    again = runner.invoke(app, ["sweep", str(path), "--out", str(out)])
    assert again.exit_code == 2
    assert again.stderr.splitlines() == [
        f"error: --out {out}: already holds a finished sweep (6 tasks, all done); --resume "
        f"would only print its summary again (as stratplan show {out} does); choose another "
        "--out to run it again"
    ]
    resumed = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    assert "6 of 6 tasks done" in resumed.stdout and "6 tasks in" in resumed.stdout
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == written
    assert resumed.stderr == ""
    # --records asked of a finished sweep makes nothing: it says so (it was silent)
    best = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--resume", "--records",
                               "best"])  # fmt: skip
    assert best.exit_code == 0 and not (out / "records").exists()
    assert best.stderr.startswith("note: --records best made no record: the sweep was finished")
    none = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--resume", "--records",
                               "none"])  # fmt: skip
    assert none.exit_code == 0 and none.stderr == ""  # none asked, none made: nothing to say


def test_python_callers_read_the_arguments_where_the_command_line_reads_flags(tmp_path):
    """The same refusals from `stratcli.run_sweep` name `out` and `resume=True`, which the
    command line shows as --out and --resume (`cli.render.flagged`)."""
    path = write(tmp_path, GRID)
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "-q"]).exit_code == 0
    with pytest.raises(InputError) as info:
        stratcli.run_sweep(path, out)
    assert str(info.value) == (
        f"out={str(out)!r}: already holds a finished sweep (6 tasks, all done); resume=True "
        "would only return it again (as stratcli.read_sweep reads it); choose another out to "
        "run it again"
    )
    other = write(tmp_path, GRID.replace("-0.2", "-0.1"), name="other")
    why = f"{out} holds the sweep of another sweep file (or a changed one); use the same file"
    with pytest.raises(InputError) as info:
        stratcli.run_sweep(other, out, resume=True)
    assert str(info.value) == f"resume: {why}, or another out"
    result = runner.invoke(app, ["sweep", str(other), "--out", str(out), "--resume"])
    assert result.exit_code == 2
    assert result.stderr.splitlines() == [f"error: --resume: {why}, or another --out"]


def test_an_unfinished_sweep_says_how_far_it_got(tmp_path):
    path = write(tmp_path, GRID)
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "-q"]).exit_code == 0
    lines = (out / "rows.jsonl").read_text().splitlines()
    (out / "rows.jsonl").write_text("\n".join(lines[:4]) + "\n")
    again = runner.invoke(app, ["sweep", str(path), "--out", str(out)])
    assert again.exit_code == 2
    assert again.stderr.splitlines() == [
        f"error: --out {out}: already holds a sweep, unfinished (4 of 6 tasks done); add "
        "--resume to finish it, or choose another --out"
    ]


def test_a_sweep_killed_before_its_summary_is_called_so_and_resume_writes_it(tmp_path):
    """Every row, no sweep.json: not "unfinished (6 of 6 tasks done)", and --resume plans
    nothing but writes the summary, after which the sweep is finished."""
    path = write(tmp_path, GRID)
    out = tmp_path / "o"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "-q"]).exit_code == 0
    rows = (out / "rows.jsonl").read_bytes()
    (out / "sweep.json").unlink()  # killed after the last row
    again = runner.invoke(app, ["sweep", str(path), "--out", str(out)])
    assert again.exit_code == 2
    assert again.stderr.splitlines() == [
        f"error: --out {out}: already holds a sweep, all tasks done, its summary not written; "
        "--resume writes it (or choose another --out)"
    ]
    resumed = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--resume", "--json"])
    assert resumed.exit_code == 0, resumed.output
    summary = json.loads(resumed.stdout)
    assert summary["done"] == 6 and summary["planned_this_run"] == 0
    assert (out / "sweep.json").is_file()
    assert (out / "rows.jsonl").read_bytes() == rows
    finished = runner.invoke(app, ["sweep", str(path), "--out", str(out)])
    assert finished.exit_code == 2 and "already holds a finished sweep" in finished.stderr


def test_a_directory_of_other_files_is_refused_as_out(tmp_path):
    plan_record(tmp_path / "runs")  # a run record, as `stratplan plan` leaves in runs/
    before = sorted(p.name for p in (tmp_path / "runs").iterdir())
    path = write(tmp_path, GRID)
    for resume in ([], ["--resume"]):
        result = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "runs"), *resume])
        assert result.exit_code == 2, result.output
        (line,) = result.stderr.splitlines()
        assert line.startswith(f"error: --out {tmp_path / 'runs'}: not a sweep directory and not")
        assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == before


def test_a_bad_sweep_file_reports_its_schema_and_value_problems_in_one_run(tmp_path):
    """A user fixing the file sees every problem at once: an unknown key of [sweep] beside a
    grid key naming no coordinate and a bound that is no number, one `error:` line each."""
    body = '[sweep.grid]\n"goal.q9" = [1]\n"goal.q1" = { linspace = ["-pi/zz", 0, 3] }\n'
    path = write(tmp_path, f'colour = "red"\n{body}', scenario=AUTO, mode="auto")
    result = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert result.stderr.splitlines() == [
        f"error: {path}: sweep.colour: unknown key (allowed: name, description, scenario, mode, "
        "check, exhaustive, set, grid, random, task)",
        f"error: {path}: sweep.grid.\"goal.q9\": unknown coordinate 'q9' (this model has: q1, "
        "q2, q3, theta)",
        f"error: {path}: sweep.grid.\"goal.q1\".linspace[0]: in '-pi/zz': unknown name 'zz' "
        "(only numbers, pi (π), E, + - * / ** and the functions abs, acos, asin, atan, atan2, "
        "cos, cosh, exp, log, sin, sinh, sqrt, tan, tanh) (got '-pi/zz')",
    ]
    assert not (tmp_path / "o").exists()


def test_a_file_with_hundreds_of_problems_prints_the_first_fifty(tmp_path):
    """Every task row is checked: a bad 120-row table printed 120 lines (20,000 for 20,000
    rows); the command prints the first 50 and how many more there are."""
    rows = "".join(f'[[sweep.task]]\n"goal.q1" = "bad{i}"\n' for i in range(120))
    path = write(tmp_path, rows)
    result = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "o")])
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 51
    assert lines[49].startswith(f"error: {path}: sweep.task[49].")
    assert lines[50] == f"error: {path}: and 70 more problems (the first 50 shown)"


def test_failure_reasons_count_alike_messages_together_most_common_first():
    """Messages that differ only in their numbers are one kind, with its first task."""
    from stratcli.sweep.outputs import MAX_REASONS, failure_reasons

    rows = {
        0: {"status": "failed", "message": "leg 1 did not reach its goal (error 0.25)"},
        1: {"status": "ok", "message": ""},
        2: {"status": "invalid", "message": "goal.q1: must be a number"},
        3: {"status": "failed", "message": "leg 2 did not reach its goal (error 1.5e-2)"},
        4: {"status": "error", "message": "leg 2 did not reach its goal (error 0.3)"},
    }
    kinds = failure_reasons(rows)
    assert kinds[0] == {
        "status": "failed", "tasks": 2, "first": 0, "message": rows[0]["message"]
    }  # fmt: skip
    assert [(k["status"], k["first"]) for k in kinds[1:]] == [("invalid", 2), ("error", 4)]
    many = {k: {"status": "failed", "message": f"reason {'abcdefg'[k]}"} for k in range(7)}
    assert len(failure_reasons(many)) == MAX_REASONS
    assert failure_reasons({1: rows[1]}) == []


def test_a_sweep_whose_tasks_fail_says_why_in_its_summary_and_sweep_json(tmp_path):
    """A new user's sweep whose every task failed printed only "status 2 failed"; the
    reasons were in results.csv alone. Newton with one iteration and no restart cannot reach
    the goals."""
    path = write(tmp_path, '[sweep.grid]\n"goal.q1" = [-0.5, -0.4]\n')
    one = '"planner.objective" = "newton", "planner.max_iterations" = 1, "planner.restarts" = 0'
    path.write_text(path.read_text().replace('"planner.objective" = "newton"', one))
    out = tmp_path / "failing"
    result = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["counts"]["failed"] == 2 and summary["failures"][0]["tasks"] == 2
    message = summary["failures"][0]["message"]
    with open(out / "results.csv") as fh:
        assert message == next(csv.DictReader(fh))["message"]  # task 0's
    shown = runner.invoke(app, ["show", str(out)], terminal_width=400)
    line = next(line for line in shown.output.splitlines() if line.strip().startswith("why"))
    assert "2 failed (task 0 and 1 more like it): " in line and message[:60] in line
    # cut at a word, saying where the whole message is (it was cut mid-word, its advice lost)
    if len(message) > 240:
        assert line.endswith(" … (in full: results.csv)")


def test_a_compare_mode_row_ranks_the_searched_sequences_and_lists_the_bounded_apart(tmp_path):
    """The row's ranking listed all 18 of Sim 4's sequences as "a > b > ...", though the
    screen searched one; those it bounded are not ranked among themselves."""
    body = '[sweep.grid]\n"goal.q1" = [-1.0]\n'
    path = write(tmp_path, body, scenario=AUTO, mode="compare", objective="energy")
    out = tmp_path / "c"
    assert runner.invoke(app, ["sweep", str(path), "--out", str(out), "--jobs", "1"]).exit_code == 0
    with open(out / "results.csv") as fh:
        (row,) = csv.DictReader(fh)
    ranked, bounded = row["ranking"].split("; bounded: ")
    assert len(ranked.split(" > ")) == int(row["reached"])
    assert len(ranked.split(" > ")) + len(bounded.split("), (")) == int(row["candidates"])


def test_strict_sweeps_exit_1_when_a_task_did_not_plan(tmp_path):
    """A sweep with failed tasks exits 0 (a failed task is a row like any other): a CI job
    could not fail on them. --strict exits 1 and says how many, --quiet or not."""
    body = (
        '[[sweep.task]]\n"planner.max_iterations" = 1\n"planner.restarts" = 0\n\n'
        '[[sweep.task]]\n"planner.max_iterations" = 100\n"planner.restarts" = 11\n'
    )
    path = write(tmp_path, body)
    plain = runner.invoke(
        app, ["sweep", str(path), "--out", str(tmp_path / "a"), "--jobs", "1", "-q"]
    )
    assert plain.exit_code == 0, plain.output
    counts = json.loads((tmp_path / "a" / "sweep.json").read_text())["counts"]
    assert counts["ok"] == 1 and sum(counts.values()) == 2
    args = ["sweep", str(path), "--out", str(tmp_path / "b"), "--jobs", "1", "-q", "--strict"]
    strict = runner.invoke(app, args)
    assert strict.exit_code == 1
    assert strict.stderr.strip() == "failed: 1 task did not plan (--strict)"
    ok = write(tmp_path, '[[sweep.task]]\n"planner.max_iterations" = 100\n', name="fine")
    args = ["sweep", str(ok), "--out", str(tmp_path / "c"), "--jobs", "1", "-q", "--strict"]
    assert runner.invoke(app, args).exit_code == 0


def test_jobs_the_command_will_not_honour_as_given_is_said(tmp_path):
    """--jobs with --dask was ignored without a word; --jobs 1000 forked 816 processes."""
    from stratcli.trie import most_workers

    sweep = write(tmp_path, GRID)
    result = runner.invoke(
        app, ["sweep", str(sweep), "--jobs", "2", "--dask", "tcp://127.0.0.1:1", "--out",
              str(tmp_path / "d")],
    )  # fmt: skip
    assert result.exit_code == 2
    assert result.stderr.splitlines()[0] == (
        "note: --jobs 2 is for local worker processes: with --dask the cluster's workers plan"
    )
    many = most_workers() + 1
    result = runner.invoke(app, ["sweep", str(sweep), "--jobs", str(many), "--out",
                                 str(tmp_path / "o")])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith(f"note: --jobs {many}: at most {most_workers()} worker ")
    workers = json.loads((tmp_path / "o" / "sweep.json").read_text())["executor"]["workers"]
    assert workers <= most_workers()


def test_a_sweep_stopped_before_it_began_says_nothing_was_written(tmp_path, capsys):
    """(Ctrl-C while connecting to a cluster: its note had said "0 of 4 tasks kept in OUT"
    and how to resume, of a folder never made.)"""
    from stratcli.cli import render
    from stratcli.cli.sweep import _resume_hint
    from stratcli.interrupts import Interrupted

    notes = []
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(render, "notes", lambda texts, always=False: notes.extend(texts))
        with pytest.raises(Interrupted), _resume_hint("stratplan sweep ...", tmp_path / "o", 4):
            raise Interrupted(2)
        assert notes == ["sweep: stopped before its first task; nothing written"]
        (tmp_path / "o").mkdir()
        with pytest.raises(Interrupted), _resume_hint("again", tmp_path / "o", 4):
            raise Interrupted(2)
    assert notes[1] == f"sweep: 0 of 4 tasks kept in {tmp_path / 'o'}; again plans the rest"
