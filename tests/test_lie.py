"""Lie brackets, the P. Hall basis, iterated integrals, the Lie-algebraic planner and `check`."""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import cumulative_trapezoid
from typer.testing import CliRunner

from stratcli.api.check import check_document
from stratcli.cli import app
from stratcli.continuity import mode_order
from stratcli.controls import FourierBasis
from stratcli.endpoint import OdeEndpoint
from stratcli.liealgebra import element_degree, flow, hall_basis, iterated_integrals, lie_basis
from stratcli.models.connection import connection
from stratcli.models.presets import preset
from stratcli.records.result import result_document
from stratcli.scenario import load_scenario, parse_scenario
from stratcli.stratified import LegSpec, PlannerSettings, plan_sequence

runner = CliRunner()
PI = np.pi
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


# ---------------------------------------------------------------------------- P. Hall basis


@pytest.mark.parametrize(
    ("m", "degree", "size"), [(2, 1, 2), (2, 2, 3), (2, 3, 5), (3, 2, 6), (3, 3, 14)]
)
def test_hall_basis_sizes_follow_witt(m, degree, size):
    basis = hall_basis(m, degree)
    assert len(basis) == size
    assert len(set(basis)) == size
    assert [element_degree(h) for h in basis] == sorted(element_degree(h) for h in basis)


def test_hall_basis_of_two_generators():
    assert hall_basis(2, 3) == [0, 1, (0, 1), (0, (0, 1)), (1, (0, 1))]


# ---------------------------------------------------------------------------- brackets


def test_unicycle_bracket_by_hand():
    """[g_v, g_w] = (∂g_w/∂q) g_v − (∂g_v/∂q) g_w = −∂g_v/∂θ = (sin θ, −cos θ, 0)."""
    system = parse_scenario(UNICYCLE).system
    lb = lie_basis(system, "drive", 2)
    th = system.symbols[2]
    assert lb.labels == ["v", "w", "[v,w]"]
    expected = sp.Matrix([sp.sin(th), -sp.cos(th), 0])
    assert sp.simplify(lb.symbolic[:, 2] - expected) == sp.zeros(3, 1)
    q = np.array([[0.3, -1.0, 0.7], [1.0, 2.0, -2.5]])
    np.testing.assert_allclose(lb.evaluate(q)[:, :, 2], np.c_[np.sin(q[:, 2]), -np.cos(q[:, 2]),
                               np.zeros(2)], atol=1e-15)  # fmt: skip


