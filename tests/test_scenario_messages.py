"""Scenario mistakes a newcomer makes, each refused in one line that says what to write
instead: [[legs]] with [decompose], a single [legs] table, a name table on a preset, an
unknown name in an angle, a misspelt Lie key or method (and the `decompose` note)."""

from __future__ import annotations

import tomllib

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.scenario import load_scenario

TASK_D = ROOT / "scenarios" / "sim4_task_d.toml"
TEXT = TASK_D.read_text()
LAST_LEG = '[[legs]]\nstratum = "S1"\n'
GOAL = 'goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]'
runner = CliRunner()


def _problem(tmp_path, text: str) -> str:
    """The one error line of loading `text` (a scenario file)."""
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    lines = str(info.value).splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{path}: "), lines
    return lines[0].removeprefix(f"{path}: ")


def test_legs_and_decompose_together_are_refused(tmp_path):
    line = _problem(tmp_path, TEXT + "\n[decompose]\nmax_length = 3\n")
    assert line == (
        "decompose: give either [[legs]] (the strata in order) or a [decompose] table "
        "(auto mode), not both"
    )
    path = tmp_path / "s.toml"
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2 and not (tmp_path / "runs").exists()
    assert f"error: {path}: decompose: give either" in result.output


def test_no_shipped_scenario_gives_both():
    for path in sorted((ROOT / "scenarios").rglob("*.toml")):
        if path.parent.name != "sweeps":  # sweep files are not scenarios
            task = load_scenario(path)
            assert task.scenario.legs is None or task.scenario.decompose is None, path


def test_decompose_of_a_legs_scenario_says_the_legs_are_not_used():
    result = runner.invoke(app, ["decompose", str(TASK_D), "--json"])
    assert result.exit_code == 0
    assert result.stderr.count("[[legs]] are not used here") == 1  # a note, not also a warning
    assert "UnusedLegsWarning" not in result.stderr
    assert "note:" not in result.stdout  # the JSON stays clean
    auto = runner.invoke(app, ["decompose", str(ROOT / "scenarios" / "sim4_auto.toml")])
    assert auto.exit_code == 0 and "note:" not in auto.output


@pytest.mark.parametrize(
    "old, new, expected",
    [
        (
            'start = [0, "pi/4", 0, 0]',
            'start = [0, "abc", 0, 0]',
            "task.start[1]: in 'abc': unknown name 'abc' (only numbers, pi (π), E, + - * / ** "
            "and the functions abs, acos,",
        ),
        (
            LAST_LEG,
            "",
            "legs: must be a list: write [[legs]] (an array of tables), one per "
            "leg (got {'stratum': 'S3'",
        ),
        (
            GOAL,
            'goal = { q1 = "-pi/3", q2 = "pi/3", q3 = "pi/4", q4 = "-pi/12" }',
            "task.goal: must be a list: a configuration by name (a table) is for "
            "URDF models only; write a list of the model's coordinates in order "
            "(q1, q2, q3, theta) (got {'q1'",
        ),
        (
            LAST_LEG,
            LAST_LEG + 'method = "lie"\nlie = { step_duraton = 0.5 }\n',
            "legs[1].lie.step_duraton: unknown key: did you mean 'step_duration'? (allowed: "
            "step_duration, gamma, degree, max_steps, alpha, rest)",
        ),
        (
            LAST_LEG,
            LAST_LEG + 'method = "Newton"\n',
            "legs[1].method: must be 'lie' or 'newton' (got 'Newton': did you mean 'newton'?)",
        ),
        (
            LAST_LEG,
            LAST_LEG + '\n[constraints]\nobstacles = { shape = "circle", centre = [2, 2], '
            "radius = 0.1 }\n",
            "constraints.obstacles: must be a list: write a list, even of one: "
            "obstacles = [{ shape = ... }], or one [[constraints.obstacles]] table per obstacle "
            "(got {'shape': 'circle'",
        ),
        (
            'continuity = "lr-C1"',
            'continuity = "lr-c1"',
            "planner.continuity: must be 'none', 'l-C0', 'l-C1', 'lr-C0' or 'lr-C1' (got "
            "'lr-c1': did you mean 'lr-C1'?)",
        ),
        (
            'continuity = "lr-C1"',
            'continuity = "lr-C1"\ndurations = "optimize"',
            "planner.durations: must be 'fixed' or 'optimise' (got 'optimize': did you mean "
            "'optimise'?)",
        ),
        (
            'continuity = "lr-C1"',
            'continuity = "lr-C1"\nobjective = "speed"',
            "planner.objective: must be 'energy' or 'newton' (got 'speed')",  # nothing near
        ),
        (
            LAST_LEG,
            LAST_LEG + "[constraints]\njoint_limits = [-2.5]\n",
            "constraints.joint_limits: must have at least 2 entries, not 1 (got [-2.5])",
        ),
        (
            LAST_LEG,
            LAST_LEG + "[constraints]\njoint_limits = [-2.5, 0, 2.5]\n",
            "constraints.joint_limits: must have at most 2 entries, not 3 (got [-2.5, 0, 2.5])",
        ),
        (
            'start = [0, "pi/4", 0, 0]',
            'start = "0, pi/4, 0, 0"',  # it said "a configuration by name (a table) is for URDF"
            "task.start: must be a list: write a list of the model's coordinates in order "
            "(q1, q2, q3, theta), not one string (got '0, pi/4, 0, 0')",
        ),
        (
            'start = [0, "pi/4", 0, 0]',
            "start = 0",  # it said "a configuration by name (a table) is for URDF" too
            "task.start: must be a list: write a list of the model's coordinates in order "
            "(q1, q2, q3, theta) (got 0)",
        ),
    ],
    ids=[
        "angle name", "single legs table", "name table on a preset", "lie key", "method",
        "single obstacle table", "a choice in another case", "a choice spelled otherwise",
        "no choice near", "a limit pair too short", "a limit pair too long", "one string",
        "one number",
    ],
)  # fmt: skip
def test_messages_say_what_to_write(tmp_path, old, new, expected):
    text = TEXT.replace(old, new)
    if new == "":  # [legs] once: a table, not an array of tables
        text = text.replace("[[legs]]", "[legs]")
    assert text != TEXT
    assert _problem(tmp_path, text).startswith(expected)


