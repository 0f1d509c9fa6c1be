"""Re-integration of a plan for its record: bounded work, said so."""

from __future__ import annotations

import numpy as np

import stratcli.simulate as simulate


def test_reintegration_is_bounded_and_says_so(unicycle_plan, monkeypatch):
    _, plan = unicycle_plan
    monkeypatch.setattr(simulate, "MAX_EVALUATIONS", 20)
    traj = simulate.sample(plan, 50)
    assert np.isnan(traj.q).all() and len(traj.notes) == len(plan.legs)
    assert "could not be re-integrated" in traj.notes[0]
    monkeypatch.undo()
    traj = simulate.sample(plan, 50)
    assert np.isfinite(traj.q).all() and traj.notes == ()


def test_the_fast_field_gives_the_generic_numbers():
    """`_field` (φ into one buffer, `ArrayFunction.at`, `.dot`) is `G(y) @ (L @ φ(t))`."""
    from stratcli.controls import FourierBasis
    from stratcli.models.presets import two_arm

    system, rng = two_arm(), np.random.default_rng(3)
    basis = FourierBasis(harmonics=4, period=1.3)
    for stratum in system.strata:
        G = system.compiled(stratum).G
        L = rng.standard_normal((len(system.strata[stratum].active), basis.size))
        field = simulate._field(G, basis, L)
        for t, y in zip(rng.uniform(0, 5, 20), rng.uniform(-3, 3, (20, system.n)), strict=True):
            np.testing.assert_allclose(
                field(t, y), G(y) @ (L @ basis.values(t)), rtol=1e-13, atol=1e-15
            )


def test_a_field_at_one_point_where_python_floats_fail_is_numpys():
    """1/0.0 raises and (-8.0)**(1/3) is complex on Python floats; numpy scalars give inf and
    NaN, as `G(q)` does, and `at` must too (a trial step may pass there and recover)."""
    import sympy as sp

    from stratcli.models.generated import ArrayFunction

    x, y = sp.symbols("x y", real=True)
    G = ArrayFunction(sp.Matrix([[1 / x, y ** sp.Rational(1, 3)], [0, sp.sin(x) + y]]), [x, y])
    with np.errstate(all="ignore"):
        for q in ([0.0, 2.0], [0.5, -8.0], [0.5, 8.0]):
            q = np.array(q)
            assert G.at(q).shape == (2, 2)
            np.testing.assert_array_equal(G.at(q), G(q))
        assert np.isinf(G.at(np.array([0.0, 2.0]))[0, 0])
        assert np.isnan(G.at(np.array([0.5, -8.0]))[0, 1])


def test_states_at_any_times_are_the_re_integrated_trajectory():
    """Controls could be asked at any time, states only on `sample`'s uniform grid. A plan's
    `states(t)` at unsorted times equals its samples there (a switch: the later leg's start,
    the same configuration), reaches the goal at the end, and refuses times off the plan."""
    import pytest
    from conftest import ROOT

    import stratcli

    plan = stratcli.plan(stratcli.load_scenario(ROOT / "scenarios" / "sim3_hybrid.toml"))
    trajectory = plan.sample(40)
    shuffled = np.random.default_rng(0).permutation(trajectory.t.size)
    q = plan.states(trajectory.t[shuffled])
    assert q.shape == trajectory.q.shape
    assert np.abs(q - trajectory.q[shuffled]).max() < 1e-8
    end = plan.states(plan.duration)
    assert end.shape == (len(plan.coordinates),)
    assert np.linalg.norm(end - plan.legs[-1].goal) <= plan.settings.tolerance
    with pytest.raises(stratcli.InputError):
        plan.states(plan.duration + 1.0)
