"""The constrained search (planners.constrained): plans inside joint limits and clear of
self-collision along every leg, checked on an independent dense re-integration; a task it
cannot plan fails with the limit and the leg named; Lie legs are refused with such limits."""

from __future__ import annotations

import io
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from reintegrate import controls, rhs_for, verify
from rich.console import Console
from scipy.integrate import solve_ivp
from typer.testing import CliRunner

from stratcli import load_scenario
from stratcli.api import plan_run
from stratcli.cli import app, render, render_plan
from stratcli.errors import InputError
from stratcli.models.geometry import world_geometry
from stratcli.planners.constrained import search_note

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
runner = CliRunner()


def _dense(task, doc, samples: int = 2000) -> np.ndarray:
    """Configurations at `samples` times a leg, integrated independently (solve_ivp)."""
    rhs, inputs = rhs_for(task, doc), doc["inputs"]
    q, out = np.array(doc["start"], dtype=float), []
    for leg in doc["legs"]:
        for piece in leg["pieces"]:
            t = np.linspace(0.0, piece["duration"], samples)
            sol = solve_ivp(
                lambda s, y, p=piece, st=leg["stratum"]: rhs(st, y, controls(p, inputs, s)),
                (0.0, piece["duration"]), q, method="DOP853", rtol=1e-11, atol=1e-12, t_eval=t,
            )  # fmt: skip
            assert sol.success
            out.append(sol.y.T)
            q = sol.y[:, -1]
    return np.concatenate(out)


def _segment_distance(p, a, b):
    d = b - a
    t = np.clip(np.einsum("...i,...i", p - a, d) / np.einsum("...i,...i", d, d), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * d), axis=-1)


def _crosses(a, b, c, d):
    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    d1, d2 = cross(b - a, c - a), cross(b - a, d - a)
    d3, d4 = cross(d - c, a - c), cross(d - c, b - c)
    return (d1 * d2 <= 0) & (d3 * d4 <= 0)


def _between(a, b, c, d):
    """Distance between segments (2-D: the closest points include an end), 0 if crossing."""
    ends = np.minimum.reduce(
        [_segment_distance(a, c, d), _segment_distance(b, c, d),
         _segment_distance(c, a, b), _segment_distance(d, a, b)]
    )  # fmt: skip
    return np.where(_crosses(a, b, c, d), 0.0, ends)


def _self_clearance(robot, q, radius):
    """Smallest surface distance between non-adjacent bodies (links as capsules, base as its
    rectangle), computed here from the link ends alone."""
    geo = world_geometry(robot, q)
    a, b, box = geo["proximal"], geo["distal"], geo["base_corners"]
    edges = [(box[:, i], box[:, (i + 1) % 4]) for i in range(4)]
    k, worst = a.shape[1], np.full(len(q), np.inf)
    for i in range(k):
        if i > 0:  # the first link is mounted on the base
            to_base = np.min([_between(a[:, i], b[:, i], c, d) for c, d in edges], axis=0)
            side = []
            for j in range(4):
                e, r = box[:, (j + 1) % 4] - box[:, j], a[:, i] - box[:, j]
                side.append(e[:, 0] * r[:, 1] - e[:, 1] * r[:, 0])
            inside = np.all(np.array(side) >= 0, axis=0) | np.all(np.array(side) <= 0, axis=0)
            worst = np.minimum(worst, np.where(inside, 0.0, to_base) - radius)
        for j in range(i + 2, k):
            worst = np.minimum(worst, _between(a[:, i], b[:, i], a[:, j], b[:, j]) - 2 * radius)
    return worst


def _inside(p, box):
    """Points p (N, 2) inside convex polygons box (N, 4, 2)."""
    side = []
    for j in range(4):
        e, r = box[:, (j + 1) % 4] - box[:, j], p - box[:, j]
        side.append(e[:, 0] * r[:, 1] - e[:, 1] * r[:, 0])
    side = np.array(side)
    return np.all(side >= 0, axis=0) | np.all(side <= 0, axis=0)


def _to_polygon(a, b, box):
    """Segments [a, b] to convex polygons (0 where they overlap), from edges and ends."""
    edges = [(box[:, i], box[:, (i + 1) % 4]) for i in range(4)]
    d = np.min([_between(a, b, c, e) for c, e in edges], axis=0)
    return np.where(_inside(a, box) | _inside(b, box), 0.0, d)


