"""Every table at 80 columns (and wider) never cuts a number or an id with "…"; output that is
not a terminal is not wrapped at all."""

from __future__ import annotations

import copy
import io
import json
import tomllib
from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import ROOT
from rich.console import Console
from typer.testing import CliRunner

from stratcli import api
from stratcli.cli import app, progress, render, render_analysis, render_plan, render_tables
from stratcli.regress import Difference

TASK_D = ROOT / "scenarios" / "sim4_task_d.toml"
AUTO = ROOT / "scenarios" / "sim4_auto.toml"
LONG_NAME = "a_scenario_with_a_rather_long_name_that_users_like_to_give"
WIDTHS = (80, 101, 160)


@pytest.fixture(scope="module")
def planned():
    """sim4_task_d planned (energy objective: its line names every start)."""
    return api.plan_run(_task(TASK_D))


def _task(path):
    from stratcli.scenario import load_scenario

    return load_scenario(path)


def _big(doc: dict) -> dict:
    """The document with numbers as wide as they get: energies ≥ 1e6, long names."""
    doc = copy.deepcopy(doc)
    doc["scenario"] = LONG_NAME
    for k, leg in enumerate(doc["legs"]):
        leg["energy"] = 3.0234e7 * (k + 1)
        leg["error"] = 4.51e-12
    doc["total_energy"] = 9.07e7
    opt = doc["optimisation"]
    for s in opt["starts"]:
        s["energy"] = 451234.5678
    return doc


def _ranking_doc() -> dict:
    rows = []
    for k in range(12):
        ok = k % 5 != 4
        rows.append(
            {
                "rank": k + 1,
                "sequence": ["S1", "S3", "S2", "S1", "S3", "S2"][: 2 + k % 5],
                "strategy": "conservative" if k % 2 else "postponed",
                "status": "ok" if ok else "failed",
                "reason": "leg 2 on S3: error 3.2e-02 > tolerance 1e-03 after 40 iterations",
                "energy": 451.2345 * 10**k if ok else None,
                "peak_control": 31.5 * (k + 1),
                "excursion": 10.816 * (k + 1),
                "duration": 2.0 + k,
                "planning_time_s": 12.345,
            }
        )
    return {
        "scenario": LONG_NAME,
        "model": "one-arm",
        "essential": ["q1", "q2", "q3", "theta"],
        "sequences": len(rows),
        "max_length": 6,
        "strategies": ["conservative", "postponed"],
        "criterion": "energy",
        "rows": rows,
    }


def _tables(planned) -> dict:
    """name → a function printing that table to render.out_console."""
    task = _task(AUTO)
    records = [
        {"run": f"20261124T095233Z-{LONG_NAME}-c8102454", "status": s, "total_energy": e}
        for s, e in (("ok", 3.0234e7), ("failed", None), ("ok", 84.04))
    ]
    report = SimpleNamespace(
        updated=False,
        scenarios=14,
        baseline=Path("scenarios/baseline.json"),
        tolerances={"energy_rel": 1e-6, "error_abs": 1e-9},
        regressions=1,
        differences=[
            Difference(LONG_NAME, "total energy", 451.23456789012, 3.0234567891e7, True),
            Difference(LONG_NAME, "leg 2 error", 1.234567e-12, 9.87654e-11, False),
            Difference("sim2", "status", "ok", "failed", True),
        ],
    )
    return {
        "plan summary": lambda: render_plan.plan_summary(_big(planned.document)),
        "plan summary (as planned)": lambda: render_plan.plan_summary(planned.document),
        "ranking": lambda: render_tables.ranking(task, _ranking_doc()),
        "check report (preset)": lambda: render_analysis.check_report(
            api.check_controllability("two-arm", samples=3)
        ),
        "check report (scenario)": lambda: render_analysis.check_report(
            api.check_controllability(str(TASK_D), samples=3)
        ),
        "decompose": lambda: render_analysis.decomposition(
            api.decompose(task, max_length=3, strategy="both"), AUTO
        ),
        "runs": lambda: render_tables.runs_table(records, Path("runs")),
        "models": lambda: render_tables.presets_table(api.preset_models()),
        "model": lambda: render_tables.model(
            "two-arm",
            api.preset_models()["two-arm"],
            api.strata_table(api.preset_models()["two-arm"]),
        ),
        "regress": lambda: render_tables.regress_report(report),
    }


