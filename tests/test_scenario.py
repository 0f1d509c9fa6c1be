"""Loading scenarios: Lie-leg validation, and a seeded fuzz of scenario inputs.

The fuzz mutates the shipped scenarios in the families of issue 12 item 5 (physical parameters,
custom-model expressions, bytes and encodings, size and nesting of the TOML, names) and loads
them with `load_scenario`; a few go through the CLI as well. Nothing but `InputError` may
escape loading, the CLI exits 0-3 and never prints a traceback.
"""

from __future__ import annotations

import random
import re
import time
from pathlib import Path

import pytest
from conftest import ROOT
from typer.testing import CliRunner

from stratcli.cli import app
from stratcli.errors import InputError
from stratcli.scenario import load_scenario, parse_scenario


def test_scenario_validation_of_lie_legs(tmp_path):
    base = (
        'name = "x"\n[model]\nkind = "preset"\nname = "one-arm"\n[task]\nstart = [0, 0, 0, 0]\n'
        "goal = [0, 0.1, 0.1, 0]\n"
    )
    good = base + '[[legs]]\nstratum = "S1"\nmethod = "lie"\nlie = { gamma = 0.3 }\n'
    task = parse_scenario(good)
    assert task.legs[0].lie.gamma == 0.3 and task.legs[0].lie.step_duration == 0.51
    with pytest.raises(Exception, match="duration"):
        parse_scenario(good.replace("lie = {", "duration = 2.0\nlie = {"))
    with pytest.raises(Exception, match="lie"):
        parse_scenario(base + '[[legs]]\nstratum = "S1"\nlie = { degree = 3 }\n')
    with pytest.raises(Exception, match="degree"):
        parse_scenario(base + '[planner]\nlie = { degree = 4 }\n[[legs]]\nstratum = "S1"\n')


SEED = 12


SCENARIOS = {p.name: p.read_text() for p in sorted((ROOT / "scenarios").glob("*.toml"))}


PLANAR = [n for n, t in SCENARIOS.items() if 'kind = "planar-manipulator"' in t]


CUSTOM = [n for n, t in SCENARIOS.items() if 'kind = "custom"' in t]


BAD_NUMBERS = [
    "0", "-1", "-0.0", "nan", "inf", "-inf", "1e300", "1e38", "1e-320", "5e-324",
    '"nan"', '"1e400"', '"9**9**9**9"', '"2**10**8"', '"exp(exp(exp(1e15)))"', '"pi/0"',
    '"x"', '"sin"', "true", '"1e38"', "[]", "{}", "9223372036854775807",
]  # fmt: skip


BAD_EXPRESSIONS = [
    "9**9**9**9", "2**10**8", "x(1)", "sin", "sin(1,2)", "sin(x=1)", "foo(1)",
    "exp(exp(exp(1e15)))",
    "(" * 300 + "1" + ")" * 300, "-" * 1500 + "1", "+".join(["1"] * 700), "1/0", "log(0)",
    "__import__('os')", "().__class__", "lambda: 1", "[1]", "1 if 1 else 2", "1j", "'s'",
    "x" * 3000, "", "   ", "sqrt(-1)", "atan2(1)", "abs()", "10**30", "1e308*1e308", "pi(2)",
]  # fmt: skip


NUMBER = re.compile(r"(?<![\w.\"'])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.\"'])")


STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"')


def _load(path: Path, what: str) -> None:
    """load_scenario must return or raise InputError; anything else fails with `what`."""
    t0 = time.perf_counter()
    try:
        load_scenario(path)
    except InputError as exc:
        assert "Traceback" not in str(exc)
    except Exception as exc:  # the point of the test
        pytest.fail(f"{what}: {type(exc).__name__}: {exc}"[:400])
    assert time.perf_counter() - t0 < 20, f"{what}: took {time.perf_counter() - t0:.1f} s"


def _replace_nth(pattern: re.Pattern, text: str, rng: random.Random, new: str) -> str:
    spans = [m.span() for m in pattern.finditer(text)]
    if not spans:
        return text
    a, b = rng.choice(spans)
    return text[:a] + new + text[b:]


def _write(tmp_path: Path, k: int, data: str | bytes) -> Path:
    path = tmp_path / f"m{k}.toml"
    path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return path


def test_physical_parameters(tmp_path):
    rng = random.Random(SEED)
    for k in range(60):
        name = rng.choice(PLANAR)
        text = SCENARIOS[name]
        # mutate a number of the [model] section only (masses, lengths, mounts, ...)
        head, sep, rest = text.partition("[task]")
        head = _replace_nth(NUMBER, head, rng, rng.choice(BAD_NUMBERS))
        if rng.random() < 0.3:  # a second one
            head = _replace_nth(NUMBER, head, rng, rng.choice(BAD_NUMBERS))
        _load(_write(tmp_path, k, head + sep + rest), f"{name} #{k}")