def _obstacle_clearance(robot, q, radius, circles, boxes):
    """Smallest distance from any body (capsule links, base rectangle) to the obstacles."""
    geo = world_geometry(robot, q)
    a, b, base = geo["proximal"], geo["distal"], geo["base_corners"]
    worst = np.full(len(q), np.inf)
    for centre, r in circles:
        c = np.broadcast_to(np.asarray(centre, float), (len(q), 2))
        edges = [_segment_distance(c, base[:, i], base[:, (i + 1) % 4]) for i in range(4)]
        worst = np.minimum(worst, np.where(_inside(c, base), 0.0, np.min(edges, axis=0)) - r)
        for i in range(a.shape[1]):
            worst = np.minimum(worst, _segment_distance(c, a[:, i], b[:, i]) - radius - r)
    for box in boxes:
        box = np.broadcast_to(box, (len(q), 4, 2))
        for i in range(a.shape[1]):
            worst = np.minimum(worst, _to_polygon(a[:, i], b[:, i], box) - radius)
        for i in range(4):
            worst = np.minimum(worst, _to_polygon(base[:, i], base[:, (i + 1) % 4], box))
    return worst


OBSTACLES = SCENARIOS / "sim4_task_d_obstacles.toml"


def _clearance_to_obstacles(task, doc) -> float:
    """The smallest distance of any body to the obstacle scenario's obstacles along `doc`'s
    plan, re-integrated independently (`_dense`)."""
    from stratcli.clearance import box_corners

    spec = tomllib.loads(OBSTACLES.read_text())["constraints"]
    circles = [(o["centre"], o["radius"]) for o in spec["obstacles"] if o["shape"] == "circle"]
    boxes = [
        box_corners(o["centre"], o["size"], o["rotation"])
        for o in spec["obstacles"]
        if o["shape"] == "box"
    ]
    q = _dense(task, doc)
    return float(_obstacle_clearance(task.system.robot, q, 0.05, circles, boxes).min())


@pytest.mark.slow
def test_the_obstacle_task_is_planned_clear_of_the_obstacles_that_the_free_plan_hits():
    task = load_scenario(OBSTACLES)
    clearance = task.constraints.clearance
    free_task = load_scenario(SCENARIOS / "sim4_task_d.toml")
    free = plan_run(free_task, check=False)
    assert _clearance_to_obstacles(task, free.document) < 0
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    verify(task, outcome.document)
    assert _clearance_to_obstacles(task, outcome.document) >= clearance - 1e-6
    assert not any("passes dipped" in note for note in outcome.result.notes)


def test_the_last_pass_keeps_a_plan_whose_contacts_kept_dipping_between_the_nodes(monkeypatch):
    """The obstacle task's search adds nodes five times (each lowering slides a contact to a
    dip between them); allowed three passes, the third keeps the plan phase 1 moved inside
    instead of lowering it once more and failing: a random task's start was dropped so."""
    from stratcli.planners import constrained

    monkeypatch.setattr(constrained, "REFINEMENTS", 2)
    task = load_scenario(OBSTACLES)
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    verify(task, outcome.document)
    assert _clearance_to_obstacles(task, outcome.document) >= task.constraints.clearance - 1e-6
    assert constrained.LAST_PASS.format(2) in outcome.result.notes
    shipped = 107.90  # (README) with all its passes, lowered each time: a little lower
    assert shipped < outcome.result.total_energy < 1.05 * shipped


def _raw(name: str, **planner) -> dict:
    raw = tomllib.loads((SCENARIOS / name).read_text())
    raw["planner"].update(planner)
    return raw


@pytest.mark.slow
@pytest.mark.parametrize("objective", ["energy", "newton"])
def test_a_shipped_plan_that_self_collides_is_planned_clear_with_the_constraints_on(objective):
    # unconstrained, Sim 4 task D folds a link through the base and swings q2 past 2.5 rad
    free_task = load_scenario(_raw("sim4_task_d.toml", objective=objective))
    free = plan_run(free_task, check=False)
    q_free = _dense(free_task, free.document)
    assert _self_clearance(free_task.system.robot, q_free, 0.05).min() < 0.05
    # with self-collision (clearance 0.05) and joint limits ±2.5 on
    task = load_scenario(_raw("sim4_task_d_constrained.toml", objective=objective))
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    doc = outcome.document
    verify(task, doc)  # goals, continuity and energies on an independent re-integration
    q = _dense(task, doc)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6
    clearance = _self_clearance(task.system.robot, q, 0.05)
    assert clearance.min() >= 0.05 - 1e-6
    # and result.json's margins agree with this independent check
    worst = min(m["self_clearance"] for m in doc["constraints"]["legs"])
    assert worst == pytest.approx(clearance.min() - 0.05, abs=1e-3)
    assert worst >= 0


