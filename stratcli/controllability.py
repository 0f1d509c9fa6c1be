"""Controllability of strata and sequences (paper eq. 2 and 4).

* **Strong controllability (eq. 4)** of a stratum at `q`: its generators and their Lie brackets
  up to a degree, restricted to the stratum's free coordinates, have rank `dim S` (the number
  of free coordinates). Reported with the smallest singular value of that stack, so a user
  sees how close to singular a configuration is. Where the requested degree falls short
  (e.g. the space manipulators at q = 0, where every first derivative of `A` vanishes), the
  check retries with third-order brackets and says so: the verdict uses the highest degree.
* **Stratified controllability (eq. 2)**: the closures of the strata of a sequence, each taken
  within its own stratum, summed in the full tangent space, span `R^n`. When that sum falls
  short, the closure *across* the strata is computed too: brackets between fields of
  different strata, which switching back and forth between the strata realises (this is how
  the biped of eq. 3 walks sideways; Goodwine's stratified construction; `crossbasis`, which
  keeps a preset's closure in the code cache). Strong
  controllability of the strata implies eq. 2 (paper §2).
* **A leg of a scenario** needs less than eq. 4: its stratum must span the coordinates the leg
  steers (the others are free, "*"). This is what decides the exit code 3 of `check` and
  `plan`: the biped is not controllable on S1 or S2, yet each of its legs only steers what
  its stratum controls.

Configurations: the given one (a scenario's start, or each leg's nominal start: the previous
leg's goal where prescribed) and `samples` seeded uniform draws in [-π, π]^n.

Bounded work on large models: planar manipulators get closed-form brackets (degree 3 by
central differences above `lie.SYMBOLIC_MAX_COORDINATES` coordinates, so a 20-link chain is
checked in about a second); the symbolic closure across strata is computed only for
manipulators of at most that many coordinates and custom models whose Hall basis across the
strata has at most `MAX_SYMBOLIC_BRACKETS` elements; a custom model retries with third-order
brackets only when the stratum's degree-3 Hall basis has at most `MAX_SYMBOLIC_BRACKETS`
elements (else the verdict stays at the requested degree). The paper's models are below every
one of these limits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .crossbasis import cross_basis
from .liealgebra import MAX_DEGREE, SYMBOLIC_MAX_COORDINATES, hall_basis, lie_basis
from .models.manipulator import ManipulatorSystem
from .models.system import System

RANK_RTOL = 1e-9  # singular values below this times the largest count as zero
MAX_SYMBOLIC_BRACKETS = 250  # custom models: largest degree-3 Hall basis derived by sympy
ROW_CACHE_SIZE = 64  # sample sets remembered per system (`_rows`)


def _cross_affordable(system: System, strata: list[str], degree: int) -> bool:
    """Whether the closure across `strata` is cheap (closed form) or small enough to derive."""
    if isinstance(system, ManipulatorSystem) or getattr(system, "spatial", None) is not None:
        return True
    if getattr(system, "robot", None) is not None:
        return system.n <= SYMBOLIC_MAX_COORDINATES
    m = sum(len(system.stratum(s).active) for s in strata)  # an upper bound on the generators
    return len(hall_basis(m, degree)) <= MAX_SYMBOLIC_BRACKETS


def _can_escalate(system: System, stratum: str) -> bool:
    """Whether third-order brackets of `stratum` are affordable (closed form or small)."""
    if getattr(system, "robot", None) is not None or getattr(system, "spatial", None) is not None:
        return True
    m = len(system.stratum(stratum).active)
    return len(hall_basis(m, MAX_DEGREE)) <= MAX_SYMBOLIC_BRACKETS


def sample_configurations(n: int, count: int, seed: int = 0) -> np.ndarray:
    """`count` configurations uniform in [-π, π]^n, reproducible by `seed`."""
    return np.random.default_rng([seed, 6]).uniform(-np.pi, np.pi, (count, n))


def _rank_and_sigma(B: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Rank and the `dim`-th singular value (0 when fewer fields) of stacks B (..., rows, r).

    A stack that is not finite (a model whose fields overflow there) has rank 0 and σ NaN:
    no rank at all, which `api.check` reports as a model problem, not as a missing direction.
    """
    finite = np.isfinite(B).all(axis=(-2, -1))
    S = np.linalg.svd(np.where(finite[..., None, None], B, 0.0), compute_uv=False)
    if S.shape[-1] == 0:
        return np.zeros(B.shape[:-2], dtype=int), np.where(finite, 0.0, np.nan)
    top = S[..., :1]
    rank = np.sum(S > RANK_RTOL * np.maximum(top, 1e-300), axis=-1)
    rank = np.where((top[..., 0] > 0) & finite, rank, 0)
    sigma = S[..., dim - 1] if S.shape[-1] >= dim else np.zeros(B.shape[:-2])
    return rank, np.where(finite, sigma, np.nan)


