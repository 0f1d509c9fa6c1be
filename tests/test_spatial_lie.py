"""Numeric brackets of spatial strata: a small joint cycle turns the base by a²·[X_i, X_j],
and `check` reports eq. 4 / eq. 2 for URDF models."""

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pinocchio")

from stratcli.cli import app
from stratcli.controllability import stratum_report
from stratcli.controls import FourierBasis
from stratcli.liealgebra import lie_basis
from stratcli.models.spatial import load_spatial

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def arm3():
    return load_spatial(ROOT / "robots" / "arm3.urdf")


def _cycle(system, stratum, q0, i, j, a):
    cs = system.compiled(stratum)
    basis = FourierBasis(harmonics=1, period=2.0)
    y = np.array(q0, dtype=float)
    for joint, sign in ((i, 1), (j, 1), (i, -1), (j, -1)):
        L = np.zeros((len(cs.act), 3))
        L[list(cs.act).index(joint), 0] = a * sign
        y, _ = cs.endpoint(y, basis, 1.0)(L.ravel(), jacobian=False)
    return y


@pytest.mark.parametrize("stratum, i, j", [("S3", 0, 1), ("S1", 1, 2), ("S2", 0, 2)])
def test_small_cycle_turns_the_base_by_the_bracket(arm3, stratum, i, j):
    q0 = np.array([0.4, -0.3, 0.8, 0.0, 0.0, 0.0])
    a = 1e-2
    end = _cycle(arm3, stratum, q0, i, j, a)
    basis = lie_basis(arm3, stratum, 2)
    s = arm3.stratum(stratum)
    c = basis.labels.index(f"[{arm3.inputs[i]},{arm3.inputs[j]}]")
    bracket = basis.evaluate(q0)[-3:, c]  # the attitude rows, body frame at R = I
    np.testing.assert_allclose(end[3:] / a**2, bracket, atol=3e-2 * np.abs(bracket).max())
    assert s.active == tuple(sorted((i, j)))


def test_planar_stratum_turns_the_base_about_one_axis_only(arm3):
    at_zero = stratum_report(arm3, "S1", np.zeros((1, 6)), degree=2)
    assert at_zero.rank[0] == 3 and not at_zero.strong  # j2, j3 swing in the base's xz plane
    general = stratum_report(arm3, "S3", np.array([[0.3, -0.5, 0.0, 0, 0, 0]]), degree=2)
    assert general.strong


def test_check_command_on_a_urdf_scenario():
    path = ROOT / "scenarios" / "spatial" / "arm3_reorient.toml"
    result = CliRunner().invoke(app, ["check", str(path)])
    assert result.exit_code == 0, result.output
    assert "stratified controllable (eq. 2)" in result.output
    assert "every leg's stratum spans" in result.output
