"""The README's Python API example runs verbatim and does what it says."""

from __future__ import annotations

import os
import re
from pathlib import Path

import matplotlib

ROOT = Path(__file__).resolve().parents[1]


def _python_api_example() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Python API", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match, "README has no python example under 'Python API'"
    return match.group(1)


def test_python_api_example_runs_verbatim(tmp_path, capsys):
    matplotlib.use("Agg")
    code = _python_api_example()
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        namespace: dict = {}
        exec(compile(code, "README.md", "exec"), namespace)
    finally:
        os.chdir(cwd)
    plan = namespace["plan"]
    assert plan.ok and (tmp_path / "configuration.png").stat().st_size > 0
    runs = list((tmp_path / "runs").iterdir())
    assert len(runs) == 1 and (runs[0] / "result.json").is_file()
    t, q, u = namespace["t"], namespace["q"], namespace["u"]
    assert t.shape[0] == q.shape[0] == u.shape[0] and q.shape[1] == 4 and u.shape[1] == 3
    # the example's plan reaches the goal on the re-integrated trajectory
    goal = plan.legs[-1].goal
    assert abs(q[-1] - goal).max() <= plan.settings.tolerance
    sampled = plan.sample()  # indexes as it unpacks (`plan.sample()[1]` was a TypeError)
    assert sampled[1] is sampled.q and sampled[-1] is sampled.u
    assert "True" in capsys.readouterr().out


def test_own_leg_planner_example_runs_verbatim():
    """README "Your own leg planner": the class registers itself and plans the legs naming it,
    with the energy and the note the comment gives."""
    from stratcli.planners import PLANNERS

    section = (ROOT / "README.md").read_text(encoding="utf-8").split("**Your own leg planner.**")[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    cwd = os.getcwd()
    os.chdir(ROOT)  # it reads scenarios/sim4_task_d.toml
    try:
        namespace: dict = {}
        exec(compile(code, "README.md", "exec"), namespace)
    finally:
        os.chdir(cwd)
        PLANNERS.pop("patient", None)
    plan = namespace["plan"]
    assert plan.ok and [leg.method for leg in plan.legs] == ["patient", "patient"]
    assert f"{plan.total_energy:.2f}" == "256.12"
    assert "every leg uses method 'patient', not optimised jointly" in plan.notes[0]


def test_every_model_table_in_the_readme_loads_and_plans_as_written(tmp_path):
    """Each ```toml block of the README that is a planar manipulator's [model] table (no
    whole scenario) builds its model and plans a task of it: the example locked joint 3 of
    a 2-link arm and was refused (`model.strata[2]`) when copied as written."""
    import tomllib

    from pydantic import TypeAdapter

    import stratcli
    from stratcli.models.specs import build_system
    from stratcli.scenario import Scenario

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = [tomllib.loads(b) for b in re.findall(r"```toml\n(.*?)```", text, re.S)]
    models = [b for b in blocks if "model" in b and "task" not in b]
    kinds = {m["model"].get("kind") for m in models}
    assert "planar-manipulator" in kinds, kinds
    spec_of = TypeAdapter(Scenario.model_fields["model"].annotation)
    for tables in models:
        if tables["model"].get("kind") != "planar-manipulator":
            continue
        system = build_system(spec_of.validate_python(tables["model"]))
        goal = [0.2] * system.n
        task = stratcli.load_scenario(
            {"name": "readme", **tables, "task": {"start": [0] * system.n, "goal": goal},
             "decompose": {}}
        )  # fmt: skip
        assert stratcli.plan_auto(task, jobs=1).ok