def _render(monkeypatch, draw, width: int) -> str:
    console = Console(width=width, record=True, force_terminal=True, file=io.StringIO())
    monkeypatch.setattr(render, "out_console", console)
    draw()
    return console.export_text()


def test_no_table_cuts_a_number_or_an_id_at_80_columns_or_wider(monkeypatch, planned):
    for name, draw in _tables(planned).items():
        for width in WIDTHS:
            text = _render(monkeypatch, draw, width)
            assert "…" not in text, f"{name} at {width} columns:\n{text}"
            if name != "runs":  # runs prints each path whole; the terminal wraps it
                assert max(map(len, text.splitlines())) <= width, (name, width)


def test_every_number_and_id_appears_whole_at_80_columns(monkeypatch, planned):
    text = _render(monkeypatch, _tables(planned)["plan summary"], 80)
    assert "3.023e+07" in text and "6.047e+07" in text and "4.51e-12" in text
    text = _render(monkeypatch, _tables(planned)["runs"], 80)
    assert f"runs/20261124T095233Z-{LONG_NAME}-c8102454" in text  # pasteable into show
    text = _render(monkeypatch, _tables(planned)["ranking"], 80)
    for k in range(8):
        if k % 5 != 4:
            assert render.fmt(451.2345 * 10**k) in text  # 451,234.50 or 4.512e+07
    text = _render(monkeypatch, _tables(planned)["regress"], 80)
    assert "3.02346e+07" in text and "9.87654e-11" in text


def test_a_small_energy_is_not_rounded_to_zero():
    """A short Lie leg's 0.0021 read "0.00" in the leg table."""
    assert render.fmt(0.00213) == "2.13e-03" and render.fmt(-0.001) == "-1.00e-03"
    assert (
        render.fmt(0.0) == "0.00" and render.fmt(0.005) == "0.01" and render.fmt(12.345) == "12.35"
    )


def _limited_ranking_doc() -> dict:
    """A comparison under a rate limit: the searched sequence slowed to 13 s, the other one
    bounded at the 2 s it was planned in before any slowing."""
    doc = _ranking_doc()
    doc["strategies"] = ["conservative"]
    doc["reference_duration_s"] = 2.0
    common = {"strategy": "conservative", "reason": None, "planning_time_s": 0.5}
    doc["rows"] = [
        {"rank": 1, "sequence": ["S1", "S3"], "status": "ok", "energy": 36.63,
         "energy_equal_time": 239.41, "peak_control": 3.0, "excursion": 3.4, "duration": 13.07,
         **common},
        {"rank": 2, "sequence": ["S3", "S1"], "status": "bounded", "energy": None,
         "energy_equal_time": None, "peak_control": None, "excursion": None, "duration": 2.0,
         "energy_bound": 239.91, "energy_bound_equal_time": 239.91, **common},
    ]  # fmt: skip
    return doc


@pytest.mark.parametrize("limited", [True, False])
def test_a_bounded_row_under_rate_limits_shows_only_its_bound_at_equal_duration(
    monkeypatch, limited
):
    # slowed by a factor of its own, a sequence not searched would not run in 2 s nor at
    # 239.91 (the searched one runs at 36.63 in 13 s): only the equal-duration bound holds
    raw = tomllib.loads(AUTO.read_text())
    if limited:
        raw["constraints"] = {"max_rate": 3.0}
    task = _task(raw)
    text = _render(monkeypatch, lambda: render_tables.ranking(task, _limited_ranking_doc()), 160)
    (line,) = [x for x in text.splitlines() if "S3 → S1" in x]
    cells = [c.strip() for c in line.split("│")]
    energy, equal, _, _, duration = cells[3:8]
    assert equal == "≥ 239.91"
    assert (energy, duration) == (("–", "–") if limited else ("≥ 239.91", "2"))