def test_check_at_names_what_an_angle_may_use():
    result = runner.invoke(app, ["check", "one-arm", "--at", "0,pi/3,0,foo"])
    assert result.exit_code == 2
    assert "unknown name 'foo' (only numbers, pi (π), E" in result.output
    assert "allowed names: none" not in result.output


AUTO_QUADRATURE = """
name = "u"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
fields = { v = ["cos(theta)", "sin(theta)", 0], w = [0, 0, "1+x"] }
strata = [{ name = "drive", active = ["v", "w"] }]
[task]
start = [0, 0, 0]
goal = [0, 1, 0]
[planner]
evaluator = "quadrature"
leg_duration = 2.0
[decompose]
max_length = 1
"""


@pytest.mark.parametrize("strata", ["", 'strata = ["drive"]\n'], ids=["all", "listed"])
def test_auto_mode_refuses_an_evaluator_its_strata_cannot_use(tmp_path, strata):
    """theta's row depends on x: no quadrature path, in auto mode as with [[legs]]."""
    path = tmp_path / "s.toml"
    path.write_text(AUTO_QUADRATURE + strata)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit) and "Traceback" not in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert errors == [
        f"error: {path}: planner.evaluator: stratum drive does not allow the quadrature path "
        "(a non-constant row depends on a non-explicit coordinate); use 'auto' or 'ode'"
    ], result.output
    assert not (tmp_path / "runs").exists()


BROKEN_UNICYCLE = """
name = "u"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
fields = { v = ["cos(thetaa)", "sin(theta)", 0], w = [0, 0, 1] }
strata = [{ name = "drive", active = ["v", "w"] }]
[task]
start = { x = 0, y = 0, theta = 0 }
goal = [0, 1, 0]
[[legs]]
stratum = "drive"
"""


def test_a_name_table_on_a_broken_model_lists_its_states_as_written(tmp_path):
    """The model does not build (`thetaa`), so `stratplan models FILE` would fail on this
    file with the same line: the hint lists the states the model declares instead."""
    line = _problem(tmp_path, BROKEN_UNICYCLE)
    assert line.startswith(
        "task.start: must be a list: a configuration by name (a table) is for "
        "URDF models only; write a list of the model's coordinates in order (x, y, theta) "
        "(got {'x'"
    ), line
    assert "models FILE" not in line


