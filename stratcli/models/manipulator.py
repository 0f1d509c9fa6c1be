"""Planar free-floating manipulators from physical parameters as stratified systems (DESIGN §7).

`q = (q_1..q_k, θ)`, `q_j' = u_j`, `θ' = Σ A_j(q) u_j` with `A = f/f_θ` from angular-momentum
conservation (MODELS.md §1-3). The numeric strata evaluate `A` and `∂A/∂q` with the vectorised
closed forms of `connection.connection` (no sympy, so 20-link chains are cheap); the symbolic
fields are derived only when something asks for them (e.g. Lie brackets).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

from .connection import connection, connection_A, connection_symbolic
from .planar import PlanarManipulator
from .system import Stratum, System

if TYPE_CHECKING:
    import sympy as sp


def stratum_name(locked: tuple[int, ...]) -> str:
    """`S1`, `S13`; with joint numbers ≥ 10 the indices are separated: `S1_12`."""
    numbers = [str(j + 1) for j in locked]
    sep = "_" if any(len(x) > 1 for x in numbers) else ""
    return "S" + sep.join(numbers)


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
            (..., 1, m, k, k) derivatives along the joints; the second by central
            differences of the closed-form dA, all shifted points in one batched call."""
            joints = q[..., :k]
            if order == 0:
                return (connection_A(robot, joints)[..., None, act],)
            A, dA = connection(robot, joints)
            out = (A[..., None, act], dA[..., None, act, :])
            if order == 1:
                return out
            h = 1e-5
            shifts = h * np.concatenate([np.eye(k), -np.eye(k)])  # (2k, k)
            moved = joints[None] + shifts.reshape(2 * k, *([1] * (joints.ndim - 1)), k)
            dAs = connection(robot, moved)[1][..., act, :]  # (2k, ..., m, k)
            dd = np.moveaxis((dAs[:k] - dAs[k:]) / (2 * h), 0, -1)  # (..., m, k, k)
            return (*out, dd[..., None, :, :, :])

        self.G, self.dG = G, dG
        self.quadrature_terms = terms


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
        strata = {}
        for locked in lock_sets if lock_sets is not None else default_lock_sets(k):
            locked = tuple(sorted(locked))
            active = tuple(j for j in range(k) if j not in locked)
            strata[stratum_name(locked)] = Stratum(stratum_name(locked), locked, active)
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