def test_a_console_that_is_no_terminal_does_not_wrap():
    stream = render.Stream(file=io.StringIO(), width=80)
    assert not stream.is_terminal and stream.width == render.PIPE_WIDTH
    sentence = " ".join(["word"] * 60)
    stream.print(sentence)
    assert stream.file.getvalue() == sentence + "\n"


def test_piped_output_has_no_line_broken_inside_a_sentence(tmp_path):
    runner = CliRunner()
    env = {"COLUMNS": "80"}
    out = tmp_path / "runs"
    result = runner.invoke(app, ["plan", str(TASK_D), "--out", str(out), "--no-animation"], env=env)
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    header, *_ = lines
    assert header.startswith("sim4_task_d") and header.endswith("P = 2.17")
    (energy,) = [x for x in lines if x.startswith("energy-optimal over all legs")]
    assert "plain Newton:" in energy  # the whole sentence on one line
    (total,) = [x for x in lines if x.startswith("total energy")]
    assert total.endswith("status ok")
    (footer,) = [x for x in lines if x.startswith("planned in")]
    assert str(out) in footer
    listed = runner.invoke(app, ["runs", "--out", str(out)], env=env)
    (run_dir,) = out.iterdir()
    assert str(run_dir) in listed.stdout and "…" not in listed.stdout


def test_progress_is_silent_in_a_pipe(tmp_path):
    """Under CliRunner stderr is no terminal: no spinner, no bar, only the result."""
    runner = CliRunner()
    result = runner.invoke(
        app, ["plan", str(TASK_D), "--out", str(tmp_path), "--no-animation", "--json"]
    )
    assert result.exit_code == 0 and result.stderr == ""
    doc = json.loads(result.stdout)
    assert doc["record"] == str(next(tmp_path.iterdir()))


@pytest.mark.parametrize(
    "planner", ["", "starts = 3", 'search = "legwise"'], ids=["default", "3 starts", "legwise"]
)
def test_plan_run_reports_its_phases_and_the_starts_it_races(tmp_path, planner):
    """The phases name the starts the energy search races: as many as the final line's
    "start k of N" counts (the pulled start is one of them; loop starts and the legwise start
    are more)."""
    path = tmp_path / "task.toml"
    path.write_text(TASK_D.read_text().replace("[planner]", f"[planner]\n{planner}", 1))
    phases: list[str] = []
    outcome = api.plan_run(_task(path), progress=phases.append)
    assert outcome.ok
    assert phases[0].startswith("checking controllability")
    assert "compiling the model" in phases
    (racing,) = [p for p in phases if p.startswith("energy search: minimum energy from ")]
    said = int(racing.split("from ")[1].split()[0])
    said += sum(p.endswith("made leg by leg (legwise)") for p in phases)
    said += sum(
        int(p.split()[2]) for p in phases if p.startswith("energy search: ") and "loop" in p
    )
    raced = outcome.document["optimisation"]["starts"]
    assert said == len(raced) >= 2
    kinds = racing.split("(")[1].rstrip(")")
    assert kinds.startswith(f"{raced[0]['from']}, {raced[1]['from']}")


def test_the_search_line_names_the_start_that_won(monkeypatch, planned):
    """ "start 3 of 3 (loop: 8 SQP iterations, ...)": where the winning start came from, as
    result.json's `from` says it."""
    doc = copy.deepcopy(planned.document)
    opt = doc["optimisation"]
    for kind in ("pulled", "loop"):
        opt["starts"][opt["best"]]["from"] = kind
        text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
        k, n = opt["best"] + 1, len(opt["starts"])
        assert f"energy-optimal over all legs together: start {k} of {n} ({kind}: " in text
    # each start's energy after where it began, and why it stopped when not at a minimum
    first = opt["starts"][0]
    first["stopped"] = "abandoned"
    text = " ".join(_render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).split())
    assert f"the starts ended at {first['from']} {first['energy']:,.2f} (abandoned)" in text


