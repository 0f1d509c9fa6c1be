"""Shared fixtures: shipped scenarios planned once per session, plans over planners ×
continuity modes, the record-output runs, and small helpers (paths, Newton objective)."""

from __future__ import annotations

from stratcli import blas  # (imports nothing heavy)

# BLAS single-threaded, as the stratplan command runs it, set before numpy loads: with two
# test workers (`-n auto`) each worker's OpenBLAS would start a thread per core
blas.single_threaded()

import dataclasses
import io
import itertools
import json
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from typer.testing import CliRunner

from stratcli.api import plan_auto, plan_run
from stratcli.api.sequences import with_legs
from stratcli.cli import app
from stratcli.models.presets import preset
from stratcli.objectives import plan_sequence
from stratcli.records.mcap_log import mcap_bytes
from stratcli.records.result import result_document
from stratcli.records.trajectory import sample
from stratcli.scenario import load_scenario
from stratcli.settings import PlannerSettings
from stratcli.stratified import LegSpec

sys.path.insert(0, str(Path(__file__).parent))

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.toml"))


def pytest_collection_modifyitems(config, items):
    """With parallel workers (`-n`, pytest-xdist) the tests marked slow go first: in file
    order the longest ones (test_screen, test_urdf_limits: minutes) came last, and one worker
    ran them alone while the other idled."""
    if getattr(config.option, "numprocesses", None):
        items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture
def scenarios_dir() -> Path:
    return ROOT / "scenarios"


# the best minimum CasADi/IPOPT found on the same Fourier problem (issue 15, item 1)
IPOPT_BEST = {"sim1_l_c1": 367.30, "sim4_task_a": 448.04}


def energy_plan(task, search: str):
    """`task` planned with the energy objective and the energy search `search`."""
    from stratcli.objectives import plan_sequence

    settings = dataclasses.replace(task.settings, objective="energy", search=search)
    return plan_sequence(task.system, task.start, task.legs, settings)


def newton_objective(settings):
    """The paper's Newton method (fast); a no-op before planner settings had an objective."""
    if "objective" in {f.name for f in dataclasses.fields(settings)}:
        return dataclasses.replace(settings, objective="newton")
    return settings


def plan_document(path, **changes):
    """Plan a scenario file with some planner settings changed: (task, result.json document).

    In auto mode the task gets the legs of the sequence chosen, so that `verify` can judge it.
    """
    task = load_scenario(path)
    if changes:
        task = task.with_changes({"planner": changes})
    if not task.legs:  # auto mode: re-integrate the sequence it chose
        outcome = plan_auto(task, check=False)
        task = with_legs(task, outcome.comparison.best.candidate.legs)
        return task, result_document(outcome.best.result, task.scenario.name, task.model_name)
    result = plan_sequence(task.system, task.start, task.legs, task.settings)
    return task, result_document(result, task.scenario.name, task.model_name)


# ------------------------------------------------------------------------------------------
# Shipped scenarios: planned once per test session
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="session")
def shipped_plans() -> dict[str, tuple[Any, Any]]:
    """Every `scenarios/*.toml`, planned once as `stratplan regress` plans it: stem → (task,
    PlanOutcome). Unchecked, at time scale 1; in auto mode the best candidate sequence, and
    the task is the scenario with that sequence's legs."""
    plans = {}
    for path in SCENARIOS:
        task = load_scenario(path)
        if task.legs:
            outcome = plan_run(task, check=False, time_scale=1.0)
        else:  # auto mode ([decompose], no [[legs]])
            outcome = plan_auto(task, check=False).best
        plans[path.stem] = (outcome.task, outcome)
    return plans


# ------------------------------------------------------------------------------------------
# Planners × continuity modes, on the one-arm preset
# ------------------------------------------------------------------------------------------

PLANNERS = ("newton", "lie")
CONTINUITY = ("none", "l-C0", "l-C1", "lr-C0", "lr-C1")


