"""Planar free-floating manipulators from physical parameters as stratified systems.

`q = (q_1..q_k, θ)`, `q_j' = u_j`, `θ' = Σ A_j(q) u_j` with `A = f/f_θ` from angular-momentum
conservation (docs/planar_model.md §1-3). The numeric strata evaluate `A`, `∂A/∂q` and the
contracted second derivatives with the vectorised closed forms of `connection` (no sympy, so
30-link chains are cheap); the symbolic fields are derived only when something asks for them (e.g.
Lie brackets).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

from .connection import (
    connection,
    connection_A,
    connection_gradient,
    connection_hessian,
)
from .connection_symbolic import connection_symbolic
from .planar import PlanarManipulator
from .system import Stratum, System

if TYPE_CHECKING:
    import sympy as sp


def stratum_name(locked: tuple[int, ...], joints: int = 0) -> str:
    """`S1`, `S13`; on a robot of 10 or more `joints` the numbers of a stratum that locks
    several are separated, `S1_2`, `S1_12`, so that `S12` is joint 12 alone (locking joint
    12, and joints 1 and 2, were both `S12`: one of them was lost)."""
    numbers = [str(j + 1) for j in locked]
    sep = "_" if joints >= 10 or any(len(x) > 1 for x in numbers) else ""
    return "S" + sep.join(numbers)


def locked_strata(k: int, lock_sets=None) -> dict[str, Stratum]:
    """The strata of a robot of `k` joints (planar or URDF), one per lock set (joint indices;
    default `default_lock_sets`), named by `stratum_name`, the other joints driven."""
    strata = {}
    for locked in lock_sets if lock_sets is not None else default_lock_sets(k):
        locked = tuple(sorted(locked))
        name = stratum_name(locked, k)
        strata[name] = Stratum(name, locked, tuple(j for j in range(k) if j not in locked))
    return strata


def default_lock_sets(k: int) -> list[tuple[int, ...]]:
    """Every single lock and, for four or more joints, every pair (issue: physical models)."""
    sets = [(j,) for j in range(k)]
    if k >= 4:
        sets += list(combinations(range(k), 2))
    return sets


@dataclass
class NumericManipulatorStratum:
    """Same interface as `CompiledStratum`, evaluated by the closed-form connection."""

    system: ManipulatorSystem
    stratum: Stratum

    def __post_init__(self) -> None:
        k = self.system.n - 1
        act = np.array(self.stratum.active, dtype=int)
        robot = self.system.robot
        self.explicit = tuple(range(k))
        self.quadrature = (k,)
        self.C_explicit = np.eye(k)[:, act]
        self.supports_quadrature = True
        m = act.size

        def G(q):  # (..., n) -> (..., n, m)
            A = connection_A(robot, q[..., :k])
            out = np.zeros((*q.shape[:-1], k + 1, m))
            out[..., act, np.arange(m)] = 1.0  # q_j' = u_j
            out[..., k, :] = A[..., act]
            return out

        def dG(q):  # (..., n) -> (..., n, m, n)
            _, dA = connection(robot, q[..., :k])
            out = np.zeros((*q.shape[:-1], k + 1, m, k + 1))
            out[..., k, :, :k] = dA[..., act, :]
            return out

        def terms(q, order):
            """θ row on the active inputs (..., 1, m) and its first (..., 1, m, k) and second
            (..., 1, m, k, k) derivatives along the joints, all in closed form."""
            joints = q[..., :k]
            if order == 0:
                return (connection_A(robot, joints)[..., None, act],)
            A, dA = connection(robot, joints)
            out = (A[..., None, act], dA[..., None, act, :])
            if order == 1:
                return out
            # the full tensor, one contraction per active input (the planners need only one:
            # `hessian_terms`)
            unit = np.zeros((m, *joints.shape))
            unit[np.arange(m), ..., act] = 1.0
            dd = np.stack([connection_hessian(robot, joints, e)[2] for e in unit], axis=-3)
            return (*out, dd[..., None, :, :, :])

        def jacobian_terms(q, V):
            """The θ row on the active inputs (..., 1, m) and Σ_a V_a ∂G_θa/∂q (..., 1, k) for
            weights V (..., 1, m): what an end point's Jacobian needs, in O(k) per point
            (`connection_gradient`)."""
            joints = q[..., :k]
            v = np.zeros(joints.shape)
            v[..., act] = V[..., 0, :]
            A, g = connection_gradient(robot, joints, v)
            return A[..., None, act], g[..., None, :]

        def hessian_terms(q, V):
            """The θ row's first derivatives (..., 1, m, k) and Σ_a V_a ∂²G_θa/∂q² (..., k, k)
            for weights V (..., 1, m): the one contraction an end point's Hessian needs, in
            O(k²) per point (`connection_hessian`)."""
            joints = q[..., :k]
            v = np.zeros(joints.shape)
            v[..., act] = V[..., 0, :]
            _, dA, H = connection_hessian(robot, joints, v)
            return dA[..., None, act, :], H

        self.G, self.dG = G, dG
        self.quadrature_terms = terms
        self.quadrature_jacobian = jacobian_terms
        self.quadrature_hessian = hessian_terms


class ManipulatorSystem(System):
    """A `System` whose vector fields come from a `PlanarManipulator`."""

    def __init__(
        self,
        robot: PlanarManipulator,
        name: str = "planar-manipulator",
        lock_sets: list[tuple[int, ...]] | None = None,
        description: str = "",
    ):
        k = robot.n_joints
        states = (*(f"q{j}" for j in range(1, k + 1)), "theta")
        inputs = tuple(f"u{j}" for j in range(1, k + 1))
        strata = locked_strata(k, lock_sets)
        super().__init__(name, states, inputs, None, strata, description=description, robot=robot)

    @property
    def fields(self) -> sp.Matrix:  # derived symbolically on first use only (slow for long chains)
        import sympy as sp  # only here: a cached model never needs sympy

        if self._fields is None:
            k = self.robot.n_joints
            A = connection_symbolic(self.robot, self.symbols[:k])
            G = sp.zeros(k + 1, k)
            for j in range(k):
                G[j, j] = 1
                G[k, j] = A[j]
            self._fields = G
        return self._fields

    @fields.setter
    def fields(self, value) -> None:
        self._fields = value

    def compiled(self, stratum):
        s = self.stratum(stratum) if isinstance(stratum, str) else stratum
        if s.name not in self._compiled:
            self._compiled[s.name] = NumericManipulatorStratum(self, s)
        return self._compiled[s.name]