def test_seeded_newton_starts_are_numbered_on_the_search_line(monkeypatch, planned):
    """result.json calls every Newton plan's start `newton`: on the search line the ones after
    the first are `seed k` (with starts = 5 a URDF plan's four read "newton", the winner too)."""
    doc = copy.deepcopy(planned.document)
    opt = doc["optimisation"]
    first = opt["starts"][-1]
    opt["starts"] = [
        {**first, "index": k, "from": "newton", "energy": 90.0 + k, "stopped": "converged"}
        for k in range(3)
    ]
    opt["best"] = 2
    text = " ".join(_render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).split())
    assert "start 3 of 3 (seed 2: " in text
    assert "the starts ended at newton 90.00, seed 1 91.00, seed 2 92.00" in text


def test_the_search_line_ends_with_why_no_loop_start_was_made(monkeypatch, planned):
    """The record's `no_loop_start` ends the search line (after the time-scaling remark,
    which is about the energies before it); an empty one adds nothing."""
    doc = copy.deepcopy(planned.document)
    doc["optimisation"]["no_loop_start"] = ""
    text = " ".join(_render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).split())
    assert "no loop start" not in text
    doc["optimisation"]["no_loop_start"] = "why not"
    doc["time_scale"] = 2.0
    doc["total_energy"] = 2.0 * doc["total_energy"]
    text = " ".join(_render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).split())
    assert "(energies before time scaling); no loop start: why not" in text


def test_a_first_order_search_without_seeded_starts_says_how_to_add_them(monkeypatch, planned):
    """A URDF plan's energy search runs from the Newton plan and its lowest legs: its search
    line says that `planner.starts` adds seeded Newton plans (a user's arm3 task: 1401.94
    from the Newton plan, 68.80 with 5), and says it only there: not where seeded plans ran,
    nor where the legs have second derivatives."""
    from stratcli.cli.render_plan import MORE_STARTS
    from stratcli.planners.energy import LOWEST_LEGS, NO_HESSIANS

    doc = copy.deepcopy(planned.document)
    opt = doc["optimisation"]
    opt["no_loop_start"] = NO_HESSIANS
    first = opt["starts"][0]

    def ran(*kinds):
        opt["starts"] = [{**first, "index": k, "from": kind} for k, kind in enumerate(kinds)]
        opt["best"] = 0
        return " ".join(_render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).split())

    for kinds in (("newton",), ("newton", LOWEST_LEGS)):
        assert ran(*kinds).count(f"no loop start: {NO_HESSIANS}; {MORE_STARTS}") == 1
    assert MORE_STARTS not in ran("newton", LOWEST_LEGS, "newton")  # a seeded plan ran
    opt["no_loop_start"] = "why not"
    assert MORE_STARTS not in ran("newton")


def test_the_free_search_line_comes_before_a_constrained_search_and_says_so(monkeypatch, planned):
    """With [constraints] that moved the plan off the free optimum, the energy search's line
    describes the plan without them: it says so, before the note of the constrained search."""
    doc = copy.deepcopy(planned.document)
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 120)
    assert "\nenergy-optimal over all legs together" in text  # unconstrained: as it was
    doc["constraints"] = {"spec": {"obstacles": [{"shape": "circle"}]}, "legs": []}
    doc["notes"] = ["constrained search from the minimum-energy plan: ..."]
    doc["total_energy"] = 1.25 * doc["total_energy"]
    lines = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400).splitlines()
    free = next(i for i, x in enumerate(lines) if "energy-optimal over all legs" in x)
    assert lines[free].startswith("without the constraints, energy-optimal over all legs")
    assert lines[free + 1].startswith("note: constrained search")


def test_a_time_scaled_plan_at_its_free_optimum_is_not_called_constrained(monkeypatch, planned):
    """The starts' energies are before time scaling: a plan run twice as fast (energy × 2)
    that stayed at the free optimum is not described as moved by its constraints."""
    doc = copy.deepcopy(planned.document)
    doc["constraints"] = {"spec": {"max_rate": 50.0}, "legs": []}
    doc["time_scale"] = 2.0
    doc["total_energy"] = 2.0 * doc["total_energy"]
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "\nenergy-optimal over all legs together" in text
    assert "without the constraints" not in text


