"""Regression against a baseline: the shipped plans against `scenarios/baseline.json`, and the
`stratplan regress` command on a small directory of its own."""

from __future__ import annotations

import json
import shutil

import pytest
from conftest import ROOT, SCENARIOS
from typer.testing import CliRunner

from stratcli.api.regression import summarise
from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.regress import compare, load_baseline, summary_of

runner = CliRunner()


def test_shipped_baseline_matches(shipped_plans):
    """What `stratplan regress scenarios --baseline scenarios/baseline.json` checks, on the
    plans of this session (planned once, as regress plans them): no difference at all."""
    baseline, tolerances = load_baseline(ROOT / "scenarios" / "baseline.json")
    now = {stem: summary_of(outcome.result) for stem, (_, outcome) in shipped_plans.items()}
    assert set(now) == {p.stem for p in SCENARIOS}
    differences = compare(now, baseline, tolerances)
    assert not differences, "\n".join(
        f"{d.scenario}: {d.quantity}: {d.baseline} -> {d.now}"
        + (" (regression)" if d.regression else "")
        for d in differences
    )


def test_summary_of_a_plan_is_what_regress_keeps(shipped_plans):
    """summary_of(plan) is `summarise` without its planning (on the cheapest scenario: the
    others are not planned twice)."""
    _, outcome = shipped_plans["unicycle"]
    summary = {**summary_of(outcome.result), "message": ""}  # (a failed plan's: not compared)
    assert summary == summarise(ROOT / "scenarios" / "unicycle.toml")


def test_regress_replays_auto_mode_unscaled_as_it_does_legs(tmp_path):
    """The baseline keeps plans as planned: a planner.time_scale of an auto-mode scenario is
    not applied (plan_auto honours it since it was found dropped; summarise must not)."""
    import tomllib

    from stratcli.tomlwrite import dumps

    raw = tomllib.loads((ROOT / "scenarios" / "sim4_auto.toml").read_text())
    raw["decompose"]["max_length"] = 2
    raw.setdefault("planner", {})["objective"] = "newton"
    plain, fast = tmp_path / "plain.toml", tmp_path / "fast.toml"
    plain.write_text(dumps(raw))
    raw["planner"]["time_scale"] = 2.0
    fast.write_text(dumps(raw))
    assert summarise(fast)["total_energy"] == summarise(plain)["total_energy"]
    # --jobs 1 (a shared CI machine): the same comparison in this process, the same plan
    assert summarise(plain, jobs=1) == summarise(plain)
    from stratcli.api import regress

    with pytest.raises(InputError, match=r"^jobs: must be an integer of at least 1 \(got 0\)$"):
        regress(tmp_path, tmp_path / "baseline.json", jobs=0)


def test_regress_detects_a_regression(tmp_path):
    scen = tmp_path / "scen"
    scen.mkdir()
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", scen / "d.toml")
    base = tmp_path / "baseline.json"
    assert (
        runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--update"]).exit_code
        == 0
    )
    same = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert same.exit_code == 0 and "no regressions" in same.output
    # one line per scenario on stderr, in a log too (no terminal here), none under --quiet
    assert "planned d: ok" in same.stderr
    quiet = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--quiet"])
    assert quiet.exit_code == 0 and "planned" not in quiet.stderr
    doc = json.loads(base.read_text())
    doc["scenarios"]["d"]["total_energy"] *= 0.5  # the baseline was cheaper: now a regression
    base.write_text(json.dumps(doc))
    worse = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert worse.exit_code == 1 and "regression" in worse.output
    # --quiet drops the progress and the table, but a failing CI job still says why
    quiet = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--quiet"])
    assert quiet.exit_code == 1 and quiet.stdout == "" and "planned" not in quiet.stderr
    assert quiet.stderr.splitlines() == [
        f"regression: d: total energy: baseline {doc['scenarios']['d']['total_energy']:.6g}, "
        f"now {doc['scenarios']['d']['total_energy'] * 2:.6g}"
    ]
    doc["scenarios"]["d"]["total_energy"] *= 4.0  # the baseline was dearer: changed, not failed
    doc["scenarios"]["gone"] = doc["scenarios"]["d"]
    base.write_text(json.dumps(doc))
    out = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)])
    assert out.exit_code == 1 and "missing" in out.output  # a scenario vanished