def test_a_name_table_on_a_model_without_states_names_the_model_problem(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(BROKEN_UNICYCLE.replace('["x", "y", "theta"]', '"x y theta"'))
    with pytest.raises(InputError) as info:
        load_scenario(path)
    start = [p.message for p in info.value.problems if p.path == "task.start"]
    assert len(start) == 1 and "models FILE" not in start[0]
    assert "coordinates in order (fix the model first: model.states: must be a " in (start[0])


def test_names_on_a_urdf_model_with_a_bad_table_leave_only_the_model_problem(tmp_path):
    # the configurations by name could not be read: three more lines said a table "is for
    # URDF models only", on a URDF model
    urdf = (ROOT / "robots" / "arm3.urdf").as_posix()
    path = tmp_path / "s.toml"
    path.write_text(
        f'name = "s"\n[model]\nkind = "urdf"\npath = "{urdf}"\nstrata = ["j3"]\n'
        "[task]\nstart = { j1 = 0, j2 = 0, j3 = 0, attitude = [0, 0, 0] }\n"
        "goal = { j1 = 0.1, j2 = 0, j3 = 0, attitude = [0, 0, 0] }\n"
        '[[legs]]\nstratum = "S3"\ngoal = { j1 = 0.1, j2 = 0, j3 = 0, attitude = "*" }\n'
    )
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert [p.path for p in info.value.problems] == ["model.strata[0]"]


@pytest.mark.parametrize("build", ["preset", "planar"])
def test_a_model_object_from_python_is_one_line_saying_to_give_its_table(build):
    """`stratcli.System` and `PlanarManipulator` are public, so a contributor tries them as a
    scenario's model; pydantic alone said `model.kind: is missing`."""
    import stratcli

    if build == "preset":
        model, kind = stratcli.preset("one-arm"), "PresetSystem"
    else:
        arm = stratcli.Arm((0.3, 0.0), 0.0, 1, (stratcli.Link(1.0, 1.0),))
        model = stratcli.PlanarManipulator(stratcli.Base(10.0, 1.0), (arm,))
        kind = "PlanarManipulator"
    scenario = {"name": "x", "model": model, "task": {"start": [0, 0], "goal": [0, 0]}}
    with pytest.raises(InputError) as info:
        load_scenario({**scenario, "legs": [{"stratum": "S1"}]})
    model_problems = [p for p in info.value.problems if p.path.startswith("model")]
    assert [p.path for p in model_problems] == ["model"]
    assert model_problems[0].message == (
        "must be a [model] table (a dict with its kind: preset, custom, planar-manipulator or "
        f"urdf), not a {kind} object; a model of your own is given by its table"
    )


def test_the_library_warns_that_a_legs_scenarios_legs_are_not_used():
    """From Python the note was only in `outcome.settings.notes`, which a notebook never shows:
    decompose and compare_sequences warn, attributed to the caller's line."""
    import warnings

    import stratcli

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = stratcli.decompose(TASK_D, max_length=2)
    (warning,) = [w for w in caught if w.category is stratcli.UnusedLegsWarning]
    assert "[[legs]] are not used here" in str(warning.message)
    assert warning.filename == __file__  # this line, not a line inside the package
    assert outcome.settings.notes  # and still a note, which the command line prints
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stratcli.decompose(ROOT / "scenarios" / "sim4_auto.toml", max_length=2)
    assert not [w for w in caught if w.category is stratcli.UnusedLegsWarning]


TASK_C = (ROOT / "scenarios" / "sim4_task_c.toml").read_text()  # S3, S2, S1 under lr-C1
WHOLE_PERIOD = "\n[planner.basis]\nharmonics = 3\nperiod = 1.0\n"  # = the legs' 1 s


def test_a_leg_of_whole_basis_periods_that_must_end_otherwise_is_refused(tmp_path):
    """Each control of a leg lasting whole periods ends as it starts; lr-C1 asks leg 2's u1
    to continue from leg 1 and to end at 0 (leg 3, on S1, does not use it). Leg by leg,
    Newton failed there with "a numerical failure (...) boundary conditions are
    inconsistent; check the model's parameters and expressions"."""
    path = tmp_path / "s.toml"
    path.write_text(TASK_C + WHOLE_PERIOD)
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path / "runs")])
    assert result.exit_code == 2 and not (tmp_path / "runs").exists()
    (line,) = result.output.strip().splitlines()
    assert line == (
        f"error: {path}: planner.basis.period: leg 2 lasts 1 s, 1 basis period of 1 s: over a "
        "whole number of them (or nearly) its controls end as they start; but under lr-C1 u1 "
        "continues from leg 1 and must end at 0 (leg 3 does not use it); use a period that "
        "does not divide the leg's duration (the paper's 2.17 s) or another duration"
    )
    # a leg's own duration of whole periods is named as that leg's
    own = TASK_C.replace('stratum = "S2"\n', 'stratum = "S2"\nduration = 2.17\n')
    line = _problem(tmp_path, own)  # (the default period is 2.17 s)
    assert line.startswith("legs[1].duration: leg 2 lasts 2.17 s, 1 basis period of 2.17 s")
    # nearly whole periods fail alike (3.0003 of them: the planner's own test decides)
    nearly = TASK_C + WHOLE_PERIOD.replace("period = 1.0", "period = 0.3333")
    assert _problem(tmp_path, nearly).startswith("planner.basis.period: leg 2 lasts 1 s, 3.0003")
    # not checked where the durations are chosen (`optimise`) or Lie legs plan their steps
    optimised = TASK_C.replace(
        'continuity = "lr-C1"', 'continuity = "lr-C1"\ndurations = "optimise"'
    )
    load_scenario(tomllib.loads(optimised + WHOLE_PERIOD))