@pytest.mark.parametrize("objective", ["energy", "newton"])
def test_limits_by_name_hold_the_base_angle_theta_too(objective):
    """`joint_limits = { theta = [...] }` bounds the base angle, not only joints (README)."""
    free_task = load_scenario(_raw("sim4_task_d.toml", objective=objective))
    free = _dense(free_task, plan_run(free_task, check=False).document)
    assert free[:, 3].min() < -2.5  # the free plan turns the base beyond the limit
    raw = _raw("sim4_task_d.toml", objective=objective)
    raw["constraints"] = {"joint_limits": {"theta": [-2.5, 2.5]}}
    task = load_scenario(raw)
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    verify(task, outcome.document)  # goals, continuity and energies re-integrated
    q = _dense(task, outcome.document)
    assert np.abs(q[:, 3]).max() <= 2.5 + 1e-6
    assert np.abs(q[:, :3]).max() > 2.5  # the joints are not limited: only theta is named


def test_a_via_left_free_keeps_the_re_chained_plan_inside_the_limits():
    """Task D's via with q2 and theta left free ("*"): the search started leg 2 at its
    nominal start, its plan moved leg 1's end in q2, and re-chaining re-planned leg 2 from
    there, 0.044 rad past q2's limit (status constraint_violated after the notes said
    "within the limits"); then it was searched again with the via held (250.29). Now q2 is
    held where the plan without the limits left it and theta chained (`stacked._held`,
    `_chained`): the plan is the search's, inside the limits, nothing re-planned."""
    raw = _raw("sim4_task_d.toml")
    raw["legs"][0]["goal"] = ["-pi/3", "*", 0, "*"]
    raw["constraints"] = {"joint_limits": [-2.5, 2.5]}
    task = load_scenario(raw)
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    assert not any("re-chained" in n for n in outcome.result.notes)
    assert all(leg.error < task.settings.tolerance for leg in outcome.result.legs)
    verify(task, outcome.document)  # goals, continuity, energies; leg 2 starts where leg 1 ends
    q = _dense(task, outcome.document)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6


def test_a_held_search_that_stops_says_so_where_it_was_silent(monkeypatch):
    """The search again with the vias held (`_rechained_within`): a numerical failure, or a
    plan that does not re-chain, is a message (the retry with more harmonics reads a stall),
    where the first search's "inside them" note was left standing; a plan inside already is
    kept as it is."""
    from stratcli import within_limits

    raw = _raw("sim4_task_d.toml")
    raw["legs"][0]["goal"] = ["-pi/3", "*", 0, "*"]
    raw["constraints"] = {"joint_limits": [-2.5, 2.5]}
    task = load_scenario(raw)
    final = plan_run(load_scenario(_raw("sim4_task_d.toml")), check=False).result
    args = (task.system, task.start, task.legs, task.settings, final, task.constraints)

    def failing(*a, **k):
        raise FloatingPointError

    monkeypatch.setattr(within_limits, "constrained_search", failing)
    plan, notes, iterations, message = within_limits._rechained_within(*args)
    assert plan is final and (notes, iterations) == ([], 0)
    assert message == "the constrained search stopped on a numerical failure (FloatingPointError)"
    assert message.startswith(within_limits.STALLED)
    from stratcli.planners.constrained import Searched

    inside = lambda *a, **k: Searched(None, ["inside the limits already"], "", float("nan"), 0)  # noqa: E731
    monkeypatch.setattr(within_limits, "constrained_search", inside)
    assert within_limits._rechained_within(*args) == (final, [], 0, "")


