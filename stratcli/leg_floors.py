"""Lower bounds on a leg's energy from its stratum's geometry alone (the screen's *floors*:
no search, a few milliseconds a leg).

A leg of duration T moves the joints its inputs drive (the stratum's constant rows,
`q̇_E = C u`) and the base (the rows that depend on the joints, `θ̇ = A(q_E) u`). With
`w(t) = ∫_0^t u` its energy `E = ∫|u|²` is bounded twice:

- *joints*: `C w(T) = Δq_E` and `|w(T)|² ≤ T E` (Cauchy-Schwarz), so `E ≥ |C⁺ Δq_E|² / T`;
- *base, two inputs*: close the path `w` by the straight segment back to its start. By
  Stokes, `Δθ - θ_segment = ∬ F ν dA` (F = ∂A_2/∂w_1 - ∂A_1/∂w_2, the curvature of the
  connection on the stratum; ν the winding number), and by the Banchoff-Pohl inequality
  `∬ ν² dA ≤ ℓ²/4π` for a closed curve of length ℓ = ∫|u| + |w(T)| ≤ √(T E) + |w(T)|. So
  `√(T E) ≥ √(4π |Δθ - θ_segment| / max|F|) - |w(T)|`.

Both allow for a plan that ends within the planner's tolerance of the goal (`slack`).
The second is what makes a leg that must turn the base through a small curvature dear: the
Sim 4 comparison's four S2 legs that turn the base far (searched minima 407-557) get floors
of 79-108 (the best sequence costs 64.80), so the screen prunes every sequence with one of
them without searching the leg (its two other S2 legs, floors 7.1 and 7.5, are searched). Unlike
the searched minima (a multi-start local search may miss a leg's global minimum), a floor
holds for every plan of the leg, as far as `max|F|` does: it is taken over the whole torus
of the two driven joints on a 64 x 64 grid, raised by the grid's half-diagonal times the
largest |∇F| at its points (a margin, not a proof: ~10 % on the one-arm robot), which needs
the connection to be 2π-periodic in them (checked at 16 points; otherwise only the joints'
bound). Legs of other strata (one input, three or more) get the joints' bound; a URDF
robot's (an attitude on SO(3), no quadrature rows) get 0.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from .curvature import curvature, driven

__all__ = ["leg_floor"]

GRID = 64  # points per driven joint on the torus where |F| is maximised
NODES = 48  # Gauss-Legendre nodes of the straight segment's integral
PERIOD_TOL = 1e-9  # relative: the connection repeats after 2π in a driven joint
PERIOD_STRIDE = 257  # ... checked at every 257th grid point (16 spread over the torus)
SAFETY = 1.0 - 1e-6  # a floor is lowered by this factor (rounding)


def floors_known(system, stratum: str) -> bool:
    """Whether legs on `stratum` can have a floor: a quadrature model's only (a URDF
    robot's have none: `leg_floor` is 0 for every leg)."""
    return _quadrature(system, stratum) is not None


def _quadrature(system, stratum: str):
    """The stratum's compiled functions where they have quadrature terms, else None."""
    try:
        cs = system.compiled(stratum)
    except Exception:  # not a quadrature model (URDF): no floor
        return None
    return cs if getattr(cs, "quadrature_terms", None) is not None else None


def leg_floor(
    system, stratum: str, start, goal, duration: float, peaks=None, slack: float = 0.0
) -> float:
    """A lower bound on `∫|u|²` over every plan of the leg from `start` to `goal` (NaN:
    free) on `stratum` in `duration` seconds (the module docstring); 0 where none is known.

    `peaks`: a dict that keeps each max|F| found, for the legs of a comparison that share a
    stratum and the joints it does not drive. `slack`: how far from `goal` a plan may end
    (the planner's tolerance: the norm of the joints' error, and the base's), so that the
    floor holds for such a plan too."""
    cs = _quadrature(system, stratum)
    if cs is None or not duration > 0:
        return 0.0
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    if not np.isfinite(start).all():
        return 0.0
    explicit = np.array(cs.explicit, dtype=int)
    known = np.isfinite(goal[explicit])
    C = cs.C_explicit
    w, *_ = np.linalg.lstsq(C[known], (goal - start)[explicit][known], rcond=None)
    if not np.allclose(C[known] @ w, (goal - start)[explicit][known], atol=1e-9):
        return 0.0  # the joints cannot get there: the search says why
    # a plan ending within `slack` of the goal: |w(T)| >= |w| - |C⁺| slack
    reach = float(np.linalg.norm(w)) - float(np.linalg.norm(np.linalg.pinv(C[known]), 2)) * slack
    floor = max(reach, 0.0) ** 2 / duration
    if C.shape[1] == 2 and known.all():
        floor = max(floor, _base_floor(cs, start, goal, w, duration, peaks, slack))
    return SAFETY * floor