def test_many_links_are_refused_or_loaded(tmp_path):
    link = "{ mass = 1.0, length = 0.5 }"
    for links in (24, 25, 200):
        text = SCENARIOS["rods_three_link.toml"]
        text = re.sub(r"links = \[[^\]]*\]", f"links = [{', '.join([link] * links)}]", text)
        _load(_write(tmp_path, links, text), f"{links} links")


def test_custom_expressions(tmp_path):
    rng = random.Random(SEED + 1)
    for k in range(60):
        name = rng.choice(CUSTOM)
        text = SCENARIOS[name]
        head, sep, rest = text.partition("[task]")
        bad = rng.choice(BAD_EXPRESSIONS).replace("\\", "\\\\").replace('"', '\\"')
        if rng.random() < 0.6:  # an expression of the vector fields
            before, mark, fields = head.partition("[model.fields]")
            fields, nxt, after = fields.partition("[[")
            fields = _replace_nth(STRING, fields, rng, f'"{bad}"')
            head = before + mark + fields + nxt + after
        else:  # an angle of the task
            rest = _replace_nth(NUMBER, rest, rng, f'"{bad}"')
        _load(_write(tmp_path, k, head + sep + rest), f"{name} #{k}: {bad[:40]}")


def test_a_field_infinite_or_complex_with_its_parameters_is_bad_input(tmp_path):
    """`tan(theta)/L` with L = 0 (sympy's ComplexInfinity) and `sqrt(-1)*x` loaded, then
    `check`, `models` and `plan` ended on a traceback and exit 1 (a leg that did not
    converge); a stratum's own parameters are said where they are the cause."""
    unicycle = SCENARIOS["unicycle.toml"]
    zero = unicycle.replace('inputs = ["v", "w"]', 'inputs = ["v", "w"]\nparameters = { L = 0 }')
    zero = zero.replace('"cos(theta)", "sin(theta)", 0]', '"cos(theta)", "sin(theta)", "1/L"]')
    cases = {
        zero: "model.fields.v[2]: in '1/L': infinite or undefined with L = 0",
        unicycle.replace('"sin(theta)"', '"sqrt(-1)*x"'): (
            "model.fields.v[1]: in 'sqrt(-1)*x': complex-valued (a field is real)"
        ),
        zero.replace("parameters = { L = 0 }", "parameters = { L = 1 }").replace(
            'active = ["v", "w"]', 'active = ["v", "w"]\nparameters = { L = 0 }'
        ): "in '1/L': infinite or undefined with L = 0 (stratum 'drive''s parameters)",
    }
    for k, (text, expected) in enumerate(cases.items()):
        with pytest.raises(InputError) as caught:
            parse_scenario(text)
        assert expected in str(caught.value)
        path = _write(tmp_path, k, text.encode())
        for command in (["check", str(path)], ["plan", str(path), "--out", str(tmp_path)]):
            result = CliRunner().invoke(app, command)
            assert result.exit_code == 2 and expected in result.output, result.output
    assert parse_scenario(zero.replace("L = 0", "L = 2")).system.n == 3


def test_custom_names_reserved_in_expressions_and_names_given_twice_are_refused():
    """A state named `lambda` failed every expression as "invalid syntax", one named `pi`
    hid the constant, and `active = ["v", "w", "w"]` was taken."""
    unicycle = SCENARIOS["unicycle.toml"]
    cases = {
        unicycle.replace('"x", "y", "theta"]', '"x", "pi", "theta"]'): (
            "model.states: pi: reserved in expressions (Python words, pi, E and the functions)"
        ),
        unicycle.replace('"x", "y", "theta"]', '"x", "lambda", "theta"]'): "model.states: lambda",
        unicycle.replace('active = ["v", "w"]', 'active = ["v", "w", "w"]'): (
            "model.strata[0].active: names twice: w"
        ),
    }
    for text, expected in cases.items():
        with pytest.raises(InputError, match=re.escape(expected)):
            parse_scenario(text)