@pytest.mark.parametrize("stratum", ["S1", "S2", "S3"])
def test_one_arm_bracket_is_the_curvature_of_the_connection(stratum):
    """On a one-arm stratum [g_i, g_j] = (∂A_j/∂q_i − ∂A_i/∂q_j) e_θ; here A and dA come from
    the physical derivation of the robot (models.connection), independent of eq. 6's sympy."""
    system = preset("one-arm")
    lb = lie_basis(system, stratum, 2)
    i, j = system.stratum(stratum).active
    q = np.random.default_rng(3).uniform(-PI, PI, (200, 4))
    _, dA = connection(system.robot, q[:, :3])
    B = lb.evaluate(q)  # free coordinates: the two joints and theta
    np.testing.assert_allclose(B[:, :2, 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(B[:, 2, 2], dA[:, j, i] - dA[:, i, j], rtol=1e-9, atol=1e-12)


def test_manipulator_closed_form_brackets_equal_the_symbolic_ones(scenarios_dir, monkeypatch):
    import stratcli.liealgebra as lie

    system = load_scenario(scenarios_dir / "rods_three_link.toml").system
    q = np.random.default_rng(4).uniform(-PI, PI, (50, 4))
    fast = lie_basis(system, "S2", 2)
    assert fast.symbolic is None  # the closed-form path of physical manipulators
    monkeypatch.setattr(lie, "_is_manipulator", lambda s: False)
    slow = lie._build(system, system.stratum("S2"), 2)  # sympy, from System.fields_on
    assert slow.symbolic is not None
    np.testing.assert_allclose(fast.evaluate(q), slow.evaluate(q), atol=1e-13)


# ---------------------------------------------------------------------------- iterated integrals


def test_iterated_integrals_match_brute_force_and_have_exact_jacobians():
    basis, T = FourierBasis(3, 2.17), 0.51
    h = iterated_integrals(basis, T, 2, 3)
    lam = np.random.default_rng(5).normal(size=2 * basis.size)
    L = lam.reshape(2, -1)
    t = np.linspace(0.0, T, 20001)
    u = basis.values(t) @ L.T
    U = cumulative_trapezoid(u, t, axis=0, initial=0.0)
    alpha = h(lam)
    np.testing.assert_allclose(alpha[:2], np.trapezoid(u, t, axis=0), rtol=1e-7)
    area = 0.5 * np.trapezoid(U[:, 0] * u[:, 1] - U[:, 1] * u[:, 0], t)
    assert alpha[2] == pytest.approx(area, rel=1e-6)
    J = h.jacobian(lam)
    E = np.eye(lam.size) * 1e-6
    numeric = np.array([(h(lam + e) - h(lam - e)) / 2e-6 for e in E]).T
    np.testing.assert_allclose(J, numeric, atol=1e-9)


def _prediction_errors(system, stratum, q0, degree, scales, flip_bracket=False):
    basis, T = FourierBasis(3, 2.17), 0.51
    lb = lie_basis(system, stratum, degree)
    h = iterated_integrals(basis, T, len(system.stratum(stratum).active), degree)
    ode = OdeEndpoint(system.compiled(stratum), q0, basis, T)
    direction = np.random.default_rng(1).normal(size=h.A1.shape[1])
    errors = []
    for eps in scales:
        lam = eps * direction
        alpha = h(lam)
        if flip_bracket:
            alpha[h.slices[1]] *= -1.0
        true, _ = ode(lam, False)
        errors.append(np.linalg.norm(flow(lb, q0, alpha) - true))
    return np.array(errors)


@pytest.mark.parametrize(("degree", "order"), [(2, 3), (3, 4)])
def test_one_step_prediction_error_shrinks_like_u_cubed(degree, order):
    """exp(Σ α_h(u) B_h)(q) against a real integration: O(|u|^3) for degree 2, O(|u|^4) for 3."""
    q0 = np.array([-PI / 3, -PI / 3, PI / 6, PI / 12])
    errors = _prediction_errors(preset("one-arm"), "S1", q0, degree, [0.2, 0.1, 0.05])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(rates > order - 0.25), rates


def test_wrong_bracket_sign_is_caught_by_the_shrinkage_rate():
    system = parse_scenario(UNICYCLE).system
    q0 = np.array([0.1, -0.2, 0.4])
    good = _prediction_errors(system, "drive", q0, 2, [0.1, 0.05, 0.025])
    bad = _prediction_errors(system, "drive", q0, 2, [0.1, 0.05, 0.025], flip_bracket=True)
    assert np.all(np.log2(good[:-1] / good[1:]) > 2.75)
    assert np.all(np.log2(bad[:-1] / bad[1:]) < 2.25)  # the O(|u|^2) bracket term is wrong


# ---------------------------------------------------------------------------- Lie legs


def _pieces_join(doc, leg, order):
    """Values (and derivatives) of consecutive pieces of a leg agree at their joints."""
    from reintegrate import controls

    inputs = doc["inputs"]
    worst = 0.0
    for a, b in zip(leg["pieces"], leg["pieces"][1:], strict=False):
        for d in range(order + 1):
            end = controls(a, inputs, a["duration"], bool(d))
            start = controls(b, inputs, 0.0, bool(d))
            worst = max(worst, float(np.abs(end - start).max()))
    return worst


@pytest.mark.parametrize(("degree", "rest"), [(3, True), (2, False)])
def test_hybrid_newton_lie_newton_keeps_continuity_and_reaches_every_goal(degree, rest):
    """A Lie leg between two Newton legs: its steps are pieces, each piece joins the next
    with C1, the first continues the Newton leg before it, the next Newton leg continues the
    last piece; every goal is reached, checked by re-integrating result.json independently."""
    from test_scenarios import verify

    system = preset("one-arm")
    q0 = np.array([0.0, PI / 4, 0.0, 0.0])
    via1 = np.array([0.0, PI / 3, 0.3, -0.05])
    via2 = via1 + np.array([0.0, 0.1, -0.05, 0.04])
    goal = np.array([-0.2, PI / 3 + 0.1, 0.25, np.nan])
    settings = PlannerSettings(objective="newton")
    lie = replace(settings.lie, degree=degree, rest=rest)
    legs = [
        LegSpec("S1", via1),
        LegSpec("S1", via2, method="lie", lie=lie),
        LegSpec("S3", goal),
    ]
    plan = plan_sequence(system, q0, legs, settings)
    assert plan.ok, plan.message
    doc = result_document(plan, "hybrid", "one-arm")
    lie_leg = doc["legs"][1]
    assert lie_leg["method"] == "lie" and len(lie_leg["pieces"]) >= 2
    assert lie_leg["duration"] == pytest.approx(0.51 * len(lie_leg["pieces"]))
    assert [p["t0"] for p in lie_leg["pieces"]] == pytest.approx(
        [0.51 * k for k in range(len(lie_leg["pieces"]))]
    )
    assert _pieces_join(doc, lie_leg, 1) <= 1e-9
    # u1 is unused on the Lie leg's S1 and u2 on the next leg's S3 (lr-C1): both end at zero
    for sw in doc["switches"]:
        assert max(abs(v) for v in sw["jump"].values()) <= 1e-9
        assert max(abs(v) for v in sw["jump_derivative"].values()) <= 1e-9

    verify(SimpleNamespace(legs=legs, text=""), doc)  # what verify() needs from a task
    if rest:  # time scaling scales every piece of the Lie leg: same path, energy x s
        from stratcli.stratified import time_scaled

        fast = time_scaled(plan, 2.0)
        assert fast.total_energy == pytest.approx(2.0 * plan.total_energy, rel=1e-9)
        verify(SimpleNamespace(legs=legs, text=""), result_document(fast, "hybrid", "one-arm"))
    # the trajectory sampler integrates the Lie leg piece by piece to the same end point
    from stratcli.records.trajectory import sample

    traj = sample(plan, samples_per_leg=100)
    np.testing.assert_allclose(traj.q[traj.leg_slice(1)][-1], plan.legs[1].end, atol=1e-8)
    assert mode_order(doc["continuity"]) == 1


def test_sim3_lie_leg_is_local_and_cheap(scenarios_dir):
    task = load_scenario(scenarios_dir / "sim3_hybrid.toml")
    assert [leg.method for leg in task.legs] == ["newton", "newton", "lie"]
    assert task.settings.lie.degree == 3
    # the Lie leg alone, from the configuration and the controls the Newton legs leave
    start = np.array([-PI / 3, -PI / 3, PI / 6, PI / 12])
    previous = (np.array([0.0, 0.0, -1.25]), np.array([0.0, 0.0, 19.6]))
    from stratcli.stratified import LegStart, plan_next_leg, planner_for

    lie_leg = task.legs[2]
    at = LegStart(start, previous, 2.0, 2)
    planner = planner_for(lie_leg, task.settings)
    leg = plan_next_leg(task.system, task.settings, lie_leg, at, None, planner)
    assert leg.converged and leg.error <= 1e-3
    assert leg.energy < 20.0  # small loops (the Newton legs cost ~10² here)
    # local: small periodic motions of the joints (the Newton legs sweep them by ~3 rad)
    t = np.linspace(0.0, leg.duration, 4001)
    u = leg.controls(t)
    joints = cumulative_trapezoid(u[:, 1:], t, axis=0, initial=0.0)
    assert np.ptp(joints, axis=0).max() < 0.5
    u0 = leg.controls(np.array([0.0]))[0]
    du0 = leg.controls(np.array([0.0]), True)[0]
    np.testing.assert_allclose(u0, previous[0], atol=1e-9)
    np.testing.assert_allclose(du0, previous[1], atol=1e-9)


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


# ---------------------------------------------------------------------------- check


def test_presets_are_strongly_controllable():
    for name in ("one-arm", "two-arm"):
        system = preset(name)
        doc = check_document(system, list(system.strata), np.zeros(system.n), samples=20)
        assert doc["strongly_controllable"] and doc["stratified_controllable"], name
        assert doc["controllable"] and not doc["problems"]
        # at q = 0 every first derivative of A vanishes: third-order brackets are needed there
        assert all(s["rank_at_requested_degree"] < s["dimension"] for s in doc["strata"])
        assert all(s["degree_at"] == 3 for s in doc["strata"])


def test_biped_is_not_controllable_on_its_strata_but_is_stratified_controllable(scenarios_dir):
    result = runner.invoke(app, ["check", str(scenarios_dir / "biped.toml"), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    strong = {s["stratum"]: s["strong"] for s in doc["strata"]}
    # the paper: not controllable on S1, S2, S12 (each reaches only 2 of 5 directions) ...
    assert strong == {"S1": False, "S2": False, "S12": False}
    assert doc["eq2"]["sum_min_rank"] == 4  # each stratum's closure alone: not enough
    # ... but stratified controllable by switching between them
    assert doc["eq2"]["by_switching"] and doc["stratified_controllable"]
    assert all(leg["ok"] for leg in doc["legs"])


TURN = 'active = ["v", "w"]\n[[model.strata]]\nname = "turn"\nactive = ["w"]'


def test_check_exit_code_3_names_the_stratum_and_configuration(tmp_path):
    scenario = tmp_path / "bad.toml"
    scenario.write_text(
        UNICYCLE.replace("goal = [0, 0.1, 0]", "goal = [1, 0, 0]")
        .replace('active = ["v", "w"]', TURN)
        .replace('stratum = "drive"', 'stratum = "turn"')
    )
    result = runner.invoke(app, ["check", str(scenario)])
    assert result.exit_code == 3
    assert "leg 1 on turn" in result.stderr and "q = (0, 0, 0)" in result.stderr
    planned = runner.invoke(app, ["plan", str(scenario), "--out", str(tmp_path / "runs")])
    assert planned.exit_code == 3 and "not controllable" in planned.stderr
    assert not any((tmp_path / "runs").iterdir())  # the directory is made, no record in it


def test_check_command_on_a_preset_prints_ranks_and_spanning_brackets():
    result = runner.invoke(app, ["check", "one-arm", "--at", "0, pi/3, 0, 0", "--samples", "5"])
    assert result.exit_code == 0, result.output
    assert "strongly controllable on every stratum" in result.output
    assert "[u2,u3]" in result.output
    bad = runner.invoke(app, ["check", "one-arm", "--at", "0, 1"])
    assert bad.exit_code == 2
