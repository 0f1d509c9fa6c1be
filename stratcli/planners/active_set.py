"""Small dense pieces of the constrained search's SQP step (`planners.constrained`): a
positive-definite model Hessian, and the strictly convex QP by least distance (no I/O)."""

from __future__ import annotations

import numpy as np

__all__ = ["convexified", "least_distance", "nnls"]


def convexified(R: np.ndarray, B: np.ndarray, floor: float) -> np.ndarray:
    """R (symmetric) made positive definite for a QP whose active constraints have the
    gradients B (rows).

    On the null space of B it keeps R's own curvature, floored at 2 `floor` (the second-order
    condition holds there at a regular minimum, so near one nothing changes). Across it, where
    the active constraints fix the step, it takes the absolute values of R's own eigenvalues
    (at least 2), and it drops the coupling between the two, which matters only while the
    active margins still move. Flooring the whole of R instead (as the unconstrained descent
    does) shifts every direction by the negative curvature that the goals' multipliers give
    across the constraints, tens of times the energy's own here: the steps shrink as much.
    """
    n = len(R)
    if n == 0:
        return R
    if B.size:
        _, S, Vt = np.linalg.svd(B)
        rank = int(np.sum(S > 1e-9 * S[0]))
        Y, N = Vt[:rank].T, Vt[rank:].T
    else:
        Y, N = np.zeros((n, 0)), np.eye(n)
    out = np.zeros_like(R)
    for V, on_null in ((N, True), (Y, False)):
        if V.shape[1] == 0:
            continue
        ev, U = np.linalg.eigh(V.T @ R @ V)
        ev = np.maximum(ev, 2.0 * floor) if on_null else np.maximum(np.abs(ev), 2.0)
        VU = V @ U
        out += (VU * ev) @ VU.T
    return out


def least_distance(A: np.ndarray, b: np.ndarray, active: np.ndarray | None = None):
    """min |w| subject to A w ≥ b, by Lawson & Hanson's least-distance programme (their
    non-negative least squares on [Aᵀ; bᵀ] u ≈ e): w and the constraints' multipliers, or
    None if the constraints admit no w. `active` (mask of A's rows, optional): the rows
    expected to be active, e.g. the last QP's of an SQP, the NNLS's first passive set."""
    m, n = A.shape
    if m == 0 or np.all(b <= 0):
        return np.zeros(n), np.zeros(m)
    E = np.vstack([A.T, b[None, :]])
    f = np.zeros(n + 1)
    f[-1] = 1.0
    u = nnls(E, f, passive=active)
    r = E @ u - f
    if abs(r[-1]) <= 1e-12:
        return None
    return -r[:n] / r[-1], u / -r[-1]


def nnls(
    E: np.ndarray,
    f: np.ndarray,
    max_iterations: int | None = None,
    passive: np.ndarray | None = None,
) -> np.ndarray:
    """argmin |E x - f| subject to x ≥ 0 (Lawson & Hanson's active-set method; scipy's
    `optimize.nnls` is not imported for it: scipy.optimize costs the command line its
    start-up time).

    `passive` (mask of E's columns, optional) warm-starts it: the least-squares solution on
    those columns, its columns at or below the tolerance dropped and solved again until every
    one is positive, is the first iterate (feasible, so the method goes on from it as from
    zero). An SQP's successive QPs share most of their active set: an H = 8 constrained
    search's QPs took 4.6x less time, the same solutions (their optimality conditions met as
    closely; where the active columns are dependent the multipliers, not unique, may split
    differently)."""
    m = E.shape[1]
    x = np.zeros(m)
    tol = 10 * np.finfo(float).eps * max(E.shape) * max(np.abs(E).max(initial=0.0), 1.0)
    passive = np.zeros(m, dtype=bool) if passive is None else passive.astype(bool)
    while passive.any():
        s = np.linalg.lstsq(E[:, passive], f, rcond=None)[0]
        if s.min() > tol:
            x[passive] = s
            break
        passive[np.flatnonzero(passive)[s <= tol]] = False
    w = E.T @ (f - E @ x)
    for _ in range(max_iterations or 3 * m):
        free = ~passive & (w > tol)
        if not free.any():
            break
        passive[int(np.argmax(np.where(free, w, -np.inf)))] = True
        for _ in range(m + 1):  # each pass drops at least one index from the passive set
            s = np.zeros(m)
            s[passive] = np.linalg.lstsq(E[:, passive], f, rcond=None)[0]
            if s[passive].min(initial=np.inf) > 0:
                break
            bad = passive & (s <= 0)
            alpha = float(np.min(x[bad] / (x[bad] - s[bad])))
            x += alpha * (s - x)
            passive &= x > tol
        x = s
        w = E.T @ (f - E @ x)
    return x