@pytest.fixture(
    scope="session",
    params=list(itertools.product(PLANNERS, CONTINUITY)),
    ids=[f"{p}-{c}" for p, c in itertools.product(PLANNERS, CONTINUITY)],
)
def small_plan(request) -> SimpleNamespace:
    """A small one-arm plan per planner × continuity mode, planned once per session.

    newton: S1 → S3 by Newton legs; lie: Newton → Lie → Newton (a Lie leg on S1 between
    them). Gives planner, continuity, legs, the plan, its result.json document and `task`
    (what `verify` needs of a scenario).
    """
    planner, continuity = request.param
    pi = np.pi
    start = np.array([0.0, pi / 4, 0.0, 0.0])
    via1 = np.array([0.0, pi / 3, 0.3, -0.05])
    via2 = via1 + np.array([0.0, 0.1, -0.05, 0.04])
    goal = np.array([-0.2, pi / 3 + 0.1, 0.25, np.nan])
    settings = PlannerSettings(continuity=continuity, objective="newton")
    if planner == "lie":
        legs = [
            LegSpec("S1", via1),
            LegSpec("S1", via2, method="lie", lie=settings.lie),
            LegSpec("S3", goal),
        ]
    else:
        legs = [LegSpec("S1", via2), LegSpec("S3", goal)]
    plan = plan_sequence(preset("one-arm"), start, legs, settings)
    doc = result_document(plan, f"{planner}-{continuity}", "one-arm")
    return SimpleNamespace(
        planner=planner,
        continuity=continuity,
        legs=legs,
        plan=plan,
        doc=doc,
        task=SimpleNamespace(legs=legs, text=""),
    )


# ------------------------------------------------------------------------------------------
# Shared plans of single scenarios
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sim4():
    """Sim 4's auto scenario, with the Newton objective."""
    task = load_scenario(ROOT / "scenarios" / "sim4_auto.toml")
    return task.with_changes({"planner": {"objective": "newton"}})


@pytest.fixture(scope="session")
def task_d():
    """Sim 4 task D planned with the Newton and with the energy objective."""
    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    newton = plan_sequence(
        task.system, task.start, task.legs, dataclasses.replace(task.settings, objective="newton")
    )
    energy = plan_sequence(task.system, task.start, task.legs, task.settings)
    return task, newton, energy


@pytest.fixture(scope="session")
def unicycle_plan():

    task = load_scenario(ROOT / "scenarios" / "unicycle.toml")
    return task, plan_sequence(task.system, task.start, task.legs, task.settings)


def chain_scenario(links: int) -> str:
    """A planar chain of `links` equal links on one arm, one leg on S1."""
    link = "{ mass = 1.0, length = 0.5 }"
    n = links + 1
    return f"""name = "chain"
[model]
kind = "planar-manipulator"
base = {{ mass = 10.0, a = 1.0, b = 0.6 }}
[[model.arms]]
mount = [0.3, 0.0]
links = [{", ".join([link] * links)}]
[task]
start = [{", ".join(["0"] * n)}]
goal = [{", ".join(["0"] + ["0.1"] * (n - 1))}]
[[legs]]
stratum = "S1"
"""


def weak_stratum_scenario(joints: str = '"*", "*"', theta: str = "10deg") -> str:
    """Issue 14's 4-link arm (base 20 kg, 1.2 x 0.8; links 3/2/1/0.5 kg, 0.9/0.7/0.5/0.3 m)
    turning its base by `theta` on S12: only the two small distal links move; `joints` are
    the goals of q3, q4."""
    return f"""name = "weak_stratum"
[model]
kind = "planar-manipulator"
base = {{ mass = 20.0, a = 1.2, b = 0.8 }}
[[model.arms]]
mount = [0.3, 0.0]
links = [
    {{ mass = 3.0, length = 0.9 }}, {{ mass = 2.0, length = 0.7 }},
    {{ mass = 1.0, length = 0.5 }}, {{ mass = 0.5, length = 0.3 }},
]
[task]
start = [0, 0, 0, 0, 0]
goal = [0, 0, {joints}, "{theta}"]
[[legs]]
stratum = "S12"
"""