@pytest.mark.parametrize(
    ("planner", "refused"),
    [
        ('continuity = "lr-C1"', True),
        ('continuity = "lr-C0"', True),
        ('continuity = "l-C1"', False),  # no condition at a middle leg's end
        ('continuity = "l-C1"\nfull_stop = true', False),  # S1's u3 new on S2: 0 at both ends
        ('continuity = "lr-C1"\nsoft_start = true\nfull_stop = true', False),
        ('continuity = "lr-C1"\nbasis = { harmonics = 3, period = 0.25 }', True),  # 4 periods
    ],
)
def test_whole_periods_are_refused_exactly_where_newton_cannot_meet_the_conditions(
    planner, refused, monkeypatch
):
    """The check agrees with the planner (bypassed): refused where leg-by-leg Newton finds
    the boundary conditions inconsistent, planned otherwise."""
    from stratcli import plan
    from stratcli import scenario as module  # its reference to the check, bypassed below

    text = TASK_C.replace('continuity = "lr-C1"', planner)
    text += "" if "period" in planner else WHOLE_PERIOD
    text = text.replace("tolerance = 1e-3", 'tolerance = 1e-3\nobjective = "newton"')
    raw = tomllib.loads(text)
    if refused:
        with pytest.raises(InputError, match="basis period"):
            load_scenario(raw)
    else:
        load_scenario(raw)
    monkeypatch.setattr(module, "periodic_problems", lambda *args: [])
    result = plan(raw, check=False)
    assert ("boundary conditions are inconsistent" in result.message) == refused
    assert result.ok != refused


def test_an_empty_file_is_one_line_saying_so(tmp_path):
    """It was three lines, one per required table ("name: required field is missing", ...)."""
    assert _problem(tmp_path, "") == (
        "the scenario is empty: it needs a name, a [model] and a [task] table (README: Scenarios)"
    )


def test_the_schemas_and_the_models_problems_come_in_one_run():
    """`soft_start = "yes"` hid a leg's goal on a locked joint until it was fixed (a new
    user's two-arm scenario): the refused key is left out and the rest is checked against
    the model in the same run; a refused value inside a list leaves its key out, and a key
    the scenario needs (the goal) leaves nothing more to check."""
    raw = tomllib.loads(TEXT)
    raw["planner"]["soft_start"] = "yes"
    raw["legs"][0]["goal"][2] = 0.5  # S3 locks q3 at its start's 0
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    paths = [p.path for p in info.value.problems]
    assert paths == ["planner.soft_start", "legs[0].goal"], info.value.problems
    assert "q3 is locked at 0 on this stratum" in info.value.problems[1].message
    raw["task"]["goal"][1] = "abc"  # the task's goal refused: nothing else can be checked
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    assert sorted(p.path for p in info.value.problems) == ["planner.soft_start", "task.goal[1]"]


def test_a_kind_in_capitals_is_one_line_with_the_kind_meant(tmp_path):
    """`kind = "URDF"` gave four lines: the kind, then each configuration by name "is for
    URDF models only ... (fix the model first: ...)", the same problem three times more."""
    raw = {
        "name": "caps",
        "model": {"kind": "URDF", "path": "robot.urdf"},
        "task": {"start": {"j1": 0}, "goal": {"j1": 1}},
        "legs": [{"stratum": "S1", "goal": {"j1": 0.5}}, {"stratum": "S2"}],
    }
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    assert [p.render() for p in info.value.problems] == [
        "model.kind: is 'URDF', not a kind (one of: preset, custom, planar-manipulator, urdf): "
        "did you mean 'urdf'?"
    ]
    raw["model"] = {"kind": "planar"}  # the start of one
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    assert info.value.problems[0].render().endswith("did you mean 'planar-manipulator'?")


def test_a_method_spelled_with_letters_swapped_is_offered_the_one_meant(tmp_path):
    """`method = "lei"` was told of STRATPLAN_PLANNERS and entry points, not of 'lie' (too
    far for difflib); a suggested name also no longer comes with that advice after it."""
    text = TEXT.replace(LAST_LEG, LAST_LEG + 'method = "lei"\n')
    assert _problem(tmp_path, text) == (
        "legs[1].method: must be 'lie' or 'newton' (got 'lei': did you mean 'lie'?)"
    )


def test_a_continuity_with_letters_swapped_is_offered_the_one_meant(tmp_path):
    """`continuity = "rl-C1"` was offered 'l-C1' (difflib's nearest), not 'lr-C1'."""
    text = TEXT.replace('continuity = "lr-C1"', 'continuity = "rl-C1"')
    assert "(got 'rl-C1': did you mean 'lr-C1'?)" in _problem(tmp_path, text)