def test_regress_json_is_the_report_for_a_ci_script(tmp_path):
    """`regress --json`: stdout is one JSON document (progress stays on stderr) with the
    verdict, every difference and each scenario's numbers; a regression still exits 1."""
    scen = tmp_path / "scen"
    scen.mkdir()
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", scen / "d.toml")
    base = tmp_path / "baseline.json"
    runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--update"])
    same = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--json"])
    report = json.loads(same.stdout)
    assert same.exit_code == 0 and "planned d: ok" in same.stderr
    assert report["schema"] == "stratplan.regress/1" and report["regressions"] == 0
    assert report["differences"] == [] and report["scenarios"] == 1
    baseline = json.loads(base.read_text())["scenarios"]["d"]
    d = report["results"]["d"]
    assert {k: d[k] for k in baseline} == baseline and d["seconds"] > 0
    baseline["total_energy"] *= 0.5
    base.write_text(json.dumps({**json.loads(base.read_text()), "scenarios": {"d": baseline}}))
    worse = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--json"])
    report = json.loads(worse.stdout)
    assert worse.exit_code == 1 and report["regressions"] == 1
    (diff,) = report["differences"]
    assert diff == {
        "scenario": "d",
        "quantity": "total energy",
        "baseline": baseline["total_energy"],
        "now": d["total_energy"],
        "regression": True,
    }


def test_regress_checks_every_scenario_file_before_planning_any(tmp_path):
    """A bad scenario file is exit 2 naming it (and every other bad one) before anything is
    planned: it was found only after planning the files sorted before it."""
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", tmp_path / "a.toml")
    text = (ROOT / "scenarios" / "unicycle.toml").read_text()
    (tmp_path / "b.toml").write_text(text.replace("[planner]", "[planner]\ntolerence = 1", 1))
    (tmp_path / "c.toml").write_text(text.replace("[model]", "colour = 1\n[model]", 1))
    result = runner.invoke(app, ["regress", str(tmp_path), "--update"])
    assert result.exit_code == 2 and "planned" not in result.stderr
    first, second = result.stderr.splitlines()
    assert first.startswith(f"error: {tmp_path / 'b.toml'}: planner.tolerence: unknown key")
    assert second == (
        f"error: {tmp_path / 'c.toml'}: colour: unknown key (allowed: name, description, model, "
        "task, planner, legs, decompose, reference, constraints)"
    )
    assert not (tmp_path / "baseline.json").exists()


def test_one_scenario_is_one_scenario_in_the_report(capsys):
    """`regress` of a single scenario said "1 scenarios" (a URDF researcher's trial)."""
    from types import SimpleNamespace

    from stratcli.cli import render_tables

    tolerances = {"energy_rel": 1e-6, "error_abs": 1e-6}
    for n, said in ((1, "1 scenario matches b.json"), (3, "all 3 scenarios match b.json")):
        report = SimpleNamespace(
            updated=False, scenarios=n, baseline="b.json", differences=[], tolerances=tolerances
        )
        render_tables.regress_report(report)
        assert said in capsys.readouterr().out
    render_tables.regress_report(SimpleNamespace(updated=True, scenarios=1, baseline="b.json"))
    assert "written: 1 scenario\n" in capsys.readouterr().out


def test_a_new_scenario_that_fails_is_a_regression_a_new_one_that_plans_is_not():
    """A CI job stayed green (exit 0, "0 of 1 differences are regressions") when a scenario
    added without --update could not be planned."""
    tolerances = {"energy_rel": 1e-6, "error_abs": 1e-6}
    ok = {"status": "ok", "total_energy": 1.0, "errors": [0.0], "energies": [1.0]}
    failed = {"status": "failed", "total_energy": 2.0, "errors": [1.0], "energies": [2.0]}
    (new,) = compare({"a": ok}, {}, tolerances)
    assert (new.now, new.regression) == ("new", False)
    (new,) = compare({"a": failed}, {}, tolerances)
    assert (new.now, new.regression) == ("new, failed", True)
    assert compare({"a": failed}, {"a": failed}, tolerances) == []  # taken in by --update


def test_a_failed_scenario_fixed_since_the_baseline_is_no_regression():
    """A scenario taken in by --update as failed, then fixed, was a regression (exit 1): its
    real energy is above what the stalled search had reached. Only a plan that succeeded
    both times is held to its numbers; one that fails now is a regression by its status."""
    tolerances = {"energy_rel": 1e-6, "error_abs": 1e-6}
    ok = {"status": "ok", "total_energy": 8.3, "errors": [1e-9, 1e-9], "energies": [4.0, 4.3]}
    stalled = {"status": "failed", "total_energy": 0.6, "errors": [0.5], "energies": [0.6]}
    fixed = compare({"u": ok}, {"u": stalled}, tolerances)
    assert [(d.quantity, d.regression) for d in fixed] == [
        ("status", False),
        ("total energy", False),
        ("legs planned", False),
    ]
    broken = compare({"u": stalled}, {"u": ok}, tolerances)
    assert [d.quantity for d in broken if d.regression] == ["status", "legs planned"]
    worse = dict(ok, total_energy=9.0)  # both ok: held to the energy
    assert [(d.quantity, d.regression) for d in compare({"u": worse}, {"u": ok}, tolerances)] == [
        ("total energy", True)
    ]