def test_a_field_entry_or_a_lock_set_of_another_type_is_refused_not_read_as_a_number():
    """`true` in a field was read as 1.0 and `strata = [["1"]]` as joint 1 (the README:
    types are strict); a list in a field was refused twice (`.str: ...`, `.float: ...`)."""
    unicycle = SCENARIOS["unicycle.toml"]
    for entry, shown in (("true", "true"), ("[1]", "[1]")):
        with pytest.raises(InputError) as caught:
            parse_scenario(unicycle.replace("w = [0, 0, 1]", f"w = [0, 0, {entry}]"))
        assert [f"{p.path}: {p.message}" for p in caught.value.problems] == [
            f"model.fields.w[2]: must be an expression (a string) or a number (got {shown})"
        ]
    rods = SCENARIOS["rods_three_link.toml"]
    quoted = rods.replace('kind = "planar-manipulator"', 'kind = "planar-manipulator"\nstrata '
                          '= [["1"], [2]]')  # fmt: skip
    with pytest.raises(InputError, match=r"model\.strata\[0\]\[0\]: must be a valid integer"):
        parse_scenario(quoted)


def test_bytes_size_and_nesting(tmp_path):
    rng = random.Random(SEED + 2)
    cases: list[tuple[str, bytes]] = []
    for k in range(30):
        name = rng.choice(list(SCENARIOS))
        data = bytearray(SCENARIOS[name].encode())
        op = k % 5
        if op == 0:
            data.insert(rng.randrange(len(data)), rng.choice([0xFF, 0xC3, 0x80, 0xFE]))
        elif op == 1:
            data.insert(rng.randrange(len(data)), 0)
        elif op == 2:
            del data[rng.randrange(len(data)) :]
        elif op == 3:
            data = bytearray(b"\xef\xbb\xbf") + data  # a byte-order mark
        else:
            i = rng.randrange(len(data))
            data[i] = rng.randrange(256)
        cases.append((f"{name} bytes #{k}", bytes(data)))
    deep = 100_000
    cases += [
        ("deep array", b"name = 'x'\na = " + b"[" * deep + b"]" * deep + b"\n"),
        ("deep table", b"name = 'x'\na = " + b"{b = " * deep + b"1" + b"}" * deep + b"\n"),
        ("deep unclosed", b"a = " + b"[" * deep),
        ("2 MB", b"# " + b"x" * 2_000_000 + b"\n"),
        ("utf-16", SCENARIOS["unicycle.toml"].encode("utf-16")),
        ("empty", b""),
    ]
    for k, (what, data) in enumerate(cases):
        _load(_write(tmp_path, k, data), what)
    _load(Path("/dev/zero"), "/dev/zero")
    _load(tmp_path, "a directory")
    _load(tmp_path / "missing.toml", "a missing file")


def test_a_nan_is_reported_with_every_other_problem_but_none_of_its_stand_ins():
    """A nan hid every other problem (a misspelt key, a via of the wrong length); the other
    problems are found with the nan replaced by 1.0 and by 2.0, and only those found both
    times are reported (a via on S1 "locked at 1" would be the stand-in's own)."""
    text = SCENARIOS["sim4_task_d.toml"]
    broken = text.replace("[planner]", "[planner]\ntolerence = 1e-3").replace(
        'start = [0, "pi/4", 0, 0]', 'start = [nan, "pi/4", inf, 0]'
    )
    broken = broken.replace('goal = ["-pi/3", "pi/3", 0, "-pi/12"]', "goal = [0, 0, 0]")
    assert "nan" in broken and "tolerence" in broken and "goal = [0, 0, 0]" in broken
    with pytest.raises(InputError) as caught:
        parse_scenario(broken)
    lines = [f"{p.path}: {p.message}" for p in caught.value.problems]
    assert lines[:2] == [
        "task.start[0]: must be a finite number (got nan)",
        "task.start[2]: must be a finite number (got inf)",
    ]
    assert [line.split(":")[0] for line in lines[2:]] == ["planner.tolerence", "legs[0].goal"]
    # S1 first locks q1 at the start's: "locked at 1 (2) on this stratum" is the stand-in's
    alone = text.replace('start = [0, "pi/4", 0, 0]', 'start = [nan, "pi/4", 0, 0]')
    alone = alone.replace('stratum = "S3"', 'stratum = "SX"').replace('"S1"', '"S3"')
    alone = alone.replace('"SX"', '"S1"')
    with pytest.raises(InputError) as caught:
        parse_scenario(alone.replace("nan", "1.0"))
    assert "legs[0].goal" in [p.path for p in caught.value.problems]  # (with 1.0 given)
    with pytest.raises(InputError) as caught:  # (leg 2 on S3 is wrong whatever q1 is)
        parse_scenario(alone)
    assert [p.path for p in caught.value.problems] == ["task.start[0]", "legs[1].goal"]


