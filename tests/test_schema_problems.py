"""Validation errors as one-line problems: paths as written, allowed keys from the schema."""

from __future__ import annotations

import pytest
from conftest import ROOT
from pydantic import ValidationError

from stratcli.scenario import Scenario
from stratcli.schema_problems import validation_problems

BASE = {
    "name": "x",
    "model": {"kind": "preset", "name": "one-arm"},
    "task": {"start": [0, 0, 0, 0], "goal": [1, 0, 0, 0]},
}


def _errors(raw: dict) -> ValidationError:
    with pytest.raises(ValidationError) as exc:
        Scenario.model_validate(raw)
    return exc.value


def test_an_unknown_key_lists_the_keys_of_its_own_table_when_given_the_schema():
    exc = _errors({**BASE, "planner": {"tolerence": 1e-3}})
    (problem,) = validation_problems(exc, root=Scenario)
    assert problem.path == "planner.tolerence"
    assert problem.message.startswith("unknown key: did you mean 'tolerance'? (allowed: ")
    far = validation_problems(_errors({**BASE, "planner": {"colour": 1}}), root=Scenario)
    assert far[0].message.startswith("unknown key (allowed: ")  # nothing near it: no guess
    (bare,) = validation_problems(exc)  # no schema to walk: no list
    assert (bare.path, bare.message) == ("planner.tolerence", "unknown key")


def test_locations_are_paths_as_written_and_a_model_without_kind_names_the_kinds():
    exc = _errors({**BASE, "task": {"start": [0, 0, 0, "x"], "goal": [1, 0, 0, 0]}})
    assert [p.path for p in validation_problems(exc, root=Scenario)] == ["task.start[3]"]
    exc = _errors({**BASE, "model": {"name": "one-arm"}})
    (problem,) = validation_problems(exc, ("scenario",), root=Scenario)
    assert problem.path == "scenario.model.kind"
    assert problem.message.startswith("is missing (one of: preset")


def test_a_value_of_several_forms_is_reported_at_its_own_path_by_the_form_it_fits():
    """`max_rate` is a number or a list: -1 is a number that is out of range, not a list; the
    path is the file's (no pydantic validator names in it)."""
    raw = {**BASE, "constraints": {"max_rate": -1}}
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert problem.path == "constraints.max_rate"
    assert problem.message == "must be more than 0 (got -1)"


def test_a_table_with_an_unknown_tag_lists_the_tags_of_its_own_union():
    raw = {**BASE, "constraints": {"obstacles": [{"shape": "triangle", "centre": [0, 1]}]}}
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert problem.path == "constraints.obstacles[0].shape"
    assert problem.message == "is 'triangle', not a shape (one of: circle, box)"


def test_a_key_of_the_file_that_starts_with_a_capital_stays_in_the_path():
    """Model class names are union tags and leave the path; a parameter named `M` does not."""
    raw = {
        "name": "x",
        "model": {
            "kind": "custom",
            "states": ["x", "y", "th"],
            "inputs": ["u1", "u2"],
            "fields": {"u1": ["cos(th)", "sin(th)", 0], "u2": [0, 0, 1]},
            "parameters": {"M": "abc"},
            "strata": [{"name": "S1", "active": ["u1", "u2"]}],
        },
        "task": {"start": [0, 0, 0], "goal": [1, 0, 0]},
    }
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert problem.path == "model.parameters.M"


def test_an_obstacle_without_its_shape_names_the_shapes_not_the_model_kinds():
    raw = {**BASE, "constraints": {"obstacles": [{"centre": [0, 1], "radius": 0.2}]}}
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert (problem.path, problem.message) == (
        "constraints.obstacles[0].shape",
        "is missing (one of: circle, box)",
    )


def test_an_obstacles_keys_are_paths_of_the_file_and_list_the_keys_of_its_shape():
    """`circle` is pydantic's tag of the union, not a key of the file; a misspelt key lists
    the keys its shape takes (a circle has no rotation); the key it is a misspelling of is
    not also "missing" (one line said that beside the one that says what to write)."""
    raw = {**BASE, "constraints": {"obstacles": [{"shape": "circle", "center": [0, 1]}]}}
    found = {p.path: p.message for p in validation_problems(_errors(raw), root=Scenario)}
    assert found == {
        "constraints.obstacles[0].radius": "required field is missing",
        "constraints.obstacles[0].center": (
            "unknown key: did you mean 'centre'? (allowed: shape, centre, radius)"
        ),
    }
    box = {"shape": "box", "centre": [0, 1], "size": [1, -1], "angle": 0.1}
    raw = {**BASE, "constraints": {"obstacles": [box]}}
    found = {p.path: p.message for p in validation_problems(_errors(raw), root=Scenario)}
    assert found["constraints.obstacles[0].size[1]"].startswith("must be more than 0")
    assert found["constraints.obstacles[0].angle"] == (
        "unknown key (allowed: shape, centre, size, rotation)"
    )


def test_a_value_of_none_of_a_fields_forms_is_one_line_naming_them_all():
    """`joint_limits = 2.5` (a pair, pairs, or a table of pairs) said "must be a list"
    and, on a second line, "must be a table"."""
    raw = {**BASE, "constraints": {"joint_limits": 2.5}}
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert (problem.path, problem.message) == (
        "constraints.joint_limits",
        "must be a list or a table (got 2.5)",
    )


def test_a_name_with_a_space_says_which_characters_a_name_takes():
    """It was pydantic's "String should match pattern '^[A-Za-z0-9_.-]+$'"."""
    raw = {**BASE, "name": "my task"}
    (problem,) = validation_problems(_errors(raw), root=Scenario)
    assert (problem.path, problem.message) == (
        "name",
        "must be ASCII letters, digits, '_', '.' and '-' only, no spaces, not starting with "
        "'.' (it names the run records and files) (got 'my task')",
    )


def test_a_number_as_a_top_level_key_is_a_problem_not_an_index_error():
    """A dict scenario (not a file: TOML keys are text) with a number as its first-level key
    died in `_path` with IndexError; it is a problem at that key like a deeper one."""
    import stratcli

    with pytest.raises(stratcli.InputError, match=r"<dict>: 1: Keys should be strings"):
        stratcli.load_scenario({1: 2})


def test_a_quoted_number_and_a_table_are_said_in_toml_words(tmp_path):
    """`tolerance = "1e-3"` said "must be a valid number (got '1e-3')" (angles take text,
    so why not this?); a value where a table belongs said "a valid dictionary"."""
    import tomllib

    import stratcli

    with pytest.raises(stratcli.InputError) as info:
        stratcli.load_scenario(
            {"name": "q", "model": 5, "task": {"start": [0], "goal": [0]}, "legs": []}
        )
    assert "model: must be a table (got 5)" in str(info.value)
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    for table in ("planner", "decompose"):  # (settings tables: "an instance of PlannerSettings")
        with pytest.raises(stratcli.InputError, match=rf"{table}: must be a table \(got 3\)"):
            stratcli.load_scenario({**tomllib.loads(text), table: 3})
    with pytest.raises(stratcli.InputError) as info:
        stratcli.load_scenario(text.replace("tolerance = 1e-3", 'tolerance = "1e-3"'))
    assert "planner.tolerance: must be a valid number (got '1e-3'): a number is written " in str(
        info.value
    )
