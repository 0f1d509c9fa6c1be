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