def test_invalid_toml_quotes_the_line_it_names():
    """ "Cannot overwrite a value (at line 4, column 17)" did not say which key was given
    twice."""
    with pytest.raises(InputError, match=r"not valid TOML: Cannot overwrite a value \(a key "
                       r"given twice\) \(at line 4, column 17: tolerance = 1e-4\)$"):  # fmt: skip
        parse_scenario('name = "x"\n[planner]\ntolerance = 1e-3\ntolerance = 1e-4\n')
    with pytest.raises(InputError, match=r"Cannot declare \('planner',\) twice \(at line 3, "
                       r"column 9: \[planner\]\)$"):  # fmt: skip
        parse_scenario('name = "x"\n[planner]\n[planner]\n')


def test_error_lines_name_the_problem(tmp_path):
    unicycle = SCENARIOS["unicycle.toml"]
    expected = {
        unicycle.replace("start = [0, 0, 0]", "start = [0, nan, 0]"): (
            "task.start[1]: must be a finite number (got nan)"
        ),
        unicycle.replace('"cos(theta)"', '"9**9**9**9"'): "exponent",
        unicycle.replace('"cos(theta)"', '"sin(1, 2)"'): "sin() takes 1 argument(s), got 2",
        unicycle.replace('"cos(theta)"', '"theta(1)"'): "'theta' is a value, not a function",
        "a = " + "[" * 1000 + "]" * 1000: "nested more than 64 levels",
    }
    for k, (text, needle) in enumerate(expected.items()):
        path = _write(tmp_path, k, text)
        with pytest.raises(InputError) as info:
            load_scenario(path)
        assert needle in str(info.value)
        assert str(info.value).startswith(str(path))
    with pytest.raises(InputError, match=r"not UTF-8 text: byte 0xff at offset 3"):
        load_scenario(_write(tmp_path, 99, b"a =\xff 1"))
    with pytest.raises(InputError, match="not a regular file"):
        load_scenario("/dev/zero")
    # a binary file: named so, not its bytes echoed to the terminal in TOML's message
    with pytest.raises(InputError, match=r": not a text file: a NUL byte at offset 0$"):
        load_scenario(_write(tmp_path, 98, b"\x00\x01\x02abc"))
    with pytest.raises(InputError, match=r"at line 1, column 5: a = \\x07b\)$"):
        load_scenario(_write(tmp_path, 97, b"a = \x07b"))  # a control character, escaped


def test_a_byte_order_mark_is_no_part_of_the_scenario(tmp_path):
    """Windows editors start UTF-8 files with one: 'Invalid statement (at line 1, column 1:
    name = ...)' showed the line, its first character invisible."""
    text = (ROOT / "scenarios" / "sim4_task_d.toml").read_text()
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert load_scenario(path).text == text


@pytest.mark.parametrize(
    "mutation",
    [
        pytest.param(lambda t: t.replace('name = "unicycle"', f'name = "{"n" * 300}"'), id="name"),
        pytest.param(lambda t: t.replace('"cos(theta)"', '"9**9**9**9"'), id="exponent"),
        pytest.param(lambda t: t.encode().replace(b"\n", b"\xff\n", 1), id="bytes"),
        pytest.param(lambda t: t + "\nx = " + "[" * 100_000, id="deep"),
        pytest.param(lambda t: t.replace("goal = [0, 1, 0]", "goal = [0, inf, 0]"), id="inf"),
    ],
)
def test_cli_never_shows_a_traceback(tmp_path, mutation):
    text = mutation(SCENARIOS["unicycle.toml"])
    path = tmp_path / "s.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    args = ["plan", str(path), "--no-animation", "--no-check", "--out", str(tmp_path / "runs")]
    result = CliRunner().invoke(app, args)
    output = result.output + (result.stderr if result.stderr_bytes is not None else "")
    assert result.exit_code in (0, 1, 2, 3), output
    assert "Traceback" not in output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        pytest.fail(f"{type(result.exception).__name__}: {result.exception}")


def test_huge_configurations_load_cleanly(tmp_path):
    rng = random.Random(SEED + 3)
    for k in range(20):
        name = rng.choice(list(SCENARIOS))
        head, sep, rest = SCENARIOS[name].partition("[task]")
        rest = _replace_nth(NUMBER, rest, rng, rng.choice(["1e38", "-1e300", "1e308"]))
        _load(_write(tmp_path, k, head + sep + rest), f"{name} #{k}")