def test_legs_the_constrained_search_planned_report_its_iterations_not_zero():
    """The legs are re-chained from the search's coefficients (Newton polishes nothing): their
    iterations and starts are the search's, over all legs together, in result.json and the
    table, not the re-chain's 0."""
    raw = _raw("sim4_task_d.toml", objective="newton")
    raw["constraints"] = {"joint_limits": {"theta": [-2.5, 2.5]}}
    outcome = plan_run(load_scenario(raw), check=False)
    assert outcome.ok, outcome.result.message
    note = next(n for n in outcome.result.notes if n.startswith("constrained search from"))
    searched = int(re.search(r"\((\d+) iterations in all", note)[1])
    assert searched > 0
    for leg in outcome.document["legs"]:
        assert leg["strategy"] == "constrained"
        assert leg["iterations"] >= searched and leg["attempts"] >= 1
    console = Console(width=120, record=True, force_terminal=True, file=io.StringIO())
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(render, "out_console", console)
        render_plan.plan_summary(outcome.document)
    text = console.export_text()
    assert text.count(f" {searched}* ") == 2  # each leg: the search's, not 0
    assert "* the constrained search's iterations and starts, over all legs together" in text
    # the method column and the plots' leg labels say which search planned the legs (under
    # the energy objective, without these columns, it was the only sign)
    rows = [line for line in text.splitlines() if f" {searched}* " in line]
    assert all("newton (constrained)" in row for row in rows)
    from stratcli.records.figure_common import leg_method

    assert leg_method(outcome.result, 0).endswith(" · newton (constrained)")


@pytest.mark.slow
def test_a_task_the_search_cannot_plan_fails_naming_the_limit_and_the_leg(tmp_path):
    # task A within ±2.5 rad with the paper's 3 harmonics, set in the scenario (so kept: with
    # the default, 5 are tried and plan it): the S2 leg's loops do not fit
    raw = tomllib.loads((SCENARIOS / "sim4_task_a_constrained.toml").read_text())
    raw["planner"]["basis"] = {"harmonics": 3}
    from stratcli.tomlwrite import dumps

    path = tmp_path / "sim4_task_a_h3.toml"
    path.write_text(dumps(raw))
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "-q", "--no-animation"])
    assert result.exit_code == 1, result.output
    assert "stalled on leg 2" in result.output and "joint limits of q1" in result.output
    assert result.output.count("stalled on leg 2") == 1  # in the failure line, not a note too
    assert re.search(r"still violated by [0-9.e+-]+ rad at its nodes", result.output)  # a unit
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    doc = json.loads((run / "result.json").read_text())
    assert doc["status"] == "failed" and doc["constraints"]["violated"]
    violation = doc["constraints"]["violation"]  # the same, for scripts
    assert violation["limit"] in doc["constraints"]["legs"][violation["leg"] - 1]
    margin = doc["constraints"]["legs"][violation["leg"] - 1][violation["limit"]]
    assert violation["by"] > 0 and margin <= -violation["by"] + 1e-12
    assert f"violates {violation['what']} by" in doc["constraints"]["violated"]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["a", "b", "c"])
def test_each_shipped_constrained_sim4_task_keeps_its_limits_on_re_integration(name):
    task = load_scenario(SCENARIOS / f"sim4_task_{name}_constrained.toml")
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    verify(task, outcome.document)
    q = _dense(task, outcome.document)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6
    assert _self_clearance(task.system.robot, q, 0.05).min() >= 0.05 - 1e-6


def test_lie_legs_are_refused_with_joint_limits_and_collisions(tmp_path):
    raw = tomllib.loads((SCENARIOS / "sim3_hybrid.toml").read_text())
    raw["constraints"] = {"joint_limits": [-3.0, 3.0]}
    with pytest.raises(InputError) as info:
        load_scenario(raw)
    lie = [i for i, leg in enumerate(raw["legs"]) if leg.get("method") == "lie"]
    paths = [p.path for p in info.value.problems]
    assert paths == [f"legs[{i}].method" for i in lie]
    # rate limits alone are met by time scaling: Lie legs are fine with them
    raw["constraints"] = {"max_rate": 5.0}
    load_scenario(raw)
    from stratcli.tomlwrite import dumps

    path = tmp_path / "lie.toml"
    raw["constraints"] = {"self_collision": True}
    path.write_text(dumps(raw))
    result = runner.invoke(app, ["plan", str(path), "--out", str(tmp_path), "-q"])
    assert result.exit_code == 2 and "Lie leg" in result.output
    assert "Traceback" not in result.output