def _rows(system: System, what: tuple, Q: np.ndarray, compute) -> tuple[np.ndarray, ...]:
    """`compute(Q)`, per-row arrays, with the rows after the first remembered per system.

    Every check of a process draws the same seeded samples after its own first row (the
    start): a sweep's tasks, auto mode's candidates. Rows are independent (one matrix, one
    SVD each), so the rows computed alone equal those computed together, bit for bit.
    """
    if len(Q) < 3:
        return compute(Q)
    cache = system.__dict__.setdefault("_row_cache", {})
    key = (what, Q[1:].tobytes())
    rest = cache.get(key)
    if rest is None:
        if len(cache) >= ROW_CACHE_SIZE:
            cache.clear()
        rest = cache[key] = compute(Q[1:])
    head = compute(Q[:1])
    return tuple(np.concatenate([h, r]) for h, r in zip(head, rest, strict=True))


@dataclass
class StratumReport:
    """Eq. 4 for one stratum at the given configurations (the first is the start)."""

    stratum: str
    dimension: int
    generators: list[str]
    degree: int  # requested
    basis_size: int
    configurations: np.ndarray  # (K, n)
    rank: np.ndarray  # (K,) at the degree used at each configuration
    sigma: np.ndarray  # (K,) smallest singular value (the dimension-th)
    degree_used: np.ndarray  # (K,) requested degree, or 3 where that fell short
    spanning: list[str]  # a spanning subset at the first configuration (greedy, basis order)
    rank_requested: np.ndarray  # (K,) rank at the requested degree

    @property
    def strong(self) -> bool:
        return bool(np.all(self.rank == self.dimension))

    @property
    def worst(self) -> int:
        """Index of the configuration with the smallest singular value."""
        return int(np.argmin(self.sigma))

    @property
    def escalated(self) -> int:
        """Configurations where the requested degree fell short but degree 3 did not."""
        return int(np.sum((self.rank_requested < self.dimension) & (self.rank == self.dimension)))


def stratum_report(
    system: System, stratum: str, configurations: np.ndarray, degree: int = 2
) -> StratumReport:
    """Rank and smallest singular value of the stratum's generators + brackets (eq. 4)."""
    s = system.stratum(stratum)
    Q = np.atleast_2d(np.asarray(configurations, dtype=float))
    lb = lie_basis(system, s, degree)
    dim = len(lb.free)

    def compute(R: np.ndarray) -> tuple[np.ndarray, ...]:
        rank, sigma = _rank_and_sigma(lb.evaluate(R), dim)
        rank_requested = rank.copy()
        used = np.full(len(R), degree)
        short = rank < dim
        if np.any(short) and degree < MAX_DEGREE and _can_escalate(system, s.name):
            B3 = lie_basis(system, s, MAX_DEGREE).evaluate(R[short])
            r3, s3 = _rank_and_sigma(B3, dim)
            rank[short], sigma[short], used[short] = r3, s3, MAX_DEGREE
        return rank, sigma, used, rank_requested

    rank, sigma, used, rank_requested = _rows(system, ("eq4", s.name, degree), Q, compute)
    first = lb if used[0] == degree else lie_basis(system, s, MAX_DEGREE)
    spanning = _spanning(first.evaluate(Q[0]), first.labels)
    return StratumReport(
        s.name,
        dim,
        [system.inputs[j] for j in s.active],
        degree,
        lb.size,
        Q,
        rank,
        sigma,
        used,
        spanning,
        rank_requested,
    )


def _spanning(B: np.ndarray, labels: list[str]) -> list[str]:
    """Fields kept in basis order when they raise the rank: which brackets are needed."""
    chosen: list[int] = []
    rank = 0
    for c in range(B.shape[1]):
        r, _ = _rank_and_sigma(B[:, [*chosen, c]][None], 1)
        if int(r[0]) > rank:
            chosen.append(c)
            rank = int(r[0])
        if rank == B.shape[0]:
            break
    return [labels[c] for c in chosen]


# --------------------------------------------------------------------------------------------
# Eq. 2: several strata together
# --------------------------------------------------------------------------------------------


@dataclass
class SequenceReport:
    """Eq. 2 for a set of strata at the given configurations."""

    strata: list[str]
    n: int
    configurations: np.ndarray
    sum_rank: np.ndarray  # (K,) rank of Σ of the strata's closures (each within its stratum)
    cross_rank: np.ndarray | None  # (K,) closure across strata, when the sum falls short
    cross_spanning: list[str] = field(default_factory=list)

    @property
    def eq2(self) -> bool:
        return bool(np.all(self.sum_rank == self.n))

    @property
    def by_switching(self) -> bool:
        return self.cross_rank is not None and bool(np.all(self.cross_rank == self.n))

    @property
    def controllable(self) -> bool:
        return self.eq2 or self.by_switching