# ------------------------------------------------------------------------------------------
# Record outputs (trajectory, MCAP log, plots) of three scenarios
# ------------------------------------------------------------------------------------------

STARTED = "2026-11-22T09:05:08.123456+00:00"
EPOCH = 1_795_338_308_123_456_000  # STARTED in ns since 1970


@dataclasses.dataclass
class Run:
    name: str
    task: object
    plan: object
    traj: object
    doc: dict
    manifest: dict
    data: bytes


def _run(name: str, evaluator: str | None = None) -> Run:
    task = load_scenario(ROOT / "scenarios" / f"{name}.toml")
    changes = {"evaluator": evaluator} if evaluator else {}
    if "objective" in {f.name for f in dataclasses.fields(task.settings)}:
        changes["objective"] = "newton"  # the paper's method: fast; these tests need any plan
    settings = dataclasses.replace(task.settings, **changes)
    if task.constraints is None:
        plan = plan_sequence(task.system, task.start, task.legs, settings)
    else:  # the search, the time scaling and the verification of [constraints]
        plan = plan_run(task, check=False).result
    assert plan.ok
    traj = sample(plan)
    doc = json.loads(json.dumps(result_document(plan, name, task.model_name)))  # as on disk
    manifest = {"schema": "stratplan.manifest/1", "started": STARTED, "seeds": {"planner": 0}}
    data = mcap_bytes(plan, traj, doc, manifest, task.text, name)
    return Run(name, task, plan, traj, doc, manifest, data)


@pytest.fixture(scope="session")
def one_arm() -> Run:
    """sim4_task_c: one-arm, 3 legs."""
    return _run("sim4_task_c")


@pytest.fixture(scope="session")
def two_arm() -> Run:
    """sim2_soft: two-arm, mirrored arms, soft start and full stop."""
    return _run("sim2_soft")


@pytest.fixture(scope="session")
def biped() -> Run:
    """The biped: a custom model without a robot drawing (automatic evaluator: fast)."""
    return _run("biped", evaluator="auto")


@pytest.fixture(scope="session")
def obstacles() -> Run:
    """sim4_task_d_obstacles: one-arm, 2 legs around two obstacles ([constraints]: /margins)."""
    return _run("sim4_task_d_obstacles")


@pytest.fixture(params=["one_arm", "two_arm", "biped", "obstacles"])
def any_run(request) -> Run:
    return request.getfixturevalue(request.param)


@pytest.fixture(params=["one_arm", "two_arm"])
def arm_run(request) -> Run:
    return request.getfixturevalue(request.param)


def mcap_messages(data: bytes, topic: str) -> list[tuple[int, dict]]:
    """(log time, decoded JSON) of every message on `topic` of an MCAP file in memory."""
    reader = make_reader(io.BytesIO(data))
    return [(m.log_time, json.loads(m.data)) for _, _, m in reader.iter_messages(topics=[topic])]


# A parallel-parking unicycle as a custom model (one stratum): cheap to plan and to check.
UNICYCLE = """
name = "uni"
[model]
kind = "custom"
states = ["x", "y", "theta"]
inputs = ["v", "w"]
[model.fields]
v = ["cos(theta)", "sin(theta)", 0]
w = [0, 0, 1]
[[model.strata]]
name = "drive"
active = ["v", "w"]
[task]
start = [0, 0, 0]
goal = [0, 0.1, 0]
[[legs]]
stratum = "drive"
"""


TASK_C = ROOT / "scenarios" / "sim4_task_c.toml"


def plan_record(tmp_path: Path, scenario: Path = TASK_C, *args: str) -> Path:
    """`stratplan plan SCENARIO --out tmp_path` (quiet, no GIF); the one record it wrote."""
    result = CliRunner().invoke(
        app, ["plan", str(scenario), "--out", str(tmp_path), "--quiet", "--no-animation", *args]
    )
    assert result.exit_code == 0, result.output
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    return run
