"""Lie brackets of a spatial (URDF) stratum, numerically, in local exponential coordinates.

On SO(3)×Rᵏ the stratum's generators are `X_a = (e_{j_a}, ξ_a(q))`: joint `j_a` turns at unit
rate and the base at the body rate `ξ_a = S_ω[:, j_a](q)`. Writing the attitude part in the
body frame (left trivialisation, the local exponential coordinates `R exp([η]×)` at `R`),
fields `X = (a, ζ_X(q))` with constant joint parts `a` have brackets (with
`[X, Y] f = X(Y f) − Y(X f)` and `[L_ξ, L_η] = L_{ξ×η}` for left-invariant fields)::

    [X, Y] = (0, ζ_X × ζ_Y + ∂ζ_Y/∂q · a_X − ∂ζ_X/∂q · a_Y).

Degree 2 uses Pinocchio's analytic derivative of the connection (`SpatialRobot.connection`);
degree 3 differentiates the degree-2 fields by fourth-order central differences (step 1e-3).
Nothing depends on `R`: the rank and σ_min of `check` are those of these 3 + k rows.
"""

from __future__ import annotations

import numpy as np

from .liealgebra import LieBasis, element_label, hall_basis
from .models.system import Stratum

__all__ = ["spatial_basis"]

STEP = 1e-3


def spatial_basis(system, stratum: Stratum, degree: int) -> LieBasis:
    """The Hall-basis fields of a spatial stratum up to `degree`, evaluated numerically."""
    robot = system.spatial
    k = robot.n_joints
    free = stratum.free(system.n)
    active = list(stratum.active)
    elements = hall_basis(len(active), degree)
    names = [system.inputs[j] for j in active]
    rows = {j: free.index(j) for j in active}
    attitude = [free.index(k + a) for a in range(3)]

    def evaluate(q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        lead = q.shape[:-1]
        Q = q.reshape(-1, q.shape[-1])[:, :k]
        memo: dict = {}

        def S(P, key):
            if ("S", key) not in memo:
                memo["S", key] = robot.angular(P)[0]  # (K, 3, k)
            return memo["S", key]

        def derivative_of_generator(P, key, j):  # ∂ξ_j/∂q (K, 3, k), analytic
            if ("D", key, j) not in memo:
                u = np.zeros_like(P)
                u[:, j] = 1.0
                memo["D", key, j] = robot.angular(P, u)[1]
            return memo["D", key, j]

        def zeta(h, P, key):
            if isinstance(h, int):
                return S(P, key)[:, :, active[h]]
            a, b = h
            out = np.cross(zeta(a, P, key), zeta(b, P, key))
            if isinstance(a, int):
                out = out + along(b, P, key, active[a])
            if isinstance(b, int):
                out = out - along(a, P, key, active[b])
            return out

        def along(h, P, key, j):  # ∂ζ_h/∂q_j (K, 3)
            if isinstance(h, int):
                return derivative_of_generator(P, key, active[h])[:, :, j]
            parts = []
            for step in (2, 1, -1, -2):
                moved = P.copy()
                moved[:, j] += step * STEP
                parts.append(zeta(h, moved, (*key, j, step)))
            return (-parts[0] + 8 * parts[1] - 8 * parts[2] + parts[3]) / (12 * STEP)

        out = np.zeros((Q.shape[0], len(free), len(elements)))
        for c, h in enumerate(elements):
            if isinstance(h, int):
                out[:, rows[active[h]], c] = 1.0
            out[:, attitude, c] = zeta(h, Q, ())
        return out.reshape(*lead, len(free), len(elements))

    labels = [element_label(h, names) for h in elements]
    return LieBasis(system, stratum, degree, elements, labels, free, None, evaluate)
