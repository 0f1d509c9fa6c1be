"""The curvature of a stratum's connection in the plane of its two driven joints.

On a stratum whose two inputs each drive one joint at unit rate (`q̇_j = ±u`), the base
turns by the line integral of the connection `A(q)` along the joints' path; closed by a
segment, that is the integral of its curvature `F = ∂A_2/∂w_1 - ∂A_1/∂w_2` over the area
the path encloses, counted with its winding number (Stokes; `w` the inputs' integrals: area
and winding are those in the plane of w, which an input driving its joint backwards mirrors
against the joints' plane). The
leg floors bound a leg's energy with the largest |F| (`leg_floors`); the energy search's
loop starts put a leg's loop on a peak of |F| (`planners.loops`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["along", "curvature", "driven"]


def along(cs) -> tuple[int, ...]:
    """The explicit rows (indices into `cs.explicit`) the connection's derivatives are
    taken along: a compiled stratum's moving ones, a planar manipulator's all of them."""
    rows = getattr(cs, "derivatives_along", None)
    return tuple(range(len(cs.explicit))) if rows is None else tuple(rows)


def driven(cs) -> tuple[tuple[int, float], ...] | None:
    """Per input, (the joint it drives, the sign) when the stratum has two inputs and each
    drives one joint at unit rate (the plane of `curvature`), else None."""
    rows = along(cs)
    C = cs.C_explicit[list(rows)]
    joints = [cs.explicit[r] for r in rows]
    if C.ndim != 2 or C.shape[1] != 2:
        return None
    out = []
    for a in range(C.shape[1]):
        nonzero = np.flatnonzero(C[:, a])
        if len(nonzero) != 1 or abs(abs(C[nonzero[0], a]) - 1.0) > 1e-12:
            return None
        out.append((joints[nonzero[0]], float(np.sign(C[nonzero[0], a]))))
    if out[0][0] == out[1][0]:
        return None
    return tuple(out)


def curvature(cs, q: np.ndarray, inputs, row: int) -> tuple[np.ndarray, np.ndarray]:
    """(F, A) at the configurations `q` (K, n): the curvature of the connection's base row
    `row` (an index into `cs.quadrature`) in the plane of the driven joints (`inputs`, from
    `driven`), and the connection itself (K, nQ, 2)."""
    (j0, s0), (j1, s1) = inputs
    rows, explicit = along(cs), list(cs.explicit)
    e0, e1 = rows.index(explicit.index(j0)), rows.index(explicit.index(j1))
    A, dA = cs.quadrature_terms(q, 1)  # (second derivatives cost O(k²) a point on a chain)
    # along the inputs' integrals: ∂/∂w_a = s_a ∂/∂q_{j_a}
    return s0 * dA[:, row, 1, e0] - s1 * dA[:, row, 0, e1], A