@pytest.mark.parametrize(
    "model, words",
    [
        (
            {"name": "two-arm"},
            "model.kind: is missing (one of: preset, custom, planar-manipulator, urdf)",
        ),
        ({"kind": "presett", "name": "two-arm"}, "model.kind: is 'presett', not a kind (one of:"),
    ],
)
def test_a_model_without_a_valid_kind_names_the_kinds(model, words):
    """Not pydantic's "Unable to extract tag using discriminator": the field and its values."""
    task = {"start": [0] * 5, "goal": [0] * 5}
    with pytest.raises(InputError) as info:
        load_scenario({"name": "x", "model": model, "task": task})
    assert words in str(info.value) and "discriminator" not in str(info.value)


def test_a_task_is_a_value_changed_only_through_its_scenario(tmp_path):
    """Assigning to a task fails; `dataclasses.replace` may not let its settings disagree
    with its scenario (the record would say otherwise); `with_changes` re-validates, and a
    record of the changed task re-plans to the same energy."""
    import dataclasses
    import json

    import stratcli

    task = stratcli.load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    with pytest.raises(dataclasses.FrozenInstanceError):
        task.goal = task.goal * 0  # type: ignore[misc]
    newton = dataclasses.replace(task.settings, objective="newton")
    with pytest.raises(ValueError, match="with_changes"):
        dataclasses.replace(task, settings=newton)
    changed = task.with_changes({"planner": {"objective": "newton"}})
    assert changed.settings == newton and task.settings.objective == "energy"
    plan = stratcli.plan(changed)
    run = stratcli.write_record(tmp_path, plan)
    again = stratcli.plan(json.loads((run / "resolved.json").read_text()))
    assert again.total_energy == pytest.approx(plan.total_energy, rel=1e-12)
    assert plan.total_energy > 1.5 * stratcli.plan(task).total_energy  # Newton's, not least
    with pytest.raises(InputError, match=r"\(with changes\): planner\.objectiv: unknown key"):
        task.with_changes({"planner": {"objectiv": "newton"}})
    with pytest.raises(ValueError, match="with_changes"):
        dataclasses.replace(task, legs=task.legs[:1])  # would record two legs, plan one
    obstacles = stratcli.load_scenario(ROOT / "scenarios" / "sim4_task_d_obstacles.toml")
    with pytest.raises(ValueError, match="with_changes"):
        dataclasses.replace(obstacles, constraints=None)
    tighter = dataclasses.replace(obstacles.constraints, clearance=0.2)  # planned, not recorded
    with pytest.raises(ValueError, match="with_changes"):
        dataclasses.replace(obstacles, constraints=tighter)
    assert dataclasses.replace(obstacles, source="renamed").constraints == obstacles.constraints
    goal = [*task.scenario.task.goal[:3], -0.2]  # θ only: the last leg (S1) moves it
    assert task.with_changes({"task": {"goal": goal}}).legs[-1].goal[3] == -0.2
    auto = task.with_changes({"legs": None, "decompose": {"max_length": 2}})
    assert auto.legs == () and auto.scenario.decompose is not None


def test_resolved_json_of_free_goal_entries_loads_back_as_the_same_task():
    """resolved.json writes a goal entry "*" as null; loading it must give the same task
    (it was refused: `task.goal[3]: expected a number ... (got None)`), so that
    `stratcli.plan(json.load(open("resolved.json")))` re-plans such a record."""
    import json

    import numpy as np

    from stratcli.records.run import resolved_scenario

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml").with_changes(
        {
            "task": {"goal": ["-pi/3", "pi/3", "pi/4", "*"]},
            "legs": [{"stratum": "S3", "goal": ["-pi/3", "pi/3", 0, "*"]}, {"stratum": "S1"}],
        }
    )
    resolved = json.loads(json.dumps(resolved_scenario(task)))
    assert resolved["task"]["goal"][3] is None
    again = load_scenario(resolved)
    assert again == task and np.isnan(again.goal[3]) and np.isnan(again.legs[0].goal[3])


def test_a_tasks_configurations_cannot_be_changed_in_place():
    """`t.goal[0] = ...` would plan a goal that resolved.json does not record."""
    import copy
    import pickle

    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    for t in (task, pickle.loads(pickle.dumps(task)), copy.deepcopy(task)):
        for array in (t.start, t.goal, *(leg.goal for leg in t.legs)):
            with pytest.raises(ValueError, match="read-only"):
                array[0] = 1.0


def test_with_changes_takes_numpy_values_as_load_scenario_does():
    """A dict of changes may hold numpy numbers, as a dict scenario may (`tomlread.plain`);
    a change that is no mapping is a one-line TypeError naming the argument."""
    import numpy as np

    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    changed = task.with_changes({"planner": {"max_iterations": np.int64(50)}})
    assert changed.settings.max_iterations == 50
    assert "max_iterations = 50\n" in changed.text
    with pytest.raises(TypeError, match=r"^changes: must be a mapping \(a dict\) \(got \["):
        task.with_changes([("planner", {})])


