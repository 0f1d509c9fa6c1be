"""Boundary conditions at switches: elimination, l- and lr-modes, soft start, full stop."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import (
    plan_document,
)
from reintegrate import (
    controls,
    verify,
)

from stratcli.continuity import eliminate, leg_constraints
from stratcli.controls import FourierBasis
from stratcli.models.presets import preset

BASIS = FourierBasis(3, 2.17)


def test_boundary_conditions_hold_after_elimination():
    system = preset("one-arm")
    prev_u = np.array([0.4, -1.2, 0.0])
    prev_du = np.array([2.0, 0.3, 0.0])
    active = system.stratum("S2").active  # u1, u3
    cons = leg_constraints(
        BASIS, 1.0, active, system.inputs, "lr-C1",
        previous=(prev_u, prev_du), next_active=system.stratum("S3").active,
        soft_start=False, full_stop=False,
    )  # fmt: skip
    elim = eliminate(cons)
    z = np.random.default_rng(1).normal(size=elim.free)
    lam = elim.coefficients(z).reshape(2, BASIS.size)
    u0, du0 = lam @ BASIS.values(0.0), lam @ BASIS.derivatives(0.0)
    uT, duT = lam @ BASIS.values(1.0), lam @ BASIS.derivatives(1.0)
    np.testing.assert_allclose(u0, [0.4, 0.0], atol=1e-12)  # u1 continues, u3 starts at 0
    np.testing.assert_allclose(du0, [2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose([uT[1], duT[1]], [0.0, 0.0], atol=1e-12)  # u3 unused on S3
    assert elim.free == 14 - 6


def test_stacked_conditions_continue_each_leg_from_the_end_of_the_one_before():
    """All legs' conditions at once (the energy objective's), legs of unequal durations:
    each leg's controls start where the one before ends (its own duration, not the next
    leg's), value and derivative, and an input the next leg leaves ends at zero (lr)."""
    from stratcli.continuity import sequence_constraints

    system = preset("one-arm")
    actives = [system.stratum(s).active for s in ("S2", "S3", "S1")]
    durations = [0.7, 1.9, 1.3]
    cons = sequence_constraints(
        BASIS, durations, actives, system.inputs, "lr-C1", soft_start=False, full_stop=False
    )
    elim = eliminate(cons)
    lam = elim.coefficients(np.random.default_rng(2).normal(size=elim.free))
    sizes = [len(a) * BASIS.size for a in actives]
    parts = np.split(lam, np.cumsum(sizes)[:-1])
    per_leg = [p.reshape(len(a), BASIS.size) for p, a in zip(parts, actives, strict=True)]
    for i in range(1, len(actives)):
        before, after, T = per_leg[i - 1], per_leg[i], durations[i - 1]
        for a, k in enumerate(actives[i]):
            if k in actives[i - 1]:
                b = actives[i - 1].index(k)
                assert after[a] @ BASIS.values(0.0) == pytest.approx(
                    before[b] @ BASIS.values(T), abs=1e-10
                )
                assert after[a] @ BASIS.derivatives(0.0) == pytest.approx(
                    before[b] @ BASIS.derivatives(T), abs=1e-10
                )
            else:  # (lr: it ended at zero on the leg before, if that leg drove it)
                assert after[a] @ BASIS.values(0.0) == pytest.approx(0.0, abs=1e-10)
        for b, k in enumerate(actives[i - 1]):
            if k not in actives[i]:
                assert before[b] @ BASIS.values(T) == pytest.approx(0.0, abs=1e-10)


def test_lr_mode_ends_unused_inputs_at_zero_and_l_mode_lets_them_jump(scenarios_dir):
    """Sim 1: under l-C1, u1 (unused on the last leg) may jump to 0; under lr-C1 it may not."""
    _, lr = plan_document(scenarios_dir / "sim1_lr_c1.toml", objective="newton")
    _, left = plan_document(scenarios_dir / "sim1_l_c1.toml", objective="newton")
    assert abs(lr["switches"][1]["jump"]["u1"]) <= 1e-9
    # l-C1 imposes nothing at the end of leg 2, so u1 generally ends away from zero
    assert abs(left["switches"][1]["jump"]["u1"]) > 1e-6


def test_soft_start_and_full_stop_hold(shipped_plans):
    doc = shipped_plans["sim2_soft"][1].document  # planned once per session

    first, last = doc["legs"][0]["pieces"][0], doc["legs"][-1]["pieces"][-1]
    for d in (False, True):
        assert np.abs(controls(first, doc["inputs"], 0.0, d)).max() <= 1e-9
        assert np.abs(controls(last, doc["inputs"], last["duration"], d)).max() <= 1e-9


@pytest.mark.parametrize("mode", ["none", "l-C0", "l-C1", "lr-C0", "lr-C1"])
def test_every_continuity_mode_on_sim1(scenarios_dir, mode):
    task, doc = plan_document(
        scenarios_dir / "sim1_lr_c1.toml", continuity=mode, objective="newton"
    )
    assert doc["continuity"] == mode
    verify(task, doc)
