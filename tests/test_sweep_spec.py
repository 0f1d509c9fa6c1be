"""Sweep files: grids, seeded random tasks and task tables expand into the right scenarios;
bad files give one line per problem naming the field (exit 2 on the command line)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from sweep_files import AUTO, GRID, RANDOM, ROOT, TASK_A, write
from typer.testing import CliRunner

from stratcli import tomlwrite
from stratcli.cli import app
from stratcli.errors import InputError, UnusedLegsWarning
from stratcli.models.numbers import parse_number
from stratcli.scenario import load_scenario
from stratcli.sweep import load_sweep


def test_a_grid_is_the_product_of_its_axes_first_axis_slowest(tmp_path):
    sweep = load_sweep(write(tmp_path, GRID))
    tasks = list(sweep.tasks())
    assert sweep.count == len(tasks) == 6 and sweep.keys == ("goal.q1", "goal.theta")
    q1 = np.linspace(parse_number("-pi/3"), 0, 3)
    for task in tasks:
        i, j = divmod(task.index, 2)
        assert task.inputs == {"goal.q1": q1[i], "goal.theta": [-0.2, parse_number("-pi/12")][j]}
        loaded = load_scenario(task.scenario)  # the task is a valid scenario with its values
        assert loaded.goal[0] == q1[i] and loaded.goal[3] == task.inputs["goal.theta"]
        assert loaded.settings.objective == "newton"  # `set` applies to every task
    assert [t.index for t in sweep.tasks(skip={0, 3})] == [1, 2, 4, 5]
    # another goal is another task: the paper's reference energy (task A's) is not its own
    # (a task's record printed "paper: 542.36, ratio ..." for it)
    assert "reference" in sweep.base and all("reference" not in t.scenario for t in tasks)
    tolerance = load_sweep(write(tmp_path, '[sweep.grid]\n"planner.tolerance" = [1e-3, 1e-4]\n'))
    assert all(t.scenario["reference"] == sweep.base["reference"] for t in tolerance.tasks())


def test_random_tasks_draw_from_per_task_seed_sequences(tmp_path):
    sweep = load_sweep(write(tmp_path, RANDOM))
    more = load_sweep(write(tmp_path, RANDOM.replace("count = 4", "count = 9"), name="more"))
    tasks, longer = list(sweep.tasks()), list(more.tasks())
    for k, task in enumerate(tasks):
        seq = np.random.SeedSequence(11, spawn_key=(k,))
        rng = np.random.default_rng(seq)
        assert task.inputs == {
            "goal.q1": rng.uniform(parse_number("-pi/2"), 0),
            "goal.theta": rng.uniform(-0.4, 0.0),
        }
        assert task.seed == int(seq.generate_state(1, np.uint64)[0] >> np.uint64(1))
        assert task.scenario["planner"]["seed"] == task.seed
        assert longer[k].inputs == task.inputs  # a task does not depend on the count
    assert len({t.seed for t in tasks}) == len(tasks)


def test_random_ranges_draw_settings_too_integers_where_both_bounds_are(tmp_path):
    """A range may name any value a grid may (an obstacle's centre, the tolerance): drawn
    uniformly, an integer setting's (the scenario refuses a value between integers) from low
    to high inclusive; a new user's obstacle range was refused as "random ranges are for
    coordinates"."""
    body = (
        '[sweep.random]\ncount = 12\nseed = 3\nranges = { "goal.q1" = [-1, 0], '
        '"planner.tolerance" = [1e-4, 1e-3], "planner.restarts" = [1, 3] }\n'
    )
    tasks = list(load_sweep(write(tmp_path, body)).tasks())
    for k, task in enumerate(tasks):
        rng = np.random.default_rng(np.random.SeedSequence(3, spawn_key=(k,)))
        expected = (rng.uniform(-1, 0), rng.uniform(1e-4, 1e-3), rng.integers(1, 3, endpoint=True))
        assert tuple(task.inputs.values()) == expected
        assert isinstance(task.inputs["goal.q1"], float)  # a coordinate: a float all the same
        settings = load_scenario(task.scenario).settings
        assert settings.tolerance == task.inputs["planner.tolerance"]
        assert settings.restarts == task.inputs["planner.restarts"]
    assert {t.inputs["planner.restarts"] for t in tasks} == {1, 2, 3}
    # integer bounds of a real setting: drawn from the reals all the same (a new user's
    # obstacle range [-1, 1] was drawn at -1, 0 and 1 alone)
    body = '[sweep.random]\ncount = 6\nranges = { "planner.leg_duration" = [1, 3] }\n'
    drawn = [t.inputs["planner.leg_duration"] for t in load_sweep(write(tmp_path, body)).tasks()]
    assert all(isinstance(x, float) and 1 <= x <= 3 for x in drawn)
    assert len(set(drawn)) == 6
    obstacle = ROOT / "scenarios" / "sim4_task_d_obstacles.toml"
    x_range = '"constraints.obstacles[0].centre[0]" = [-0.35, -0.25]'
    body = f"[sweep.random]\ncount = 3\nranges = {{ {x_range} }}\n"
    for task in load_sweep(write(tmp_path, body, scenario=obstacle, name="o")).tasks():
        x = task.inputs["constraints.obstacles[0].centre[0]"]
        assert (
            -0.35 <= x <= -0.25 and task.scenario["constraints"]["obstacles"][0]["centre"][0] == x
        )


def test_a_task_table_and_an_inline_scenario(tmp_path):
    base = TASK_A.read_text().replace("[model]", "[scenario.model]")
    for table in ("task", "planner", "legs", "reference"):
        base = base.replace(f"[{table}]", f"[scenario.{table}]")
    path = tmp_path / "inline.toml"
    path.write_text(
        '[sweep]\nname = "inline"\n\n[[sweep.task]]\n"goal.q1" = -0.5\n'
        '"planner.tolerance" = 1e-4\n\n[[sweep.task]]\n"goal.q1" = "-pi/4"\n'
        '"planner.tolerance" = 1e-3\n\n[scenario]\n' + base.replace("[[legs]]", "[[scenario.legs]]")
    )
    sweep = load_sweep(path)
    tasks = list(sweep.tasks())
    assert [t.inputs for t in tasks] == [
        {"goal.q1": -0.5, "planner.tolerance": 1e-4},
        {"goal.q1": parse_number("-pi/4"), "planner.tolerance": 1e-3},
    ]
    assert load_scenario(tasks[0].scenario).settings.tolerance == 1e-4


def test_auto_mode_plans_the_base_without_its_legs(tmp_path):
    """... and says so (`UnusedLegsWarning`, a note on the command line; it was silent, where
    `plan` and `compare-sequences` say it); a base without legs says nothing."""
    with pytest.warns(UnusedLegsWarning, match=r'^sweep: mode = "auto" decomposes each task '
                      r"afresh, so the base scenario's \[\[legs\]\] are not used$"):  # fmt: skip
        sweep = load_sweep(write(tmp_path, GRID, mode="auto"))
    task = next(sweep.tasks())
    assert "legs" not in task.scenario and "decompose" in task.scenario
    assert not load_scenario(task.scenario).legs
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sweep = load_sweep(write(tmp_path, GRID, scenario=AUTO, mode="compare", name="c"))
    assert sweep.mode == "compare"


BAD = [
    ("[sweep.grid]\n\"goal.q9\" = [1, 2]\n", 'sweep.grid."goal.q9": unknown coordinate'),
    ("[sweep.grid]\n\"goal.q1\" = [1, \"abc\"]\n", 'sweep.grid."goal.q1"[1]:'),
    ("[sweep.grid]\n\"planner.continuity\" = [\"C7\"]\n", 'sweep.grid."planner.continuity"[0]'),
    ("[sweep.grid]\n\"goal.q1\" = { linspace = [0, 1, 0] }\n", "linspace[2]: must be a whole"),
    (  # it said "at least 3 entries" (read as 3 or more) and, with 4, "at most 3"
        "[sweep.grid]\n\"goal.q1\" = { linspace = [0, 1] }\n",
        "linspace: must be [start, stop, count]: 3 values, not 2",
    ),
    ("[sweep.grid]\n\"goal.q1\" = { linspace = [0, 1, 2] }\n[sweep.random]\ncount = 2\n"
     "ranges = { \"goal.q1\" = [0, 1] }\n", "sweep: give only one of"),
    ("[sweep.random]\ncount = 2\nranges = { \"goal.q1\" = [1, 0] }\n", "low must be below high"),
    ("[sweep.random]\ncount = 0\nranges = { \"goal.q1\" = [0, 1] }\n", "sweep.random.count"),
    (  # a key of a grid axis's table: the typo's hint, and not also "linspace: missing"
        "[sweep.grid]\n\"goal.q1\" = { linspce = [0, 1, 3] }\n",
        'sweep.grid."goal.q1".linspce: unknown key: did you mean \'linspace\'? (allowed: '
        "linspace)",
    ),
    (  # it said "... or instance of Linspace"
        "[sweep.grid]\n\"goal.q1\" = -1.0\n",
        'sweep.grid."goal.q1": must be a list or a table (got -1.0)',
    ),
    (  # names are not drawn: it said "in 'l-C0': unknown name 'l'"
        "[sweep.random]\ncount = 2\nranges = { \"planner.continuity\" = [\"l-C0\", \"lr-C1\"] }\n",
        'sweep.random.ranges."planner.continuity": a random range draws a number between two '
        "bounds, and planner.continuity takes names ('l-C0'): vary it over a list in "
        "[sweep.grid] or [[sweep.task]]",
    ),
    (  # an integer setting's range with a bound that is not an integer
        "[sweep.random]\ncount = 2\nranges = { \"planner.restarts\" = [0, 2.5] }\n",
        'sweep.random.ranges."planner.restarts"[1]: ',
    ),
    (
        "[[sweep.task]]\n\"goal.q1\" = 1\n[[sweep.task]]\n\"goal.q2\" = 1\n",
        "sweep.task[0]: misses goal.q2 (set by sweep.task[1]): every [[sweep.task]] sets the same",
    ),
    ("[sweep.grid]\n\"legs[5].goal.q1\" = [0]\n", "the scenario has no legs[5]"),
    (
        "grod = 1\n[sweep.grid]\n\"goal.q1\" = [0]\n",
        "sweep.grod: unknown key: did you mean 'grid'? (allowed: name, ",
    ),
    ("check = \"yes\"\n[sweep.grid]\n\"goal.q1\" = [0]\n", "sweep.check: must be"),
    (  # ignored before: legs mode compares no candidates
        "exhaustive = true\n[sweep.grid]\n\"goal.q1\" = [0]\n",
        'sweep.exhaustive: applies to mode = "compare" only (its comparison then searches '
        'every candidate sequence fully), not to mode = "legs": remove it or set that mode',
    ),
    ("[sweep.random]\ncount = \"3\"\nranges = { \"goal.q1\" = [0, 1] }\n", "count: must be"),
]  # fmt: skip


@pytest.mark.parametrize(("body", "expected"), BAD)
def test_a_bad_sweep_file_names_the_field(tmp_path, body, expected):
    path = write(tmp_path, body)
    with pytest.raises(InputError) as exc:
        load_sweep(path)
    lines = str(exc.value).splitlines()
    assert all(line.startswith(f"{path}: ") for line in lines)
    assert any(expected in line for line in lines), lines


def test_the_command_exits_2_with_one_line_per_problem(tmp_path):
    """The schema's problem and those of the values in one run, not one stage per run."""
    path = write(tmp_path, '[sweep.grid]\n"goal.q9" = [1]\n"goal.q1" = ["x", 0]\n')
    text = path.read_text().replace('mode = "legs"', 'mode = "legs"\ncheck = "maybe"')
    path.write_text(text)
    result = CliRunner().invoke(app, ["sweep", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert len(lines) == 3, result.output
    assert lines[0].startswith(f"error: {path}: sweep.check: must be a valid boolean")
    assert 'sweep.grid."goal.q9": unknown coordinate' in lines[1]
    assert 'sweep.grid."goal.q1"[0]' in lines[2]
    assert not (tmp_path / "o").exists()


def test_one_mistake_on_every_value_of_a_long_axis_lists_three_and_counts_the_rest(tmp_path):
    """Task D's second leg keeps q1 at its first leg's goal: every q1 of the axis is a problem
    of its own (its message names the value), one line each: 50 lines, 8.8 kB."""
    scenario = ROOT / "scenarios" / "sim4_task_d.toml"
    body = '[sweep.grid]\n"goal.q1" = { linspace = [-1.5, -1.2, 50] }\n'
    with pytest.raises(InputError) as caught:
        load_sweep(write(tmp_path, body, scenario=scenario))
    lines = str(caught.value).splitlines()
    assert len(lines) == 4, lines
    assert [line.split(": ")[1] for line in lines] == [
        'sweep.grid."goal.q1"[0]',
        'sweep.grid."goal.q1"[1]',
        'sweep.grid."goal.q1"[2]',
        'sweep.grid."goal.q1"',
    ]
    assert "q1 is locked at -1.0472 on this stratum but its goal is -1.5;" in lines[0]
    assert lines[3].endswith(
        'sweep.grid."goal.q1": 47 more of its 50 values checked have problems too'
    )
    few = '[sweep.grid]\n"goal.q1" = [-1.5, -1.4, -1.3, -1.2]\n'  # four: each is listed
    with pytest.raises(InputError) as caught:
        load_sweep(write(tmp_path, few, scenario=scenario, name="few"))
    assert len(str(caught.value).splitlines()) == 4 and "more of its" not in str(caught.value)


INLINE = """[scenario]
name = "inline"
model = { kind = "preset", name = "one-arm" }
task = { start = [0, 0, 0, 0], goal = [0, 0, 0] }
decompose = {}
"""

# A file with problems the schema finds and problems of its values (which the schema's do
# not cause): every one is reported, once (`expected`: the start of each line, in order)
STAGES = [
    (  # an unknown key of [sweep], and a grid key naming no coordinate
        'colour = "red"\n[sweep.grid]\n"goal.q9" = [1, 2]\n"goal.theta" = [0.1]\n',
        "auto", AUTO,
        ["sweep.colour: unknown key", 'sweep.grid."goal.q9": unknown coordinate \'q9\''],
    ),
    (  # a mode and a count out of range, and two bounds that are not numbers
        '[sweep.random]\ncount = 0\n'
        'ranges = { "goal.q1" = ["-pi/zz", 0], "goal.theta" = [0, "x"] }\n',
        "automatic", AUTO,
        ["sweep.mode: must be 'legs', 'auto' or 'compare' (got 'automatic')",
         "sweep.random.count: must be at least 1",
         'sweep.random.ranges."goal.q1"[0]: in \'-pi/zz\'',
         'sweep.random.ranges."goal.theta"[1]: in \'x\''],
    ),
    (  # a description that is not text, a task that misses a key and a value not a number
        'description = 5\n[[sweep.task]]\n"goal.q1" = -0.5\n"planner.seed" = 3\n'
        '[[sweep.task]]\n"goal.q1" = "abc"\n',
        "auto", AUTO,
        ["sweep.description: must be a valid string (got 5)",
         'sweep.task[1]."goal.q1": in \'abc\'',
         "sweep.task[1]: misses planner.seed (set by sweep.task[0])"],
    ),
    (  # a setting the schema refuses, the base scenario's own problem, a key naming nothing
        'check = "maybe"\n[sweep.grid]\n"goal.q1" = [0.1]\n"goal.q9" = [1]\n' + INLINE,
        "auto", None,
        ["sweep.check: must be a valid boolean",
         "scenario.task.goal: needs 4 values (q1, q2, q3, theta), got 3",
         'sweep.grid."goal.q9": unknown coordinate \'q9\''],
    ),
    (  # a range whose key names no coordinate and whose bound is not a number: both
        '[sweep.random]\ncount = 2\nranges = { "goal.q9" = ["-pi/zz", 1] }\n',
        "auto", AUTO,
        ['sweep.random.ranges."goal.q9": unknown coordinate \'q9\'',
         'sweep.random.ranges."goal.q9"[0]: in \'-pi/zz\''],
    ),
    (  # a range of a setting the scenario does not have, and a tolerance's bound below 0
        '[sweep.random]\ncount = 2\nranges = { "planner.harmonic" = [1, 3], '
        '"planner.tolerance" = [-1e-3, 1e-3] }\n',
        "auto", AUTO,
        ['sweep.random.ranges."planner.harmonic": ',
         'sweep.random.ranges."planner.tolerance"[0]: '],
    ),
]  # fmt: skip


@pytest.mark.parametrize(("body", "mode", "scenario", "expected"), STAGES)
def test_problems_of_the_schema_and_of_the_values_are_reported_in_one_run(
    tmp_path, body, mode, scenario, expected
):
    path = write(tmp_path, body, scenario=scenario or AUTO, mode=mode)
    if scenario is None:  # the base is the inline [scenario]
        path.write_text(path.read_text().replace(f'scenario = "{AUTO}"\n', ""))
    with pytest.raises(InputError) as exc:
        load_sweep(path)
    lines = [line.removeprefix(f"{path}: ") for line in str(exc.value).splitlines()]
    assert len(lines) == len(expected), lines
    for line, start in zip(lines, expected, strict=True):
        assert line.startswith(start), (line, start)


# A value the schema refuses is left out of the checks of the values: nothing it causes is
# reported beside it (no missing table of tasks, base scenario or [[legs]] of legs mode)
REFUSED = [
    ('[sweep.grid]\n"goal.q1" = 5\n', "auto", 'sweep.grid."goal.q1": '),
    ('[sweep.random]\ncount = 2\nranges = { "goal.q1" = 3 }\n', "auto", "sweep.random.ranges"),
    ('[[sweep.task]]\n"goal.q1" = 1\n', "automatic", "sweep.mode: "),
    ('[sweep.grid]\n"goal.q1" = [0]\n', "auto", "sweep.scenario: must be a valid string"),
]  # fmt: skip


@pytest.mark.parametrize(("body", "mode", "expected"), REFUSED)
def test_a_refused_value_causes_no_second_problem(tmp_path, body, mode, expected):
    path = write(tmp_path, body, scenario=AUTO, mode=mode)
    if expected.startswith("sweep.scenario"):
        path.write_text(path.read_text().replace(f'"{AUTO}"', "5"))
    with pytest.raises(InputError) as exc:
        load_sweep(path)
    lines = [line.removeprefix(f"{path}: ") for line in str(exc.value).splitlines()]
    assert lines and all(line.startswith(expected) for line in lines), lines


def test_a_nan_in_a_sweep_file_is_reported_with_every_other_problem(tmp_path):
    """Only `sweep.grid.goal.theta[0]: must be a finite number (got nan)` was printed, and
    with its key unquoted, unlike the other problems of the same axis."""
    body = 'colour = 1\n[sweep.grid]\n"goal.theta" = [nan, 0.1]\n"goal.q9" = [1]\n'
    with pytest.raises(InputError) as caught:
        load_sweep(write(tmp_path, body))
    assert [f"{p.path}: {p.message}"[:44] for p in caught.value.problems] == [
        'sweep.grid."goal.theta"[0]: must be a finite',
        "sweep.colour: unknown key (allowed: name, de",
        'sweep.grid."goal.q9": unknown coordinate \'q9',
    ]


def test_a_task_is_a_base_scenario_of_a_sweep_given_as_a_dict():
    """`{"sweep": {...}, "scenario": task}` was "cannot be written as TOML: cannot write Task
    to TOML" (a notebook's tables had to be `tomllib.loads(task.text)`); a URDF task's
    relative path stays its file's."""
    task = load_scenario(TASK_A).with_changes({"planner.tolerance": 1e-4})
    grid = {"goal.theta": [0.1]}
    given = [
        {"sweep": {"name": "a", "grid": grid}, "scenario": task},
        {"sweep": {"name": "b", "grid": grid, "scenario": task}},
    ]
    for source in given:
        (first,) = load_sweep(source).tasks()
        planned = load_scenario(first.scenario)
        assert planned.settings.tolerance == 1e-4 and planned.goal[3] == 0.1
    arm3 = load_scenario(ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    base = load_sweep({"sweep": {"name": "u", "grid": {"goal.j2": [0.1]}}, "scenario": arm3}).base
    assert Path(base["model"]["path"]).resolve() == (ROOT / "robots" / "arm3.urdf").resolve()
    with pytest.raises(InputError, match=r"sweep\.scenario: give a path or a \[scenario\] "):
        load_sweep({**given[1], "scenario": task})


def test_the_base_scenarios_reference_energy_is_the_sweeps_only_where_the_task_is_its(
    tmp_path,
):
    """Each task of a sweep over goals drops the paper's energy (for the paper's task), but
    the sweep kept it, and energy_hist.png took every task's ratio to it."""
    over_goals = load_sweep(write(tmp_path, RANDOM))
    assert over_goals.reference_energy is None
    assert all("reference" not in task.scenario for task in over_goals.tasks())
    seeds = '[sweep.grid]\n"planner.seed" = [1, 2]\n'
    over_seeds = load_sweep(write(tmp_path, seeds, name="seeds"))
    assert over_seeds.reference_energy == 542.36  # sim4_task_a's: every task is the paper's
    assert all(task.scenario["reference"]["energy"] == 542.36 for task in over_seeds.tasks())


def test_the_shipped_goal_map_is_a_21_by_21_auto_grid_around_the_papers_goal():
    sweep = load_sweep(ROOT / "scenarios" / "sweeps" / "sim4_goal_map.toml")
    assert sweep.mode == "auto" and sweep.count == 441 and sweep.keys == ("goal.q1", "goal.theta")
    middle = next(sweep.tasks(skip=set(range(220))))  # task 220: the middle of the grid
    goal = load_scenario(middle.scenario).goal
    assert np.allclose(goal, [-np.pi / 3, np.pi / 3, np.pi / 4, -np.pi / 12], atol=1e-12)


def test_problems_of_the_base_scenario_name_its_file(tmp_path):
    base = tmp_path / "base.toml"
    base.write_text(TASK_A.read_text().replace("tolerance = 1e-3", "tolerance = 7"))
    with pytest.raises(InputError) as exc:
        load_sweep(write(tmp_path, GRID, scenario=base))
    assert "sweep.scenario: " in str(exc.value) and "planner.tolerance" in str(exc.value)
    assert str(base) in str(exc.value)
    base.write_text('name = "nolegs"\n[model]\nkind = "preset"\nname = "one-arm"\n'
                    "[task]\nstart = [0, 0, 0, 0]\ngoal = [1, 0, 0, 0]\n")  # fmt: skip
    with pytest.raises(
        InputError, match=r"sweep\.mode: legs mode plans the base scenario.s \[\[legs\]\]"
    ):
        load_sweep(write(tmp_path, GRID, scenario=base))
    assert load_sweep(write(tmp_path, GRID, scenario=base, mode="auto")).count == 6


def test_legs_mode_refuses_an_auto_mode_base_at_once(tmp_path):
    """An auto-mode base ([decompose], no [[legs]]) loads, but in legs mode every task would
    end `invalid`: the file is refused instead, saying which modes plan it."""
    with pytest.raises(InputError) as exc:
        load_sweep(write(tmp_path, GRID, scenario=AUTO))
    assert str(exc.value).count("\n") == 0
    assert "sweep.mode: legs mode plans the base scenario's [[legs]], and " in str(exc.value)
    assert str(exc.value).endswith('has none: set mode = "auto" or "compare"')
    assert load_sweep(write(tmp_path, GRID, scenario=AUTO, mode="auto", name="a")).count == 6
    unset = write(tmp_path, GRID, scenario=AUTO, name="u")  # no mode: blamed a key not given
    unset.write_text(unset.read_text().replace('mode = "legs"\n', ""))
    with pytest.raises(InputError, match=r"sweep\.mode: legs mode \(the default, where no mode "
                       r"is given\) plans the base scenario's \[\[legs\]\]"):  # fmt: skip
        load_sweep(unset)


def test_a_missing_base_scenario_names_the_path_as_given_and_as_read(tmp_path):
    """A relative `sweep.scenario` is read beside the sweep file: the error says where."""
    (tmp_path / "sub").mkdir()
    sweep = write(tmp_path / "sub", GRID, scenario="../nope.toml")
    with pytest.raises(InputError) as exc:
        load_sweep(sweep)
    read = str(tmp_path / "nope.toml")
    assert f"sweep.scenario: ../nope.toml ({read}): cannot read scenario file" in str(exc.value)


def test_a_base_scenarios_relative_urdf_path_is_relative_to_that_scenario(tmp_path):
    """As when the base scenario is planned alone: not relative to the working directory
    (its tasks are dicts, loaded where the sweep runs)."""
    pytest.importorskip("pinocchio")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        '[sweep]\nname = "u"\nscenario = "%s"\n[sweep.grid]\n"planner.tolerance" = [1e-5]\n'
        % (ROOT / "scenarios" / "spatial" / "arm3_reorient.toml")
    )
    (task,) = load_sweep(sweep).tasks()
    assert load_scenario(task.scenario).system.n == 6


def test_an_inline_base_scenarios_relative_urdf_path_is_relative_to_the_sweep_file(tmp_path):
    """A top-level [scenario] table is the sweep file's own: its relative URDF path is read
    beside that file (it was read from the working directory)."""
    pytest.importorskip("pinocchio")
    import shutil
    import tomllib

    source = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    base = tomllib.loads(source.read_text())
    urdf = source.parent / base["model"]["path"]
    (tmp_path / "my_robots").mkdir()
    shutil.copy(urdf, tmp_path / "my_robots" / "arm3_copy.urdf")
    base["model"]["path"] = "my_robots/arm3_copy.urdf"
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        '[sweep]\nname = "u"\n[sweep.grid]\n"planner.tolerance" = [1e-5]\n\n'
        + tomlwrite.dumps({"scenario": base})
    )
    (task,) = load_sweep(sweep).tasks()
    assert load_scenario(task.scenario).system.n == 6


def test_a_problem_every_value_of_an_axis_has_is_one_line():
    """An unknown setting is the axis's problem, not each value's (it printed once a value)."""
    body = '[sweep.grid]\n"planner.harmonics" = [2, 3, 4]\n"goal.q1" = [0, "x"]\n'
    with pytest.raises(InputError) as exc:
        load_sweep(
            '[sweep]\nname = "h"\nscenario = "%s"\n' % (ROOT / "scenarios" / "sim4_task_a.toml")
            + body
        )
    lines = str(exc.value).splitlines()
    assert len(lines) == 2, lines
    assert 'sweep.grid."planner.harmonics": planner.harmonics: unknown key' in lines[0]
    assert lines[0].endswith("(every value)") and "sweep.grid.\"goal.q1\"[1]: in 'x'" in lines[1]


def test_linspace_over_an_integer_setting_gives_integers(tmp_path):
    """`planner.seed = { linspace = [0, 4, 5] }` gave 0.0 ... 4.0, which the (strict) seed
    refuses; integer ends and integral points of a setting are integers, coordinates stay
    floats."""
    body = (
        '[sweep.grid]\n"planner.seed" = { linspace = [0, 4, 5] }\n'
        '"goal.theta" = { linspace = [-1, 0, 2] }\n'
    )
    tasks = list(load_sweep(write(tmp_path, body)).tasks())
    seeds = [t.inputs["planner.seed"] for t in tasks[::2]]
    assert seeds == [0, 1, 2, 3, 4] and all(type(s) is int for s in seeds)
    assert [t.inputs["goal.theta"] for t in tasks[:2]] == [-1.0, 0.0]
    assert type(tasks[0].inputs["goal.theta"]) is float


def test_a_urdf_configuration_by_name_takes_its_attitude_components_as_keys(tmp_path):
    """README: a key is goal.NAME, NAME a coordinate of the model; a URDF model's rx, ry, rz
    were refused in a configuration given by name ("unknown names rz")."""
    pytest.importorskip("pinocchio")
    reorient = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    rpy = tmp_path / "rpy.toml"
    rpy.write_text(
        reorient.read_text()
        .replace('path = "../../robots/arm3.urdf"', f'path = "{ROOT / "robots" / "arm3.urdf"}"')
        .replace(
            "attitude = [0.18888013627784192, 0.1584892526874515, 0.18888013627784192] }",
            'rpy = ["10deg", 0, 0] }',
        )
    )
    cases = [
        (reorient, '"goal.rz" = [0.05]', [0.18888013627784192, 0.1584892526874515, 0.05]),
        (rpy, '"goal.rz" = [0.05]', [np.radians(10), 0.0, 0.05]),
        (reorient, '"legs[1].goal.rz" = [0.05]', None),  # ["*", 0.174..., "*"]: rz prescribed
    ]
    for scenario, axis, expected in cases:
        sweep = write(tmp_path, f"[sweep.grid]\n{axis}\n", scenario=scenario)
        (task,) = load_sweep(sweep).tasks()
        loaded = load_scenario(task.scenario)
        if expected is not None:
            np.testing.assert_allclose(loaded.goal[3:], expected, atol=1e-15)
        else:
            via = loaded.legs[1].goal
            assert np.isnan(via[3]) and via[4] == pytest.approx(0.17408920232346858)
            assert via[5] == 0.05
    # a name the model has not is named with the keys it takes (it listed the scenario's
    # names, "attitude" and "rpy" among them, which are no keys)
    bad = write(tmp_path, '[sweep.grid]\n"goal.q9" = [1.0]\n', scenario=reorient, name="bad")
    with pytest.raises(InputError) as info:
        load_sweep(bad)
    assert info.value.problems[0].message == (
        "unknown coordinate 'q9' (this model has: j1, j2, j3, rx, ry, rz)"
    )


def test_a_grid_over_one_entry_of_a_list_setting_moves_an_obstacle(tmp_path):
    body = '[sweep.grid]\n"constraints.obstacles[0].centre[0]" = { linspace = [-0.5, 0.1, 3] }\n'
    obstacles = ROOT / "scenarios" / "sim4_task_d_obstacles.toml"
    sweep = load_sweep(write(tmp_path, body, scenario=obstacles))
    xs = []
    for task in sweep.tasks():
        (circle, box) = load_scenario(task.scenario).constraints.spec["obstacles"]
        xs.append(circle["centre"][0])
        assert circle["centre"][1] == 1.3 and box["centre"] == [1.9, -0.1]  # the rest kept
    assert xs == pytest.approx([-0.5, -0.2, 0.1])
    body = body.replace("centre[0]", "centre[2]")
    with pytest.raises(InputError) as info:
        load_sweep(write(tmp_path, body, scenario=obstacles, name="past"))
    (problem,) = info.value.problems
    assert problem.message == "the scenario has no constraints.obstacles[0].centre[2]"


def test_a_linspace_point_that_is_zero_but_for_rounding_is_zero(tmp_path):
    """-pi/4 to pi/12 in 5 steps wrote goal.theta = 1.1102230246251565e-16 into results.csv."""
    body = '[sweep.grid]\n"goal.theta" = { linspace = ["-pi/4", "pi/12", 5] }\n'
    values = [t.inputs["goal.theta"] for t in load_sweep(write(tmp_path, body)).tasks()]
    assert values[3] == 0.0 and values == pytest.approx(np.linspace(-np.pi / 4, np.pi / 12, 5))


def test_a_misspelt_key_of_a_grid_axis_is_one_line(tmp_path):
    path = write(tmp_path, '[sweep.grid]\n"goal.q1" = { linspce = [0, 1, 3] }\n')
    with pytest.raises(InputError) as exc:
        load_sweep(path)
    (line,) = str(exc.value).splitlines()  # not also "linspace: required field is missing"
    assert line.endswith("linspce: unknown key: did you mean 'linspace'? (allowed: linspace)")


@pytest.mark.parametrize("name", ["..", ".", ".hidden"])
def test_a_sweep_name_that_is_no_directory_of_its_own_is_refused(tmp_path, name):
    """`name = ".."` made the default output sweeps/.. (refused only because that folder
    held files); a name starting with "." is a hidden folder, as a run's partial one is."""
    path = write(tmp_path, '[sweep.grid]\n"goal.q1" = [0]\n', name=name)
    with pytest.raises(InputError, match=r"sweep\.name: .*not starting with '\.'"):
        load_sweep(path)