def test_a_failed_scenario_says_why_in_the_log_and_the_json(tmp_path):
    """`regress` said `planned fails: failed` and `now new, failed`, never the plan's own
    message (which leg, how far, what to try)."""
    scen = tmp_path / "scen"
    scen.mkdir()
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    text = text.replace("tolerance = 1e-3", "tolerance = 1e-3\nmax_iterations = 1\nrestarts = 0")
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", scen / "u.toml")
    base = tmp_path / "baseline.json"
    assert (
        runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--update"]).exit_code
        == 0
    )
    (scen / "fails.toml").write_text(text)
    out = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--quiet"])
    assert out.exit_code == 1
    (line,) = out.stderr.strip().splitlines()
    assert line.startswith(
        "regression: fails: scenario: baseline absent, now new, failed (leg 1 on S3"
    )
    doc = json.loads(
        runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--json"]).stdout
    )
    assert doc["results"]["fails"]["message"].startswith("leg 1 on S3 did not reach its goal")
    assert (
        "message"
        not in json.loads(
            (
                runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--update"]),
                base.read_text(),
            )[1]
        )["scenarios"]["fails"]
    )  # the baseline keeps what it compares


@pytest.mark.parametrize(("where", "said"), [("nosuch", "no such directory"), ("f.toml", "a file")])
def test_regress_of_no_folder_says_what_it_was_given(tmp_path, where, said):
    """It said `no scenario files (*.toml) in nosuch`, as of an empty folder."""
    (tmp_path / "f.toml").write_text("")
    result = CliRunner().invoke(app, ["regress", str(tmp_path / where)])
    assert result.exit_code == 2
    assert result.output.strip() == (
        f"error: {tmp_path / where}: {said}{', not a folder' if said == 'a file' else ''} "
        "(regress replays the *.toml files of a folder)"
    )


def test_update_quiet_takes_the_differences_in_without_calling_them_regressions(tmp_path):
    """`--update --quiet` printed `regression: ...` lines and exited 0, the baseline
    rewritten: the lines said the opposite of what was done."""
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", tmp_path / "unicycle.toml")
    args = ["regress", str(tmp_path), "--jobs", "1", "--update", "--quiet"]
    assert CliRunner().invoke(app, args).exit_code == 0
    text = (tmp_path / "unicycle.toml").read_text()
    assert text.count("[planner]") == 1 and "objective" not in text
    newton = text.replace("[planner]", '[planner]\nobjective = "newton"')
    (tmp_path / "unicycle.toml").write_text(newton)  # a higher energy than the baseline's
    plain = CliRunner().invoke(app, ["regress", str(tmp_path), "--jobs", "1", "--quiet"])
    assert plain.exit_code == 1 and "regression: unicycle: total energy" in plain.output
    taken = CliRunner().invoke(app, args)
    assert taken.exit_code == 0 and "regression" not in taken.output, taken.output
    again = CliRunner().invoke(app, ["regress", str(tmp_path), "--jobs", "1", "--quiet"])
    assert again.exit_code == 0 and again.output == ""


def test_a_baseline_updated_with_a_diverged_scenario_is_read_back(tmp_path):
    """A leg that diverges has no energy (NaN) and an infinite error: `--update` wrote them
    as NaN and Infinity, which the next `regress` refused ("total_energy is nan, not a
    number"), CI broken by its own baseline. They are null (what a failed entry may hold)."""
    scen = tmp_path / "scen"
    scen.mkdir()
    text = (ROOT / "scenarios" / "unicycle.toml").read_text()
    (scen / "far.toml").write_text(text.replace("goal = [0, 1, 0]", "goal = [0, 1000, 0]"))
    base = tmp_path / "baseline.json"
    update = ["regress", str(scen), "--baseline", str(base), "--update", "--quiet"]
    assert runner.invoke(app, update).exit_code == 0
    entry = json.loads(base.read_text())["scenarios"]["far"]  # (strict JSON: no NaN)
    assert entry["status"] == "failed" and entry["total_energy"] is None
    assert entry["errors"] == [None]
    again = runner.invoke(app, ["regress", str(scen), "--baseline", str(base), "--quiet"])
    assert again.exit_code == 0, again.stderr
    (scen / "far.toml").write_text(text)  # planned again: its energy was none, now a number
    fixed = runner.invoke(app, ["regress", str(scen), "--baseline", str(base)], terminal_width=200)
    row = next(line for line in fixed.stdout.splitlines() if "total energy" in line)
    assert row.split("│")[2].strip() == "–"  # the baseline's null (it showed "None")
    assert "None" not in fixed.stdout