def test_with_changes_takes_dotted_keys_as_a_sweep_does():
    """`{"planner.tolerance": 1e-4}` (a sweep's key) was an unknown top-level key; a sweep's
    coordinate and index keys work too (`scenario_keys.assign`, the sweeps' own)."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    nested = task.with_changes({"planner": {"tolerance": 1e-4, "basis": {"harmonics": 5}}})
    dotted = task.with_changes({"planner.tolerance": 1e-4, "planner.basis.harmonics": 5})
    assert dotted == nested and dotted.text == nested.text
    assert task.with_changes({"planner": {"seed": 3}, "planner.tolerance": 1e-4}).settings.seed == 3
    assert task.with_changes({"planner.continuity": "l-C0"}).settings.continuity == "l-C0"
    goal = task.with_changes({"goal.theta": 0.1}).goal
    assert goal[3] == 0.1 and goal[:3].tolist() == task.goal[:3].tolist()
    via = task.with_changes({"legs[0].goal.theta": -0.3}).legs[0].goal
    assert via[3] == -0.3 and via[:3].tolist() == task.legs[0].goal[:3].tolist()
    assert dotted.with_changes({"planner.tolerance": None}).settings.tolerance == 1e-3  # removed
    obstacles = load_scenario(ROOT / "scenarios" / "sim4_task_d_obstacles.toml")
    moved = obstacles.with_changes({"constraints.obstacles[0].centre[0]": 1.0})
    assert moved.constraints.circles[0][0].tolist() == [1.0, 1.3]
    for changes, why in [
        ({"planner.tolerance": -1}, r"planner\.tolerance: must be at least"),
        ({".x": 1}, r"\.x: not a dotted name such as"),
        ({"goal.q9": 1}, r"goal\.q9: unknown coordinate 'q9' \(this model has: q1, q2, q3, "
                         r"theta\)"),
        ({"legs[5].goal": [0, 0, 0, 0]}, r"legs\[5\]\.goal: the scenario has no legs\[5\]"),
        ({"planner.tolerance": 1e-4, "planner": {"tolerance": 1e-5}},
         r"planner\.tolerance: given twice, as this key and in a nested table"),
        ({"task": {"goal": [0, 0, 0, 0]}, "goal.q1": 1}, r"goal\.q1: given twice"),
        ({"goal.q1": None}, r"goal\.q1: None removes a table's key; \"\*\" leaves a "
                            r"coordinate free"),
        ({"legs[1].goal.q1": 1}, r"legs\[1\]\.goal\.q1: the scenario has no legs\[1\]\.goal "
                                 r"\(the last leg's goal is task\.goal\)"),
    ]:  # fmt: skip
        with pytest.raises(InputError, match=r"\(with changes\): " + why):
            task.with_changes(changes)


def test_with_changes_names_coordinates_of_the_model_it_changes_to():
    """`{"model.name": "two-arm", ..., "goal.q4": -0.9}` from a one-arm task was refused as
    "unknown coordinate 'q4' (this model has: q1, q2, q3, theta)": coordinate names were
    checked against the model before the change."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    two_arm = {
        "model.name": "two-arm",
        "task.start": [0, 1.0, 0, 1.0, 0],
        "task.goal": [0, -1.0, 0, -1.0, 0],
        "legs": [{"stratum": "S3", "goal": [0, -1.0, 0, -0.5, 0]}, {"stratum": "S2"}],
        "goal.q4": -0.9,
    }
    changed = task.with_changes(two_arm)
    assert list(changed.system.states) == ["q1", "q2", "q3", "q4", "theta"]
    assert changed.goal.tolist() == [0, -1.0, 0, -0.9, 0]
    nested = {**two_arm, "model": {"name": "two-arm"}}
    del nested["model.name"]
    assert task.with_changes(nested) == changed
    back = load_scenario(ROOT / "scenarios" / "sim2.toml")
    with pytest.raises(InputError, match=r"goal\.q4: unknown coordinate 'q4' \(this model "
                       r"has: q1, q2, q3, theta\)"):  # fmt: skip
        back.with_changes({"model.name": "one-arm", "goal.q4": 0.1})


