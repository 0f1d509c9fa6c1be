"""What a notebook passes as a scenario or a sweep: a path, TOML text or a dict, with numpy
values and arrays in it; each problem named once, with one "(got ...)"."""

from __future__ import annotations

import copy
import pickle
import tomllib

import numpy as np
import pytest
from sweep_files import GRID, ROOT, TASK_A, write

import stratcli
from stratcli.errors import InputError
from stratcli.sweep import load_sweep

UNICYCLE = tomllib.loads((TASK_A.parent / "unicycle.toml").read_text())


def _with(**planner) -> dict:
    scenario = copy.deepcopy(UNICYCLE)
    scenario["planner"].update(planner)
    return scenario


def test_numpy_scalars_and_arrays_in_a_dict_are_python_values():
    source = _with(
        basis={"harmonics": np.int64(5), "period": np.float64(2.5)},
        seed=np.int64(3), starts=np.int32(2), soft_start=np.True_,
    )  # fmt: skip
    source["task"]["goal"] = np.array([0.0, 1.0, 0.0])
    task = stratcli.load_scenario(source)
    s = task.settings
    assert (s.basis.harmonics, s.seed, s.starts, s.soft_start) == (5, 3, 2, True)
    assert type(s.basis.harmonics) is int and type(s.soft_start) is bool
    np.testing.assert_array_equal(task.goal, [0.0, 1.0, 0.0])
    assert "harmonics = 5\n" in task.text  # recorded as the TOML file it stands for
    assert type(source["planner"]["seed"]) is np.int64  # the caller's dict is left as it is


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        (np.array([0.0, 1.0, np.nan]), ["task.goal[2]: must be a finite number (got nan)"]),
        ([0.0, 1.0, np.float64(np.inf)], ["task.goal[2]: must be a finite number (got inf)"]),
        (
            np.zeros((3, 1)),
            [
                f"task.goal[{i}]: expected a number or an expression such as 'pi/3' (got [0.0])"
                for i in range(3)
            ],
        ),
        ([True, 1, 0], ["task.goal[0]: expected a number (got True)"]),
    ],
    ids=["nan-array", "inf-scalar", "2-d", "bool"],
)
def test_a_bad_value_is_shown_once(goal, expected):
    source = copy.deepcopy(UNICYCLE)
    source["task"]["goal"] = goal
    with pytest.raises(InputError) as caught:
        stratcli.load_scenario(source)
    lines = str(caught.value).splitlines()
    assert lines == [f"<dict 'unicycle'>: {line}" for line in expected]  # its own name
    assert all(line.count("(got ") == 1 for line in lines)


def test_an_unnamed_dict_or_text_is_named_for_what_it_is():
    source = copy.deepcopy(UNICYCLE)
    del source["name"]
    with pytest.raises(InputError, match=r"^<dict>: name: required field is missing"):
        stratcli.load_scenario(source)
    source["name"] = ["not", "a", "name"]
    with pytest.raises(InputError, match=r"^<dict>: name: "):
        stratcli.load_scenario(source)
    with pytest.raises(InputError, match=r"^<text>: name: required field is missing"):
        stratcli.load_scenario('[model]\nkind = "preset"\nname = "unicycle"\n')


def test_a_sweep_is_a_path_toml_text_or_a_dict_with_numpy_axes(tmp_path):
    path = write(tmp_path, GRID)
    text = path.read_text()
    from_path, from_text = load_sweep(path), load_sweep(text)
    as_dict = tomllib.loads(text)
    as_dict["sweep"]["grid"] = {"goal.q1": np.linspace(-1.0, 0.0, 3), "goal.theta": [-0.2, 0.0]}
    from_dict = load_sweep(as_dict)
    assert from_text.source == "<text 'small'>" and from_dict.source == "<dict 'small'>"
    assert from_path.digest == from_text.digest  # the same tasks
    assert from_dict.count == 6 and [t.inputs for t in from_dict.tasks()][1] == {
        "goal.q1": -1.0,
        "goal.theta": 0.0,
    }
    seeds = copy.deepcopy(as_dict)
    seeds["sweep"]["grid"] = {"planner.seed": np.arange(4)}
    assert [t.seed for t in load_sweep(seeds).tasks()] == [0, 1, 2, 3]


def test_a_missing_sweep_file_is_named_a_sweep_file(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(InputError, match=r"nope\.toml: cannot read sweep file: No such file"):
        stratcli.run_sweep(missing)
    with pytest.raises(InputError, match=r"^<text 'd'>: sweep\.scenario: give a base scenario"):
        stratcli.run_sweep('[sweep]\nname = "d"\n[sweep.grid]\n"goal.y" = [0]\n')


def test_run_sweep_plans_a_dict(tmp_path):
    sweep = {"sweep": {"name": "d", "grid": {"goal.y": np.array([1.0])}}, "scenario": UNICYCLE}
    outcome = stratcli.run_sweep(sweep, tmp_path / "d", jobs=1, records="none")
    assert outcome.summary["done"] == 1 and outcome.rows[0]["status"] == "ok"
    # frozen values: their rows and summaries are read-only too (they were plain dicts)
    report = stratcli.read_sweep(tmp_path / "d")
    assert report.rows == outcome.rows
    for rows in (outcome.rows, report.rows, pickle.loads(pickle.dumps(report)).rows):
        with pytest.raises(TypeError, match="read-only"):
            rows[0]["status"] = "failed"
    with pytest.raises(TypeError, match="read-only"):
        outcome.summary["done"] = 0


def test_a_path_with_an_equals_sign_is_a_path(tmp_path):
    """Directories such as `lr=0.1` are common; only a string naming no file is read as TOML
    text for its "=" (one line of text is never a whole scenario anyway)."""
    folder = tmp_path / "tol=1e-3"
    folder.mkdir()
    (folder / "s.toml").write_text((ROOT / "scenarios" / "unicycle.toml").read_text())
    task = stratcli.load_scenario(str(folder / "s.toml"))
    assert task.source == str(folder / "s.toml")
    assert stratcli.check_controllability(str(folder / "s.toml"), samples=0).controllable
    assert load_sweep(str(write(folder, GRID))).count == 6
    with pytest.raises(InputError, match=r"^<text>: name: must be ASCII letters"):  # not a name
        stratcli.load_scenario('name = "one line"')


def test_a_pathlib_path_in_a_dict_is_the_path_it_names(tmp_path):
    """A notebook builds paths with pathlib: `model.path` (a URDF) and a sweep's `scenario`
    were refused, 'must be a valid string (got PosixPath(...))'."""
    arm = tomllib.loads((ROOT / "scenarios" / "spatial" / "arm3_reorient.toml").read_text())
    arm["model"]["path"] = ROOT / "robots" / "arm3.urdf"
    task = stratcli.load_scenario(arm)
    assert task.scenario.model.path == str(ROOT / "robots" / "arm3.urdf")
    sweep = tomllib.loads(write(tmp_path, GRID).read_text())
    sweep["sweep"]["scenario"] = TASK_A  # a Path
    assert load_sweep(sweep).count == 6