def test_spatial_legs_are_searched_within_the_urdfs_limits():
    """arm3_reorient leaves j1's ±3.14 rad of the URDF without constraints; with a table
    (the URDF's limits apply) its plan is searched inside them, the attitude still reached."""
    raw = tomllib.loads((SCENARIOS / "spatial" / "arm3_reorient.toml").read_text())
    raw["model"]["path"] = str((SCENARIOS / "spatial" / raw["model"]["path"]).resolve())
    raw["constraints"] = {"max_rate": 5.0}  # the URDF's joint limits apply
    outcome = plan_run(load_scenario(raw), check=False)
    assert outcome.ok, outcome.result.message
    assert not any("not searched for" in note for note in outcome.result.notes)
    assert all(m.joint_limit >= 0 for m in outcome.result.constraints.legs)


@pytest.mark.slow
def test_more_constrained_starts_keep_the_lowest_plan_inside_the_limits():
    """`constrained_starts = 2`: the search goes on past the first start that gets inside and
    keeps the lower of the two; on Sim 4 D a seeded Newton plan leads to a lower constrained
    minimum than the plan's own, re-checked inside the limits independently."""
    one = plan_run(load_scenario(_raw("sim4_task_d_constrained.toml")), check=False)
    raw = _raw("sim4_task_d_constrained.toml")
    raw["planner"]["constrained_starts"] = 2
    task = load_scenario(raw)
    two = plan_run(task, check=False)
    assert two.ok, two.result.message
    assert two.result.total_energy < 0.95 * one.result.total_energy
    assert any("lowest of 2 constrained starts" in note for note in two.result.notes)
    # the one start's plan costs 3.3x the free plan's: its notes say more starts may help
    hint = "with planner.constrained_starts = 2 the search goes on to a second start"
    assert any(hint in note for note in one.result.notes)
    assert not any(hint in note for note in two.result.notes)
    verify(task, two.document)
    q = _dense(task, two.document)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6
    assert _self_clearance(task.system.robot, q, 0.05).min() >= 0.05 - 1e-6


def test_limits_on_a_custom_models_integrated_coordinate_are_searched_for():
    """The unicycle's x is integrated (x' = v cos θ), not a closed-form joint: a limit on it
    is kept along the whole plan by the search (it was skipped as 'locked', and the plan
    then failed verification), re-checked on an independent dense re-integration."""
    raw = tomllib.loads((SCENARIOS / "unicycle.toml").read_text())
    free_task = load_scenario(raw)
    free = _dense(free_task, plan_run(free_task, check=False).document)
    assert np.abs(free[:, 0]).max() > 0.25  # the free plan swings x beyond the limit
    raw["constraints"] = {"joint_limits": {"x": [-0.2, 0.2]}}
    task = load_scenario(raw)
    outcome = plan_run(task, check=False)
    assert outcome.ok, outcome.result.message
    verify(task, outcome.document)
    q = _dense(task, outcome.document)
    assert np.abs(q[:, 0]).max() <= 0.2 + 1e-6


def test_the_search_note_says_lowered_only_when_the_energy_fell():
    """A search whose final plan cost more than its first plan inside the limits (nodes
    added between dips) said "energy 816.052, lowered to 1016.03" (a random obstacle task)."""
    down = search_note("minimum-energy", 288, 261, 816.052, 797.5, True)
    assert "energy 816.052 when first within the limits, lowered to 797.5 inside them" in down
    up = search_note("minimum-energy", 288, 261, 816.052, 1016.03, True)
    assert "lowered" not in up and "816.052 when first within the limits, raised to 1016.03" in up
    # the Newton objective: the final energy too where the nodes added moved the plan (a new
    # user read "energy 315.185 when within the limits" against the table's 329.01)
    newton = search_note("Newton", 288, 261, 816.052, 1016.03, False)
    assert "energy 816.052 when first within the limits, raised to 1016.03 by the nodes" in newton
    same = search_note("Newton", 288, 261, 816.052, 816.052, False)
    assert "energy 816.052 when within the limits (at the speed planned" in same


def _barrier_round(values, iterations=50):
    """`MarginSearch._lower_barrier` on a stub whose barrier steps all succeed with `values`;
    the steps it took."""
    from stratcli.planners import margin_search

    class Stub(margin_search.MarginSearch):
        def __init__(self):  # no problem: only the round's bookkeeping is exercised
            self.iterations, self.energy, self.taken, self.z = 0, 1.0, 0, None
            self.problem = type("P", (), {"energy": staticmethod(lambda z: 1.0)})

        def _barrier_step(self, mu):
            self.taken += 1
            self.barrier_value = values[self.taken - 1]  # (the accepted trial's)
            return True

    stub = Stub()
    stub._lower_barrier(iterations)
    return stub.taken