def test_a_plan_the_final_pass_changed_says_what_the_legs_ended_at(monkeypatch, planned):
    """Without constraints, a plan whose energy differs from the best start's (the final pass
    re-chained and polished a leg) says so on the search's line, beside the starts."""
    doc = copy.deepcopy(planned.document)
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "re-chained" not in text  # the plan is the best start's
    doc["total_energy"] = 0.999 * doc["total_energy"]
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert f"; re-chained: {render.fmt(doc['total_energy'])}; plain Newton:" in text


def test_a_stalled_search_keeping_the_free_plan_says_what_it_re_chained_to(monkeypatch, planned):
    """A stalled constrained search keeps the free plan: its total (re-chained) differed from
    the starts' energies on the line below it, with nothing saying why."""
    from stratcli.constraints import KEPT_FREE

    doc = copy.deepcopy(planned.document)
    doc["constraints"] = {"spec": {"joint_limits": [-1, 1]}, "legs": []}
    doc["status"], doc["message"] = "failed", f"the search stalled; {KEPT_FREE}, in which ..."
    doc["total_energy"] = 1.03 * doc["total_energy"]
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "without the constraints, energy-optimal" in text
    assert f"; re-chained: {render.fmt(doc['total_energy'])}; plain Newton:" in text
    del doc["message"]  # a constrained search moved it: not a re-chaining
    doc["status"] = "ok"
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "without the constraints, energy-optimal" in text and "re-chained" not in text


def test_the_record_line_names_the_animation_when_one_was_written(tmp_path):
    runner = CliRunner()
    for flag in ("--animation", "--no-animation"):
        out = tmp_path / flag
        result = runner.invoke(app, ["plan", str(TASK_D), "--out", str(out), flag])
        assert result.exit_code == 0, result.output
        (run_dir,) = out.iterdir()
        last = result.stdout.splitlines()[-1]
        gif = run_dir / "motion.gif"
        assert gif.is_file() == (flag == "--animation")
        assert last.endswith(
            f"record: {run_dir} · animation: {gif}" if gif.is_file() else f"record: {run_dir}"
        )


def test_a_footer_names_the_animation_beside_the_record(tmp_path):
    assert render.record(tmp_path) == f"record: {tmp_path}"
    (tmp_path / "motion.gif").write_bytes(b"GIF89a")
    assert render.record(tmp_path) == f"record: {tmp_path} · animation: {tmp_path / 'motion.gif'}"


def test_messages_print_user_text_verbatim_not_as_emoji(tmp_path):
    """`:-1:` quoted in an error (as in `--dask localhost:-1`) stays that text; rich made it
    a thumbs-down. Every console of the commands prints no emoji."""
    missing = tmp_path / "a:-1:b:smile:.toml"
    result = CliRunner().invoke(app, ["plan", str(missing)])
    assert result.exit_code == 2
    assert (
        result.stderr == f"error: {missing}: cannot read scenario file: No such file or directory\n"
    )
    console = render.Stream(file=io.StringIO())
    console.print("localhost:-1: :smile:")
    assert console.file.getvalue() == "localhost:-1: :smile:\n"
    assert all(isinstance(c, render.Stream) for c in (render.out_console, render.err_console))
    task = SimpleNamespace(description="connecting to localhost:-1 [b]")
    assert progress.description_column().render(task).plain == "connecting to localhost:-1 [b]"


def test_margins_met_exactly_print_as_zero_and_violations_as_they_are():
    from stratcli.cli.render_limits import limit_margins

    report = {
        "samples_per_leg": 2000,
        "legs": [
            {"joint_limit": 0.2, "rate": -5.55e-16, "acceleration": None},
            {"joint_limit": -0.01, "rate": 0.3, "acceleration": None},
        ],
    }
    line = limit_margins(report)
    assert "leg 1: joints 0.2 rad, rate 0 rad/s;" in line  # met exactly: rounding, not -5.55e-16
    assert "leg 2: joints -0.01 rad, rate 0.3 rad/s" in line  # a violation keeps its sign


def test_a_record_that_cannot_be_written_is_one_line_exit_4(capsys):
    """The line said 'cannot write the run record' twice (the error's own words and a prefix)."""
    import typer

    from stratcli.errors import RecordError

    with pytest.raises(typer.Exit) as exit_, render.reported():
        raise RecordError("cannot write the run record in /tmp/x: File exists")
    assert exit_.value.exit_code == 4
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["error: cannot write the run record in /tmp/x: File exists"]