def test_a_baseline_path_is_read_as_the_other_paths_are(tmp_path, monkeypatch):
    """`--baseline=~/b.json` was not the home directory; a baseline in a folder that does not
    exist, or a folder, ended `--update` in a traceback after every scenario was planned; a
    baseline that is a symbolic link was replaced by a plain file (its target left as it
    was)."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    scen = tmp_path / "scen"
    scen.mkdir()
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", scen / "u.toml")
    update = ["regress", str(scen), "--update", "--quiet", "--baseline"]
    assert runner.invoke(app, [*update[:-1], "--baseline=~/b.json"]).exit_code == 0
    assert (tmp_path / "home" / "b.json").is_file()
    for bad, why in [
        (tmp_path / "nosuch" / "b.json", f"no such directory {tmp_path / 'nosuch'}"),
        (scen, "a directory, not a file"),
    ]:
        refused = runner.invoke(app, [*update, str(bad)])
        assert refused.exit_code == 2
        assert refused.stderr.strip() == f"error: baseline file {bad}: {why}"
    (tmp_path / "link.json").symlink_to(tmp_path / "home" / "b.json")
    before = (tmp_path / "home" / "b.json").stat().st_mtime_ns
    assert runner.invoke(app, [*update, str(tmp_path / "link.json")]).exit_code == 0
    assert (tmp_path / "link.json").is_symlink()
    assert (tmp_path / "home" / "b.json").stat().st_mtime_ns > before  # its target written


def test_a_regress_report_is_a_frozen_value(tmp_path):
    """`RegressReport` was frozen but held a list of mutable differences and plain dicts: a
    script could change a report's results or append a difference to it."""
    import dataclasses
    import pickle

    from stratcli.api.regression import regress

    scen = tmp_path / "scen"
    scen.mkdir()
    shutil.copy(ROOT / "scenarios" / "unicycle.toml", scen / "u.toml")
    report = regress(scen, tmp_path / "b.json", update=True)
    assert isinstance(report.differences, tuple) and report.differences  # (new: a difference)
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.differences[0].regression = False
    for table in (report.results, report.seconds, report.tolerances):
        with pytest.raises(TypeError, match="read-only"):
            table["x"] = 1
    with pytest.raises(TypeError, match="read-only"):
        report.results["u"]["status"] = "failed"
    assert pickle.loads(pickle.dumps(report)) == report


def test_energy_moved_between_legs_is_shown_not_a_regression():
    """The baseline keeps each leg's energy, but only the total was compared: energy moved
    from one leg to another at the same total went unsaid."""
    tol = {"energy_rel": 1e-6, "error_abs": 1e-6}
    base = {"x": {"status": "ok", "total_energy": 10.0, "errors": [0, 0], "energies": [4.0, 6.0]}}
    moved = {"x": {**base["x"], "energies": [5.0, 5.0]}}
    diffs = compare(moved, base, tol)
    assert [(d.quantity, d.baseline, d.now, d.regression) for d in diffs] == [
        ("leg 1 energy", 4.0, 5.0, False),
        ("leg 2 energy", 6.0, 5.0, False),
    ]
    rounding = {"x": {**base["x"], "energies": [4.0 + 1e-9, 6.0 - 1e-9]}}
    assert compare(rounding, base, tol) == []


def test_a_baselines_own_tolerances_decide_not_the_defaults(tmp_path):
    """A baseline loosened for another machine's maths libraries (energy_rel 1e-2) passes a
    0.5 % move; one tightened below the defaults fails a move the defaults would pass."""
    from stratcli.regress import DEFAULT_TOLERANCES, compare, load_baseline

    summary = {"status": "ok", "total_energy": 100.0, "errors": [1e-9], "energies": [100.0]}
    path = tmp_path / "baseline.json"
    for tolerances, moved, fails in (({"energy_rel": 1e-2}, 1.005, False),
                                     ({"energy_rel": 1e-9}, 1 + 1e-7, True)):  # fmt: skip
        path.write_text(json.dumps({
            "schema": "stratplan.baseline/1", "tolerances": tolerances,
            "scenarios": {"d": summary},
        }))  # fmt: skip
        scenarios, read = load_baseline(path)
        assert read == DEFAULT_TOLERANCES | tolerances
        now = {"d": {**summary, "total_energy": 100.0 * moved}}
        assert any(d.regression for d in compare(now, scenarios, read)) is fails
        defaults = compare(now, scenarios, DEFAULT_TOLERANCES)  # the other way round
        assert any(d.regression for d in defaults) is not fails