def test_a_barrier_round_ends_on_a_plateau_and_not_while_it_descends():
    """The round only leads the SQP into the basin: it ends once FLAT_STEPS steps together
    lowered the barrier by less than FLAT (relative), not on one small step."""
    from stratcli.planners.margin_search import FLAT, FLAT_STEPS

    descending = [100.0 * (1 - 1e-3) ** k for k in range(50)]
    assert _barrier_round(descending) == 50
    plateau = [100.0] * 3 + [100.0 * (1 - 0.5 * FLAT / FLAT_STEPS) ** k for k in range(47)]
    assert _barrier_round(plateau) == FLAT_STEPS + 1
    one_small = [100.0, 99.0, 98.99999, 97.0, *[96.0 - k for k in range(46)]]
    assert _barrier_round(one_small) == 50


COMBINED = """
name = "combined_limits"
[model]
kind = "preset"
name = "one-arm"
[task]
start = [0, "pi/4", 0, 0]
goal = ["-pi/3", "pi/3", "pi/4", "-pi/12"]
[planner]
continuity = "lr-C1"
soft_start = true
full_stop = true
[[legs]]
stratum = "S3"
goal = ["-pi/3", "pi/3", 0, "-pi/12"]
[[legs]]
stratum = "S1"
[constraints]
joint_limits = ["-150deg", "150deg"]
max_rate = 0.8
max_acceleration = 1.5
self_collision = true
clearance = 0.05
obstacles = [
  { shape = "circle", centre = [-0.3, 1.3], radius = 0.15 },
  { shape = "box", centre = [1.9, -0.1], size = [0.3, 0.6], rotation = "30deg" },
]
"""


@pytest.mark.slow  # three constrained searches of a two-leg plan: ~10 s
def test_a_search_that_stalls_in_the_default_basis_is_planned_with_more_harmonics():
    """A hardware engineer's realistic table (soft start and full stop, ±150°, self-collision,
    a circle and a rotated box, rate and acceleration limits) stalled on leg 1 with the
    default 3 harmonics; it is planned again with 5, inside every limit on an independent
    re-integration. A scenario that sets its harmonics keeps them and fails as before."""
    import math

    from stratcli.clearance import box_corners

    task = load_scenario(COMBINED)
    outcome = plan_run(task, check=False)
    plan, doc = outcome.result, outcome.document
    assert plan.ok, plan.message
    assert any(n.startswith("planned with 5 harmonics: the search within") for n in plan.notes)
    assert {p["basis"]["harmonics"] for leg in doc["legs"] for p in leg["pieces"]} == {5}
    verify(task, doc)  # goals, continuity and energies on an independent re-integration
    q = _dense(task, doc)
    assert np.abs(q[:, :3]).max() <= math.radians(150) + 1e-6
    assert _self_clearance(task.system.robot, q, 0.05).min() >= 0.05 - 1e-6
    circles = [((-0.3, 1.3), 0.15)]
    boxes = [box_corners((1.9, -0.1), (0.3, 0.6), math.radians(30))]
    clearance = _obstacle_clearance(task.system.robot, q, 0.05, circles, boxes)
    assert clearance.min() >= 0.05 - 1e-6
    for leg in doc["legs"]:  # the rates and accelerations as run, from the controls alone
        for piece in leg["pieces"]:
            t = np.linspace(0.0, piece["duration"], 2001)
            u = np.array([controls(piece, doc["inputs"], s) for s in t])
            du = np.array([controls(piece, doc["inputs"], s, derivative=True) for s in t])
            assert np.abs(u).max() <= 0.8 + 1e-6 and np.abs(du).max() <= 1.5 + 1e-6
    given = load_scenario(
        COMBINED.replace("full_stop = true", "full_stop = true\nbasis = { harmonics = 3 }")
    )
    kept = plan_run(given, check=False).result
    assert not kept.ok and kept.message.startswith("the constrained search stalled on leg 1")
    assert not any("harmonics" in n for n in kept.notes)
    # which bodies (it said "self-collision still violated", or "an obstacle" of several)
    assert re.match(
        r"the constrained search stalled on leg 1: (self-collision|an obstacle) \((link \d|the "
        r"base) and [^)]+\) still violated by [0-9.]+ at its nodes",
        kept.message,
    ), kept.message