def test_changing_the_task_drops_the_papers_reference_energy():
    """A changed goal still printed "(paper: 124.59, ratio 0.90)": the paper's energy is for
    its own task (a sweep drops it alike); a change of the planner keeps it."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    assert task.scenario.reference.energy == 124.59
    assert task.with_changes({"planner.tolerance": 1e-4}).scenario.reference.energy == 124.59
    for changes in ({"goal.theta": 0.1}, {"task": {"goal": ["-pi/3", "pi/3", 0.7, -0.3]}}):
        assert task.with_changes(changes).scenario.reference is None
    given = task.with_changes({"goal.theta": 0.1, "reference": {"energy": 99.0}})
    assert given.scenario.reference.energy == 99.0


def test_no_legs_says_how_to_ask_for_auto_mode():
    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    with pytest.raises(InputError, match=r"legs: must have at least 1 entry, not 0: for auto "
                       r"mode to choose the legs, give a \[decompose\] table instead"):  # fmt: skip
        task.with_changes({"legs": []})
    assert task.with_changes({"legs": None, "decompose": {}}).legs == ()  # as the hint says


def test_a_key_that_looks_like_an_index_is_an_unknown_key_not_a_crash():
    """A quoted key "legs[0]" (a sweep's way of writing it) raised IndexError while its
    problem was described: pydantic's location filter took it for a union member's tag."""
    with pytest.raises(InputError) as caught:
        load_scenario('name = "x"\n"legs[0]" = 1\n')
    assert "<text 'x'>: legs[0]: unknown key (allowed: name, " in str(caught.value)
    task = load_scenario(ROOT / "scenarios" / "sim4_task_a.toml")
    with pytest.raises(InputError, match=r"planner\.a\(b: unknown key"):
        task.with_changes({"planner": {"a(b": 1}})


def test_a_checked_task_still_pickles_for_worker_processes():
    """The check caches the Lie brackets' generated code on the system, which does not
    pickle: a task sent to a spawned worker or Dask after `stratcli.plan` failed."""
    import pickle

    import stratcli

    task = load_scenario(ROOT / "scenarios" / "sim3_hybrid.toml")
    assert stratcli.check_controllability(task, samples=0).controllable
    assert "_lie_cache" in task.system.__dict__
    again = pickle.loads(pickle.dumps(task))
    assert stratcli.check_controllability(again, samples=0).controllable


def test_tasks_compare_and_hash_by_their_scenario():
    """A task is a value: loaded twice, from its file or its text, unpickled or with changes
    that change nothing, it equals itself and hashes alike (a dict key, a set member); a
    changed scenario is another task. (Equality raised ValueError on the arrays and hash()
    raised TypeError on the pydantic Scenario.)"""
    import dataclasses
    import pickle

    path = ROOT / "scenarios" / "sim4_task_a.toml"
    task = load_scenario(path)
    same = [
        load_scenario(path),
        parse_scenario(path.read_text(), "text"),
        pickle.loads(pickle.dumps(task)),
        task.with_changes({}),
        dataclasses.replace(task, source="renamed"),
    ]
    for other in same:
        assert other is not task and other == task and not other != task
        assert hash(other) == hash(task)
    assert len({task, *same}) == 1 and {task: 1}[same[0]] == 1
    newton = task.with_changes({"planner": {"objective": "newton"}})
    moved = task.with_changes({"task": {"goal": [-0.5, "pi/3", "pi/4", "-pi/12"]}})
    assert newton != task and moved != task and newton != moved
    assert len({task, newton, moved}) == 3
    assert task != path.read_text() and task != 0  # other types: unequal, no error
    assert load_scenario(task) is task  # (a TypeError, where plan and the others take one)


def test_a_tasks_legs_cannot_be_changed_in_place():
    """`task.legs` was a list: `task.legs.reverse()` planned the reversed legs while the
    task's scenario, which the record writes, still said the given order."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    assert isinstance(task.legs, tuple) and [leg.stratum for leg in task.legs] == ["S3", "S1"]
    with pytest.raises(AttributeError):
        task.legs.reverse()
    import pickle

    again = pickle.loads(pickle.dumps(task))
    assert isinstance(again.legs, tuple) and again == task


def test_a_shared_model_cannot_be_renamed_or_given_another_robot():
    """`preset(name)` is one object for every task of that model: `task.system.name = ...`
    renamed it in every plan after (and `robot = ...` changed their physics and collision
    geometry). Its fields are set once; a copy or an unpickled model is guarded alike."""
    import copy
    import pickle

    import stratcli

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    assert task.system is stratcli.preset("one-arm")
    for system in (task.system, pickle.loads(pickle.dumps(task.system)), copy.copy(task.system)):
        for name, value in (("name", "renamed"), ("robot", None), ("states", ())):
            with pytest.raises(AttributeError, match=rf"\.{name} is read-only .*shared"):
                setattr(system, name, value)
    assert stratcli.preset("one-arm").name == "one-arm"
    assert load_scenario(ROOT / "scenarios" / "sim4_task_d.toml") == task


def test_a_shared_model_cannot_be_changed_in_place():
    """Its strata, parameters and symbolic fields were a dict and a sympy Matrix:
    `preset("one-arm").strata["S1"] = None` made every later load of the model in the
    process die in an AttributeError, and `fields[3, 0] = 0` was taken while plans kept the
    first physics. They are read-only now, in copies and unpickled models too, which still
    equal the model (its compiled functions are no part of its value)."""
    import copy
    import pickle

    import stratcli

    custom = load_scenario(ROOT / "scenarios" / "unicycle.toml").system
    for system in (stratcli.preset("one-arm"), custom):
        for model in (system, pickle.loads(pickle.dumps(system)), copy.copy(system)):
            assert model == system
            with pytest.raises(TypeError):
                model.strata["S1"] = None
            with pytest.raises(TypeError):
                model.parameters["k"] = 1.0
            with pytest.raises(TypeError):
                model.fields[0, 0] = 0
            with pytest.raises(AttributeError, match=r"\.fields is read-only"):
                model.fields = model.fields
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    assert set(task.system.strata) == {"S1", "S2", "S3"}
    import dataclasses

    assert dataclasses.asdict(task)["system"]["name"] == "one-arm"  # (a mapping proxy: no)


def test_a_urdf_model_equals_itself_its_pickle_and_another_load_of_its_file():
    """Its `==` read the symbolic fields a URDF model has not, and raised: it equalled
    nothing, itself included."""
    import pickle

    path = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    system = load_scenario(path).system
    assert system == system and pickle.loads(pickle.dumps(system)) == system
    assert load_scenario(path).system == system and load_scenario(path) == load_scenario(path)
    other = load_scenario(ROOT / "scenarios" / "spatial" / "arm7_three_legs.toml").system
    assert other != system


def test_a_field_with_abs_plans_without_a_traceback(tmp_path):
    """`abs(x)` is an allowed function, but its derivative's derivative is a Dirac delta,
    which numpy has no name for: every command ended in a 117-line NameError. The delta is
    0 away from the kink; this Heisenberg-like system (the bracket's z is 2 + 0.5 sign(x),
    never 0) plans onto its goal."""
    import stratcli

    raw = {
        "name": "abs",
        "model": {
            "kind": "custom",
            "states": ["x", "y", "z"],
            "inputs": ["u1", "u2"],
            "fields": {"u1": [1, 0, "-y"], "u2": [0, 1, "x + 0.5*abs(x)"]},
            "strata": [{"name": "both", "active": ["u1", "u2"]}],
        },
        "task": {"start": [0.2, 0, 0], "goal": [0.2, 0, 0.5]},
        "planner": {"objective": "newton"},
        "legs": [{"stratum": "both"}],
    }
    plan = stratcli.plan(raw)
    assert plan.ok, plan.message
    import json

    (tmp_path / "abs.json").write_text(json.dumps(raw))
    result = CliRunner().invoke(app, ["check", str(tmp_path / "abs.json")])
    assert result.exit_code == 0 and "Traceback" not in result.output, result.output


def test_a_path_across_a_pole_of_the_fields_fails_instead_of_reaching_its_goal():
    """z' = u2 / (x - 0.5) with x from 0 to 1: the quadrature summed across the pole and the
    plan said ok (error 1e-13) while an ODE integration stops at x = 0.5. The leg is integrated
    again and fails numerically, saying why; with the ODE evaluator it failed already."""
    import stratcli
    from stratcli.status import Status

    raw = {
        "name": "pole",
        "model": {
            "kind": "custom",
            "states": ["x", "y", "z"],
            "inputs": ["u1", "u2"],
            "fields": {"u1": [1, 0, 0], "u2": [0, 1, "1/(x - 0.5)"]},
            "strata": [{"name": "s", "active": ["u1", "u2"]}],
        },
        "task": {"start": [0, 0, 0], "goal": [1, 1, 0.3]},
        "legs": [{"stratum": "s"}],
    }
    for objective in ("newton", "energy"):
        plan = stratcli.plan({**raw, "planner": {"objective": objective}})
        assert not plan.ok and plan.legs[0].status is Status.NUMERICAL_FAILURE
        assert "an ODE integration of its controls breaks down on the way" in plan.message
    clear = {**raw, "task": {"start": [2, 0, 0], "goal": [3, 1, 0.3]}}  # x far past the pole
    assert stratcli.plan(clear).ok