def _base_floor(cs, start, goal, w, T: float, peaks, slack: float) -> float:
    """The Stokes / Banchoff-Pohl bound of the module docstring, over the base rows. A plan
    that ends within `slack` of the goal is closed by one more segment of at most `slack`
    to it: the loop is that much longer and encloses up to `slack (1 + max|A|)` less."""
    inputs = driven(cs)
    if inputs is None:
        return 0.0
    best = 0.0
    for row, i in enumerate(cs.quadrature):
        if not np.isfinite(goal[i]):
            continue
        residual = abs(goal[i] - start[i] - _segment(cs, start, w, row))
        if not residual > slack:
            continue
        fixed = np.delete(start, [j for j, _ in inputs]).tobytes()
        key = (cs.stratum.name, row, fixed)
        found = peaks.get(key) if peaks is not None else None
        if found is None:
            found = _peak_curvature(cs, start, inputs, row)
            if peaks is not None:
                peaks[key] = found
        peak, most = found
        if not peak > 0:
            continue
        enclosed = residual - slack * (1.0 + most)
        if not enclosed > 0:
            continue
        length = math.sqrt(4.0 * math.pi * enclosed / peak) - float(np.linalg.norm(w)) - slack
        best = max(best, max(length, 0.0) ** 2 / T)
    return best


def _segment(cs, start: np.ndarray, w: np.ndarray, row: int) -> float:
    """`∫ A·dw` along the straight segment from `start` to the leg's joint goal."""
    s, weights = _nodes()
    q = np.repeat(start[None, :], NODES, axis=0)
    q[:, list(cs.explicit)] += s[:, None] * (cs.C_explicit @ w)[None, :]
    (A,) = cs.quadrature_terms(q, 0)
    return float(weights @ (A[:, row, :] @ w))


@cache
def _nodes() -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1]."""
    s, weights = np.polynomial.legendre.leggauss(NODES)
    return 0.5 * (s + 1.0), 0.5 * weights


def _peak_curvature(cs, start: np.ndarray, inputs, row: int) -> tuple[float, float]:
    """(max |F|, max |A|) over the torus of the two driven joints (the others where `start`
    has them), |F| with a margin of half the grid's diagonal times the largest |∇F| at the
    grid's points, by central differences (|∇F| between them is not bounded: a margin, not
    a proof); (NaN, NaN) when the connection is not 2π-periodic in a driven joint or not
    finite there."""
    (j0, _), (j1, _) = inputs
    h = 2.0 * math.pi / GRID
    g0, g1 = np.meshgrid(np.arange(GRID) * h, np.arange(GRID) * h, indexing="ij")
    q = np.repeat(start[None, :], GRID * GRID, axis=0)
    q[:, j0] += g0.ravel()
    q[:, j1] += g1.ravel()
    F, A = curvature(cs, q, inputs, row)
    if not _periodic(cs, q[::PERIOD_STRIDE], A[::PERIOD_STRIDE], (j0, j1)):
        return math.nan, math.nan
    # |∇F| by central differences on the periodic grid (the same in w as in q: the signs
    # only reflect the axes)
    if not (np.isfinite(F).all() and np.isfinite(A).all()):
        return math.nan, math.nan
    grid = F.reshape(GRID, GRID)
    slope = [(np.roll(grid, -1, axis=a) - np.roll(grid, 1, axis=a)) / (2 * h) for a in (0, 1)]
    grad = np.hypot(*slope)
    peak = float(np.abs(F).max() + h / math.sqrt(2.0) * grad.max())
    return peak, float(np.linalg.norm(A[:, row, :], axis=-1).max())


def _periodic(cs, q: np.ndarray, A: np.ndarray, joints) -> bool:
    """The connection at `q` (values `A`) repeats after 2π in each driven joint."""
    scale = max(1.0, float(np.abs(A).max()))
    for j in joints:
        shifted = q.copy()
        shifted[:, j] += 2.0 * math.pi
        (B,) = cs.quadrature_terms(shifted, 0)
        if not np.allclose(A, B, rtol=0.0, atol=PERIOD_TOL * scale):
            return False
    return True