def test_a_long_ranking_prints_its_first_rows_and_says_where_the_rest_are(monkeypatch):
    """986 candidates (an 8-joint URDF robot) printed 986 rows and a line per failure."""
    doc = _ranking_doc()
    doc["rows"] = [dict(doc["rows"][k % 12], rank=k + 1) for k in range(100)]
    for row in doc["rows"][1::2]:  # every other one failed
        row.update(status="failed", energy=None)
    doc["sequences"] = 100
    text = _render(monkeypatch, lambda: render_tables.ranking(_task(AUTO), doc), 160)
    cells = [line.split("│") for line in text.splitlines() if line.count("│") > 2]
    ranks = [int(c[0]) for c in cells if c[0].strip().isdigit()]
    shown = render_tables.SHOWN_RANKS
    assert ranks == list(range(1, shown + 1))
    assert f"… and {100 - shown} more sequences, ranks {shown + 1}–100" in text
    failed = sum(row["status"] == "failed" for row in doc["rows"][:shown])
    assert failed > render_tables.SHOWN_FAILURES
    assert text.count(") failed: ") == render_tables.SHOWN_FAILURES
    assert f"… and {failed - render_tables.SHOWN_FAILURES} more failed above" in text


def test_progress_in_a_log_is_a_plain_line_after_10_s_then_at_most_every_30_s(monkeypatch):
    """A compare-sequences of 565 s printed nothing in a CI log (the bar is for terminals)."""
    clock = [1000.0]
    monkeypatch.setattr(progress.time, "monotonic", lambda: clock[0])
    console = Console(width=80, record=True, file=io.StringIO())
    monkeypatch.setattr(progress, "err_console", console)
    update = progress.progress_lines("sweep", " tasks")
    for t, done in ((5, 1), (11, 2), (20, 3), (41.5, 4), (75, 5)):
        clock[0] = 1000.0 + t
        update(done, 9)
    assert console.export_text().splitlines() == [
        "sweep: 2 of 9 tasks (11 s)",
        "sweep: 4 of 9 tasks (41 s)",
        "sweep: 5 of 9 tasks (1 min 15 s)",
    ]
    assert not progress.shown(quiet=True, json_output=False)
    assert not progress.shown(quiet=False, json_output=True)
    console = Console(width=80, record=True, file=io.StringIO())
    monkeypatch.setattr(progress, "err_console", console)
    clock[0] = 0.0
    phase = progress.phase_lines()  # `plan`'s phases in a log: the same rule
    for t, text in ((2, "energy search"), (12, "constrained search: start 2 [a seed]"), (20, "x")):
        clock[0] = float(t)
        phase(text)
    assert console.export_text().splitlines() == [
        "constrained search: start 2 [a seed] (12 s)",  # each phase from 10 s on, as written
        "x (20 s)",
    ]


def test_the_bounded_sequences_are_counted_in_words(monkeypatch):
    task = _task(AUTO)
    doc = _limited_ranking_doc()  # one bounded row
    text = _render(monkeypatch, lambda: render_tables.ranking(task, doc), 160)
    assert "\n1 sequence bounded, not searched: " in text
    doc["rows"].append({**doc["rows"][1], "rank": 3, "sequence": ["S2", "S1"]})
    text = _render(monkeypatch, lambda: render_tables.ranking(task, doc), 160)
    assert "\n2 sequences bounded, not searched: " in text and "(s)" not in text
    # ranked at equal duration, the bound compared with the best's is that one (a new user
    # read "≥ 60.52" at the sequence's own 3 s against the best's 64.80), and the bounded
    # rows are in the order of their bounds, not ranks the exhaustive search would give
    assert "is, at the equal total duration, at least the best's" in text
    assert "not ranked among themselves" in text