def sequence_report(
    system: System, strata: Sequence[str], configurations: np.ndarray, degree: int = 2
) -> SequenceReport:
    Q = np.atleast_2d(np.asarray(configurations, dtype=float))
    names = list(dict.fromkeys(strata))

    def closures(R: np.ndarray) -> list[np.ndarray]:
        blocks = []
        for name in names:
            lb = lie_basis(system, name, degree)
            blocks.append(lb.full(R))
            free = list(lb.free)
            short = _rank_and_sigma(blocks[-1][:, free], len(free))[0] < len(free)
            if np.any(short) and degree < MAX_DEGREE and _can_escalate(system, name):  # eq. 4
                blocks.append(lie_basis(system, name, MAX_DEGREE).full(R))
        return blocks

    def summed(R: np.ndarray) -> tuple[np.ndarray]:
        return (_rank_and_sigma(np.concatenate(closures(R), axis=-1), system.n)[0],)

    (sum_rank,) = _rows(system, ("eq2", tuple(names), degree), Q, summed)
    report = SequenceReport(names, system.n, Q, sum_rank, None)
    if not report.eq2 and _cross_affordable(system, names, max(degree, 2)):
        cross = cross_basis(system, tuple(names), max(degree, 2))
        (report.cross_rank,) = _rows(
            system,
            ("cross", tuple(names), degree),
            Q,
            # the strata's own closures too (raised to degree 3 where one needed it): across
            # strata at degree 2 alone a URDF arm's rank was 3 where its S3 alone spans 5
            lambda R: (
                _rank_and_sigma(
                    np.concatenate([cross.evaluate(R), *closures(R)], axis=-1), system.n
                )[0],
            ),
        )
        report.cross_spanning = _spanning(cross.evaluate(Q[:1])[0], cross.labels)
    return report


# --------------------------------------------------------------------------------------------
# A scenario's legs
# --------------------------------------------------------------------------------------------


@dataclass
class LegReport:
    index: int
    stratum: str
    targets: tuple[int, ...]
    configuration: np.ndarray  # the leg's nominal start
    rank: int  # at the nominal start, on the targeted coordinates
    sigma: float
    failure: np.ndarray | None  # first configuration where the targets are not spanned
    failure_rank: int = 0
    failure_finite: bool = True  # whether the fields and brackets are numbers there
    failure_sampled: bool = False  # the failure is at a sample, not at the nominal start

    @property
    def ok(self) -> bool:
        return self.failure is None


def leg_reports(
    system: System, start: np.ndarray, legs, samples: np.ndarray, degree: int = 2
) -> list[LegReport]:
    """Each leg's stratum must span the coordinates the leg steers (at its nominal start and
    at the samples; third-order brackets where the degree falls short)."""
    out = []
    nominal = np.asarray(start, dtype=float).copy()
    for i, leg in enumerate(legs):
        s = system.stratum(leg.stratum)
        goal = np.asarray(leg.goal, dtype=float)
        targets = tuple(j for j in s.free(system.n) if not np.isnan(goal[j]))
        Q = np.vstack([nominal, samples]) if len(samples) else nominal[None]
        rank, sigma = _target_rank(system, s.name, targets, Q, degree)
        bad = np.flatnonzero(rank < len(targets))
        out.append(
            LegReport(
                i,
                s.name,
                targets,
                nominal.copy(),
                int(rank[0]),
                float(sigma[0]),
                Q[bad[0]].copy() if bad.size else None,
                int(rank[bad[0]]) if bad.size else 0,
                bool(np.isfinite(sigma[bad[0]])) if bad.size else True,
                bool(bad.size and bad[0] > 0),
            )
        )
        nominal = np.where(np.isnan(goal), nominal, goal)
    return out


def _target_rank(system, stratum, targets, Q, degree):
    lb = lie_basis(system, stratum, degree)
    rows = [lb.free.index(j) for j in targets]
    if not rows:
        return np.zeros(len(Q), dtype=int), np.ones(len(Q))

    def compute(R: np.ndarray) -> tuple[np.ndarray, ...]:
        with np.errstate(all="ignore"):  # a model that overflows: σ NaN (`_rank_and_sigma`)
            rank, sigma = _rank_and_sigma(lb.evaluate(R)[:, rows], len(rows))
            short = rank < len(rows)
            if np.any(short) and degree < MAX_DEGREE and _can_escalate(system, stratum):
                lb3 = lie_basis(system, stratum, MAX_DEGREE)
                r3, s3 = _rank_and_sigma(lb3.evaluate(R[short])[:, rows], len(rows))
                rank[short], sigma[short] = r3, s3
        return rank, sigma

    return _rows(system, ("leg", stratum, targets, degree), Q, compute)
