"""Boundary conditions on the controls of a leg and their elimination (paper §4.3, §5.2).

Controls are linear in the coefficients, so every condition at a switch is a row of
`C λ = c` (eq. 25). They are eliminated once per leg with an orthonormal null-space basis,
`λ = λp + N z` (eq. 26-29), and the planner iterates in `z`.

Modes: `none`; `l-C0`/`l-C1`: a leg starts where the previous leg's controls
ended (inputs new on this leg start at 0); `lr-C0`/`lr-C1`: additionally, inputs the next leg
does not use end at 0. `C1` adds the same conditions on the derivatives. `soft_start` and
`full_stop` ask `u = u' = 0` at the very start and the very end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .controls import FourierBasis

MODES = ("none", "l-C0", "l-C1", "lr-C0", "lr-C1")


def mode_order(mode: str) -> int:
    """Highest derivative order kept continuous: -1 (none), 0 (C0) or 1 (C1)."""
    return -1 if mode == "none" else int(mode[-1])


@dataclass(frozen=True)
class Constraints:
    """Linear conditions `C λ = c` on one leg's flat coefficient vector, with labels."""

    C: np.ndarray
    c: np.ndarray
    labels: tuple[str, ...]


@dataclass(frozen=True)
class Elimination:
    """The coefficients that meet a leg's continuity conditions: `λ = particular + null @ z`,
    with orthonormal `null` (p x free), for any `z` (paper eq. 26-29)."""

    particular: np.ndarray
    null: np.ndarray

    @property
    def free(self) -> int:
        """How many free parameters `z` has (0: the conditions fix the coefficients)."""
        return self.null.shape[1]

    def coefficients(self, z: np.ndarray) -> np.ndarray:
        """The flat coefficients `particular + null @ z` (they meet the conditions)."""
        return self.particular + self.null @ z

    def project(self, lam: np.ndarray) -> np.ndarray:
        """z of the feasible point closest to `lam`."""
        return self.null.T @ (lam - self.particular)


def leg_constraints(
    basis: FourierBasis,
    duration: float,
    active: tuple[int, ...],
    input_names: tuple[str, ...],
    mode: str,
    *,
    previous: tuple[np.ndarray, np.ndarray] | None,
    next_active: tuple[int, ...] | None,
    soft_start: bool,
    full_stop: bool,
) -> Constraints:
    """Conditions for one leg.

    `previous` holds the values and derivatives of *all* inputs at the end of the previous
    leg (zero for inputs it did not use), or None for the first leg; `next_active` the inputs
    of the next leg, or None for the last leg.
    """
    order = mode_order(mode)
    size = basis.size
    rows: list[np.ndarray] = []
    rhs: list[float] = []
    labels: list[str] = []
    start = (basis.values(0.0), basis.derivatives(0.0))
    end = (basis.values(duration), basis.derivatives(duration))
    names = ("u", "u'")

    def add(a: int, phi: np.ndarray, value: float, label: str) -> None:
        row = np.zeros(len(active) * size)
        row[a * size : (a + 1) * size] = phi
        rows.append(row)
        rhs.append(value)
        labels.append(label)

    for a, k in enumerate(active):
        name = input_names[k]
        if previous is None:
            if soft_start:
                for d in (0, 1):
                    add(a, start[d], 0.0, f"soft start: {names[d]}_{name}(0) = 0")
        elif order >= 0:
            for d in range(order + 1):
                add(a, start[d], float(previous[d][k]), f"{names[d]}_{name}(0) continues")
        if next_active is None:
            if full_stop:
                for d in (0, 1):
                    add(a, end[d], 0.0, f"full stop: {names[d]}_{name}(T) = 0")
        elif mode.startswith("lr") and k not in next_active:
            for d in range(order + 1):
                add(a, end[d], 0.0, f"{names[d]}_{name}(T) = 0 (unused on the next leg)")
    p = len(active) * size
    C = np.array(rows).reshape(len(rows), p)
    return Constraints(C, np.array(rhs, dtype=float), tuple(labels))


def eliminate(constraints: Constraints) -> Elimination:
    """Particular solution and orthonormal null space of `C λ = c` (SVD, rank-revealing)."""
    C, c = constraints.C, constraints.c
    p = C.shape[1]
    if C.shape[0] == 0:
        return Elimination(np.zeros(p), np.eye(p))
    U, S, Vt = np.linalg.svd(C)
    rank = int(np.sum(S > 1e-10 * S[0]))
    particular = Vt[:rank].T @ ((U[:, :rank].T @ c) / S[:rank])
    residual = float(np.abs(C @ particular - c).max())
    if residual > 1e-9 * (1.0 + float(np.abs(c).max())):
        raise ValueError(  # (continuity rows at both ends are dependent: periodic controls)
            f"boundary conditions are inconsistent (residual {residual:.2e}): over a whole "
            "number of basis periods, or nearly, a control ends as it starts, so it cannot "
            "continue the one before and end at 0; use a period that does not divide the leg "
            "or Lie step"
        )
    return Elimination(particular, Vt[rank:].T)


def sequence_constraints(
    basis: FourierBasis,
    durations: list[float],
    actives: list[tuple[int, ...]],
    input_names: tuple[str, ...],
    mode: str,
    *,
    soft_start: bool,
    full_stop: bool,
) -> Constraints:
    """All boundary conditions of a whole sequence on the stacked coefficients of its legs.

    The same conditions as `leg_constraints` applied leg by leg, but with the previous leg's
    final controls as unknowns: used when all legs are optimised together.
    """
    order = mode_order(mode)
    size = basis.size
    offsets = np.cumsum([0] + [len(a) * size for a in actives])
    rows: list[np.ndarray] = []
    labels: list[str] = []
    names = ("u", "u'")

    def row(terms: list[tuple[int, int, np.ndarray]], label: str) -> None:
        r = np.zeros(offsets[-1])
        for leg, a, phi in terms:
            r[offsets[leg] + a * size : offsets[leg] + (a + 1) * size] += phi
        rows.append(r)
        labels.append(label)

    def at(t: float, d: int) -> np.ndarray:
        return basis.values(t) if d == 0 else basis.derivatives(t)

    last = len(actives) - 1
    for i, active in enumerate(actives):
        T = durations[i]
        for a, k in enumerate(active):
            name = input_names[k]
            if i == 0 and soft_start:
                for d in (0, 1):
                    row([(0, a, at(0.0, d))], f"soft start: {names[d]}_{name}(0) = 0")
            if i > 0 and order >= 0:
                prev = actives[i - 1]
                for d in range(order + 1):
                    terms = [(i, a, at(0.0, d))]
                    if k in prev:
                        terms.append((i - 1, prev.index(k), -at(durations[i - 1], d)))
                    row(terms, f"leg {i + 1}: {names[d]}_{name}(0) continues")
            if i == last and full_stop:
                for d in (0, 1):
                    row([(i, a, at(T, d))], f"full stop: {names[d]}_{name}(T) = 0")
            if i < last and mode.startswith("lr") and k not in actives[i + 1]:
                for d in range(order + 1):
                    row([(i, a, at(T, d))], f"leg {i + 1}: {names[d]}_{name}(T) = 0")
    C = np.array(rows).reshape(len(rows), offsets[-1])
    return Constraints(C, np.zeros(len(rows)), tuple(labels))