LOOPS_IN_LIMITS = """
name = "loops_in_limits"
[model]
kind = "preset"
name = "one-arm"
[task]
start = [-0.7374, 1.1155, 0.4638, -0.1220]
goal = [-2.2594, 1.1155, -0.3359, -0.4436]
[planner]
continuity = "lr-C1"
tolerance = 1e-3
[[legs]]
stratum = "S2"
[constraints]
joint_limits = [-2.5, 2.5]
self_collision = true
clearance = 0.05
"""


@pytest.mark.slow  # three whole plans (3, 5 and 8 harmonics), each constrained: ~6 s
def test_a_search_that_stalls_with_5_harmonics_too_is_planned_with_8():
    """A random task's S2 leg (bench_random seed 595598246) must turn the base by 0.32 rad
    while q1 ends 0.24 rad from its limit: with 3 and with 5 harmonics the search stalls
    with a joint past ±2.5 rad; with 8 the loops fit inside. The plan says so and is inside
    its limits on an independent re-integration."""

    task = load_scenario(LOOPS_IN_LIMITS)
    outcome = plan_run(task, check=False)
    plan, doc = outcome.result, outcome.document
    assert plan.ok, plan.message
    assert any(
        n.startswith("planned with 8 harmonics: the search within the limits stalled with 3 (the ")
        and re.search(r"\(the default; on leg 1: the joint limits of q\d still violated by", n)
        and n.endswith(" and 5; planner.basis.harmonics = 8 asks for these from the start")
        for n in plan.notes
    )
    assert {p["basis"]["harmonics"] for leg in doc["legs"] for p in leg["pieces"]} == {8}
    verify(task, doc)
    q = _dense(task, doc)
    assert np.abs(q[:, :3]).max() <= 2.5 + 1e-6
    assert _self_clearance(task.system.robot, q, 0.05).min() >= 0.05 - 1e-6


def test_more_harmonics_are_tried_in_turn_and_the_notes_say_which(monkeypatch):
    """`with_more_harmonics` plans with 5, then 8 harmonics (each warm-started from the plan
    found without the limits, in the larger basis) and keeps the first that gets inside;
    where none does, the first plan comes back with a note naming the counts tried. Auto
    mode's first count only: 5. (The plans themselves are stubbed: only the order, the
    warm starts and the wording are under test.)"""
    import dataclasses

    from stratcli import objectives
    from stratcli.urdf_limits import violation_advice

    task = load_scenario(ROOT / "scenarios" / "sim4_task_d.toml")
    plan = plan_run(task, check=False).result
    stuck = dataclasses.replace(plan, message="the constrained search stalled on leg 1: ...")
    asked = []

    def planned(inside_with):
        def fake(system, start, legs, settings, warm, progress, constraints):
            n = settings.basis.harmonics
            asked.append(n)
            assert [w.size for w in warm] == [len(leg.active) * (2 * n + 1) for leg in plan.legs]
            return plan if n == inside_with else stuck

        return fake

    def more(**kw):
        return objectives.with_more_harmonics(
            task.system, task.start, task.legs, task.settings, stuck, None, said.append, **kw
        )

    said = []
    monkeypatch.setattr(objectives, "plan_sequence", planned(inside_with=None))
    out = more()
    assert asked == [5, 8]
    assert out.message == stuck.message + " (with 3 harmonics; it stalled with 5 and 8 too)"
    assert out.notes[-1] == "with 5 and 8 harmonics the plan did not get inside the limits either"
    advice = violation_advice(out, "leg 1 (S3) violates the joint limits of q1")
    assert "more than 8 harmonics (planner.basis.harmonics)" in advice  # not what it tried
    assert "more harmonics" not in advice
    assert said == [
        "constrained search: stalled; planning again with 5 harmonics",
        "constrained search: stalled with 5 too; planning again with 8 harmonics",
    ]
    asked.clear()
    out = more(more=objectives.MORE_HARMONICS[:1])
    assert asked == [5]
    assert out.message == stuck.message + " (with 3 harmonics; it stalled with 5 too)"
    assert out.notes[-1] == "with 5 harmonics the plan did not get inside the limits either"
    assert "more than 5 harmonics" in violation_advice(out, "")
    asked.clear()
    monkeypatch.setattr(objectives, "plan_sequence", planned(inside_with=5))
    out = more()
    assert asked == [5] and not out.message
    assert out.notes[-1] == (
        "planned with 5 harmonics: the search within the limits stalled with 3 (the default; "
        "on leg 1: ...); planner.basis.harmonics = 5 asks for these from the start"
    )
    dipping = "the constrained search kept dipping below a margin between its nodes"
    assert objectives.stalled(stuck) and objectives.stalled(
        dataclasses.replace(plan, message=dipping)
    )  # each search that did not get inside is retried
    assert not objectives.stalled(plan)
    assert "try via configurations" in violation_advice(stuck, "")  # not retried: as it was
    assert "more harmonics" in violation_advice(stuck, "")