def test_a_leg_the_continuation_reached_says_so_in_the_plan_table(monkeypatch):
    """Sim 4 task A planned by Newton: the second leg's first two attempts stall and the
    short continuation reaches it; the table and the plots' leg labels say so beside the
    method, as result.json's `strategy` does."""
    scenario = tomllib.loads((ROOT / "scenarios" / "sim4_task_a.toml").read_text())
    scenario["planner"]["objective"] = "newton"
    plan = api.plan(scenario, check=False)
    doc = plan.to_dict()
    assert [leg["strategy"] for leg in doc["legs"]] == ["newton", "continuation"]
    from stratcli.records.figure_common import leg_method  # the plots' leg labels

    assert [leg_method(plan, k) for k in (0, 1)] == ["S1 · newton", "S2 · newton (continuation)"]
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    rows = [line for line in text.splitlines() if " S1 " in line or " S2 " in line]
    assert "newton (continuation)" in rows[1] and "(continuation)" not in rows[0]


def test_a_start_stopped_on_its_way_to_another_starts_minimum_names_that_start(
    monkeypatch, planned
):
    """Task D: newton is stopped heading for pulled's minimum. "(same minimum)" after the
    first of two starts read as if it meant the second; the line numbers the start now."""
    doc = copy.deepcopy(planned.document)
    starts = doc["optimisation"]["starts"]
    assert [s["stopped"] for s in starts] == ["converged", "same minimum"]
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "pulled 84.04, newton 84.04 (heading for start 1's minimum);" in text
    starts.reverse()  # the other way round: the first listed was stopped
    for k, start in enumerate(starts):
        start["index"] = k
    doc["optimisation"]["best"] = 1
    text = _render(monkeypatch, lambda: render_plan.plan_summary(doc), 400)
    assert "newton 84.04 (heading for start 2's minimum), pulled 84.04;" in text


def test_a_table_too_wide_for_the_terminal_loses_no_column_or_digit():
    """At 40 or 60 columns Rich shrank `check`'s text columns to nothing: "spanning at q" and
    the verdict vanished with their headers, and a number could read 1.8 for 1.8e-02. A table
    that cannot fit with its words whole is printed whole, the terminal wrapping its lines."""
    from rich.markup import escape

    from stratcli.cli import render

    out = io.StringIO()
    console = render.Stream(file=out, force_terminal=True, width=40, color_system=None)
    rows = render.table()
    for header in ("stratum", "rank at q", "σ_min at q", "min rank, σ_min"):
        render.number_column(rows, header)
    render.text_column(rows, "spanning at q")
    render.text_column(rows, "eq. 4")
    spanning = escape("u2, u3, [u2,[u2,u3]]")  # (as `check` adds it: not markup)
    rows.add_row("S1", "3 (deg 3)", "1.8e-02", "3, 6.4e-04", spanning, "strong")
    console.print(rows)
    text = out.getvalue()
    for cell in ("1.8e-02", "3, 6.4e-04", "u2, u3, [u2,[u2,u3]]", "strong", "spanning at q"):
        assert cell in text, text
    assert console.width == 40  # (the console's own width is left as it was)
    narrow = io.StringIO()  # a table that fits wraps its text columns as before
    fits = render.Stream(file=narrow, force_terminal=True, width=40, color_system=None)
    small = render.table()
    render.number_column(small, "leg")
    render.text_column(small, "note")
    small.add_row("1", "a note of several words that wrap inside the column")
    fits.print(small)
    assert max(len(line) for line in narrow.getvalue().splitlines()) <= 40


def test_a_word_wider_than_the_terminal_is_not_broken_by_a_newline(monkeypatch):
    """At 40 columns the record's path was broken mid-name by a newline, which a path copied
    from the screen then held; a word that fits is still wrapped at the spaces."""
    from stratcli.cli import render

    out = io.StringIO()
    monkeypatch.setattr(
        render, "out_console", render.Stream(file=out, force_terminal=True, width=40)
    )
    path = "/tmp/runs/20261129T033810Z-unicycle-e0bff845"
    render.say(f"planned in 228 ms · 4.66 s in all · record: {path}")
    assert path in out.getvalue()
    out.seek(0), out.truncate()
    render.say("a line of several words, each narrower than the terminal, wraps at spaces")
    assert all(len(line) <= 40 for line in out.getvalue().splitlines())
    assert len(out.getvalue().splitlines()) == 2