# Random task 1853662621 of benchmarks/bench_random.py --constraints: its free minimum is a
# loop start's, whose loops the constrained search cannot bring inside ±2.5 rad.
LOOPED = {
    "name": "random_1853662621",
    "model": {"kind": "preset", "name": "one-arm"},
    "task": {
        "start": [
            -0.8389390171205248,
            0.8287341304145612,
            -0.27921182074360074,
            0.6159815589981124,
        ],
        "goal": [
            -0.15260295727241002,
            -0.24885225971392533,
            -2.4198293698901074,
            0.671392552721757,
        ],
    },
    "planner": {"continuity": "lr-C1", "tolerance": 0.001},
    "legs": [
        {"stratum": s, "goal": [x, -0.24885225971392533, -2.4198293698901074, 0.671392552721757]}
        for s, x in [
            ("S1", -0.8389390171205248),
            ("S2", -0.15260295727241002),
            ("S3", -0.15260295727241002),
            ("S2", -0.15260295727241002),
        ]
    ],
    "constraints": {"joint_limits": [-2.5, 2.5], "self_collision": True, "clearance": 0.05},
}


def test_where_the_free_minimum_is_a_loop_starts_the_search_also_starts_from_the_plain_one(
    monkeypatch,
):
    """The constrained search starts from the plan itself, and where its energy search kept a
    loop start, from the minimum of the search's own starts next, before seeded Newton
    plans. (Which start gets inside depends on the machine's rounding: on an Intel Xeon the
    plain minimum did with 3 harmonics; on an AMD EPYC every start stalled there and a
    seeded one got inside with 5, after 40 s. So the order of the starts is what is
    asserted, and the search is stopped once the second has been asked for; plans kept
    inside their limits are re-integrated independently by the tests above.)"""
    import stratcli.within_limits as within

    class Enough(Exception):
        """The two starts wanted were asked for."""

    tried = []  # the kind of each start's seed, as the search is asked

    def recording(system, start, legs, settings, targets, seeds, *args, **kwargs):
        tried.append([kind for kind, _ in seeds])
        if len(tried) == 2:
            raise Enough
        return searched(system, start, legs, settings, targets, seeds, *args, **kwargs)

    searched = within.constrained_search
    monkeypatch.setattr(within, "constrained_search", recording)
    free = load_scenario({k: v for k, v in LOOPED.items() if k != "constraints"})
    free_plan = plan_run(free, check=False).result
    assert free_plan.optimisation.starts[free_plan.optimisation.best].kind == "loop"
    with pytest.raises(Enough):
        plan_run(load_scenario(LOOPED), check=False)
    assert tried == [["minimum-energy"], ["minimum-energy (without loop starts)"]]


def test_a_plan_inside_its_limits_below_the_free_minimum_says_the_free_search_stopped_higher():
    """A URDF task's free energy search ended at 687.34 (a joint swung two turns); inside
    the limits the plan cost 58.88, a plan of the free problem too, and nothing said so."""
    from stratcli.settings import PlannerSettings
    from stratcli.within_limits import _below_free

    energy = PlannerSettings(objective="energy")
    (note,) = _below_free(energy, 687.34, 58.8837)
    assert note.startswith("inside the limits the plan costs less than the minimum found")
    assert "(58.88 against 687.34)" in note and "stopped in a higher minimum" in note
    assert _below_free(energy, 84.04, 280.92) == []  # the usual: the limits cost energy
    assert _below_free(energy, 84.04, 84.04) == []  # inside already
    assert _below_free(PlannerSettings(objective="newton"), 687.34, 58.88) == []  # no minimum
