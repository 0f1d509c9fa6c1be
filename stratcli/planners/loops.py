"""The loop starts of the energy search: a leg's loop moved onto a peak of the base's curvature.

On a stratum whose two inputs each drive one joint, a leg turns the base by the integral of
the connection's curvature F over the area its joints' path encloses, counted with the
path's winding number (`stratcli.curvature`). The stacked problem's minima differ in how
their loops use F, and local descent cannot change a loop's winding: from the Newton plan's
basin the search may end with one large loop over a region where F changes sign, where a
smaller loop run twice round the nearest peak of |F| costs less (Sim 4 task A's second leg:
440.9 against 391.5; Sim 1 l-C1's: 302.5 against 251.8). So, from the search's minimum,
for each leg on such a stratum whose goal fixes the base (`loop_starts`):

1. **Peaks**: the local maxima of |F| on a grid of `GRID` x `GRID` points over a window of
   ±`WINDOW` rad round the middle of the leg's joint segment (one evaluation of the
   connection's derivatives); the `PEAKS` nearest to that middle are kept.
2. **Paths**: for each peak, 1 or 2 turns (`TURNS`) in either sense, a *lollipop* at
   constant speed: straight from the leg's start to the circle of radius ρ about the peak,
   round it, straight to the leg's end. ρ is the smallest of `RADII` at which the path turns
   the base by the leg's goal (interpolated between the scanned radii); the path's energy
   is L²/T (constant speed is the least for a given path).
3. **Starts**: paths whose energy is below `SCREEN` times the leg's energy at the minimum
   are fitted by the leg's controls (least squares on the path at `FIT_NODES` times, every
   other coefficient held near the minimum) and brought onto the goals, lowest path energy
   first; each leg's first that gets there is a start (a leg whose loop is dear is not
   crowded out by a cheap leg's). The energy search races them after its own starts, against
   the minima those reached (`energy.optimise_energy`, kind "loop"), and keeps one only if it
   ends lower.

Steps 1-2 cost a few milliseconds a leg and most legs offer no path below the screen, so
the starts are raced only where a different winding is likely to pay.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..curvature import curvature, driven
from .base import onto_goals
from .legwise import BROKE_DOWN  # numbers that break down make no loop start either

GRID = 40  # points per driven joint in the peaks' window
WINDOW = 1.25 * math.pi  # half-width of that window, rad (a little over a period of a joint)
PEAK_FLOOR = 0.25  # peaks below this fraction of the window's largest |F| are ignored
PEAKS = 3  # peaks tried per leg, nearest first
TURNS = (1, 2)
RADII = np.linspace(0.1, 2.5, 13)  # scanned loop radii, rad
PATH_NODES = 64  # points along a path for its turn of the base and its length
# A path is a start if its energy is below SCREEN times the leg's at the minimum. A lollipop
# costs more than the minimum it leads to (Sim 4 A: 1.22x, Sim 1 l-C1 1.25x), and auto mode's
# leg bounds (legs planned alone) must reach the minima the sequences' searches do: with 1.25,
# a loose bound of a random task (`bench_screen.py`, seed 9) missed the lower minimum that a
# path at 1.27x the leg's energy leads to.
SCREEN = 1.5
FIT_NODES = 48  # times at which the leg's controls are fitted to the path
HOLD = 1e-3  # weight (relative) holding the other coefficients at the minimum in the fit
RESTORED, RESTORE_ITERATIONS = 1e-6, 10  # loosely: the race restores to rounding


# why a search made no loop start (`loop_starts`; result.json `optimisation.no_loop_start`)
NO_LEG = "no leg has two inputs that each drive one joint and a goal that fixes the base"
NO_PATH = (  # (none turns it far enough at a scanned radius, or those that do are too dear)
    "no loop round a spot where the base turns fastest turns it far enough for under "
    f"{SCREEN:g}x its leg's energy"
)
NOT_FITTED = "no loop cheap enough could be fitted onto the goals"
NOT_NUMBERS = "the loop geometry broke down numerically"


def loop_starts(problem, z: np.ndarray) -> tuple[list[np.ndarray], str]:
    """Loop starts (whitened z of `problem`) from its minimum `z` (module docstring), and
    why there are none ("" where there are): no leg qualifies (`NO_LEG`), no path passes the
    screen (`NO_PATH`), none was fitted onto the goals (`NOT_FITTED`) or the numbers broke
    down (`NOT_NUMBERS`)."""
    try:
        with np.errstate(all="ignore"):
            legs = list(_legs(problem))
            if not legs:
                return [], NO_LEG
            paths = sorted(_paths(problem, z, legs), key=lambda p: p[0])
            out = []
            for i in sorted({p[1] for p in paths}):  # per leg: its cheapest path that restores
                starts = (_fitted(problem, z, *p[1:]) for p in paths if p[1] == i)
                out += itertools.islice((s for s in starts if s is not None), 1)
            return out, "" if out else (NOT_FITTED if paths else NO_PATH)
    except BROKE_DOWN:
        return [], NOT_NUMBERS


def _legs(problem):
    """(index, end-point map, driven inputs) of each leg a loop start applies to: its
    stratum's two inputs each drive one joint and its goal fixes the base's one quadrature
    coordinate."""
    for i, ep in enumerate(problem.endpoints):
        cs = ep.cs
        inputs = driven(cs) if getattr(cs, "quadrature_terms", None) is not None else None
        if inputs is None or len(cs.quadrature) != 1 or cs.quadrature[0] not in problem.targets[i]:
            continue
        yield i, ep, inputs


def _paths(problem, z: np.ndarray, legs):
    """(energy, leg index, joints, path as a function of s) of every path under the screen,
    on `legs` (`_legs`)."""
    parts = problem.split(problem.coefficients(z))
    for i, ep, inputs in legs:
        cs = ep.cs
        a, b = problem.offsets[i], problem.offsets[i + 1]
        energy = float(parts[i] @ problem.M[a:b, a:b] @ parts[i])
        q_s, q_e = ep.q0, ep(parts[i], False)[0]
        joints = [j for j, _ in inputs]
        start, end = q_s[joints], q_e[joints]
        # a lollipop about c is no shorter than |start - c| + |c - end| (it goes round c at
        # least once): peaks farther than that from the leg's ends cannot pass the screen
        reach = np.sqrt(SCREEN * energy * ep.duration)
        shapes = [
            (centre, turns, sense)
            for centre in _peaks(cs, q_s, inputs, 0.5 * (start + end))
            if np.linalg.norm(start - centre) + np.linalg.norm(end - centre) < reach
            for turns in TURNS
            for sense in (1.0, -1.0)
        ]
        if not shapes:
            continue
        # every shape at every scanned radius, the base's turn along each in one evaluation
        s = np.linspace(0.0, 1.0, PATH_NODES)
        centres, turns, senses = (np.array(v) for v in zip(*shapes, strict=True))
        paths = lollipop(start, end, centres, turns, senses, RADII, s)
        base = cs.quadrature[0]
        miss = _turns(cs, q_s, inputs, paths) - (q_e[base] - q_s[base])  # (shapes, radii)
        for shape, row in zip(shapes, miss, strict=True):
            # (a radius where the connection is not finite is no crossing)
            finite = np.isfinite(row[:-1]) & np.isfinite(row[1:])
            crossing = np.flatnonzero(finite & (np.sign(row[:-1]) != np.sign(row[1:])))
            if crossing.size == 0:
                continue
            k = crossing[0]  # the smallest radius that turns the base far enough
            radius = RADII[k] + (RADII[k + 1] - RADII[k]) * row[k] / (row[k] - row[k + 1])
            cost = _length(start, end, *shape, radius) ** 2 / ep.duration
            if cost < SCREEN * energy:
                yield cost, i, joints, _curve(start, end, shape, radius)


def _curve(start, end, shape, radius):
    """The lollipop of `shape` (centre, turns, sense) and `radius` as a function of s."""
    return lambda s: lollipop(start, end, *shape, np.array([radius]), s)[0, 0]


def _peaks(cs, q_s: np.ndarray, inputs, middle: np.ndarray) -> list[np.ndarray]:
    """The `PEAKS` local maxima of |F| in the window round `middle`, nearest first."""
    axis = np.linspace(-WINDOW, WINDOW, GRID)
    g0, g1 = np.meshgrid(middle[0] + axis, middle[1] + axis, indexing="ij")
    q = np.repeat(q_s[None, :], GRID * GRID, axis=0)
    q[:, inputs[0][0]], q[:, inputs[1][0]] = g0.ravel(), g1.ravel()
    F = np.abs(curvature(cs, q, inputs, 0)[0]).reshape(GRID, GRID)
    if not np.isfinite(F).all() or not F.max() > 0:
        return []
    inner = F[1:-1, 1:-1]
    peak = inner >= PEAK_FLOOR * F.max()
    for d0 in (-1, 0, 1):
        for d1 in (-1, 0, 1):
            if d0 or d1:
                peak &= inner >= F[1 + d0 : GRID - 1 + d0, 1 + d1 : GRID - 1 + d1]
    found = np.argwhere(peak) + 1
    centres = np.stack([g0[tuple(found.T)], g1[tuple(found.T)]], axis=1)
    order = np.argsort(np.linalg.norm(centres - middle, axis=1))
    return list(centres[order[:PEAKS]])


def _entry(start, end, centres, radii):
    """Where lollipops about `centres` (S, 2) of `radii` (R,) meet their circles (the point
    nearest the middle of start and end), (S, R, 2), and the angles there (S, 1, 1)."""
    d = 0.5 * (start + end) - centres
    a0 = np.arctan2(d[:, 1], d[:, 0])[:, None, None]
    ray = np.stack([np.cos(a0), np.sin(a0)], axis=-1)[:, :, 0, :]  # (S, 1, 2)
    return centres[:, None, :] + radii[None, :, None] * ray, a0


def _length(start, end, centre, turns, sense, radius) -> float:
    """The length of the lollipop (`lollipop`) of one shape and radius."""
    entry = _entry(start, end, centre[None, :], np.array([radius]))[0][0, 0]
    loop = 2.0 * math.pi * radius * turns
    return float(np.hypot(*(entry - start)) + loop + np.hypot(*(end - entry)))


def lollipop(start, end, centres, turns, senses, radii, s) -> np.ndarray:
    """Points (S, R, K, 2) at fractions `s` (K,) of constant-speed paths, per shape (a
    centre, a number of turns, a sense: +1 counter-clockwise; S of each) and radius (R):
    straight from `start` to the circle of that radius about the centre (its point nearest
    the middle of start and end), that many turns round it, straight to `end`."""
    centres = np.atleast_2d(centres)
    turns, senses = (np.reshape(v, (-1, 1, 1)) for v in (turns, senses))
    radii = np.asarray(radii, dtype=float)
    entry, a0 = _entry(start, end, centres, radii)  # (S, R, 2), (S, 1, 1)
    r = radii[None, :, None]
    l1 = np.linalg.norm(entry - start, axis=-1)[..., None]  # (S, R, 1)
    l2 = np.linalg.norm(end - entry, axis=-1)[..., None]
    lc = 2.0 * math.pi * r * turns
    x = np.asarray(s, dtype=float) * (l1 + lc + l2)  # (S, R, K)
    into = np.clip(x / np.maximum(l1, 1e-12), 0.0, 1.0)[..., None]
    back = np.clip((x - l1 - lc) / np.maximum(l2, 1e-12), 0.0, 1.0)[..., None]
    angle = a0 + senses * np.clip(x - l1, 0.0, lc) / r
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    circle = centres[:, None, None, :] + r[..., None] * ring
    e = entry[:, :, None, :]
    out = np.where((x <= l1)[..., None], start + into * (e - start), circle)
    return np.where((x > l1 + lc)[..., None], e + back * (end - e), out)


def _turns(cs, q_s, inputs, paths: np.ndarray) -> np.ndarray:
    """The base's turn along each of `paths` (..., K points, 2 joints), by the trapezoid
    rule (a path's parametrisation does not change it)."""
    shape, K = paths.shape[:-2], paths.shape[-2]
    flat = paths.reshape(-1, K, 2)
    q = np.repeat(q_s[None, :], flat.shape[0] * K, axis=0)
    for c, (j, _) in enumerate(inputs):
        q[:, j] = flat[..., c].ravel()
    (A,) = cs.quadrature_terms(q, 0)
    w = np.diff(flat, axis=1) * np.array([sign for _, sign in inputs])  # the inputs' integrals
    A = A[:, 0, :].reshape(-1, K, 2)
    return np.einsum("pka,pka->p", 0.5 * (A[:, 1:] + A[:, :-1]), w).reshape(shape)


def _fitted(problem, z: np.ndarray, i: int, joints, path) -> np.ndarray | None:
    """Whitened z whose leg `i` moves its driven `joints` along `path` (least squares at
    `FIT_NODES` times; the other coefficients held near `z`), on the goals, or None."""
    ep = problem.endpoints[i]
    a, b = problem.offsets[i], problem.offsets[i + 1]
    t = np.linspace(0.0, ep.duration, FIT_NODES)
    Psi = ep.basis.integrals(t)  # q_E(t) = q0_E + Ψ(t) Lᵀ Cᵀ, L = λ_i as (inputs, size)
    rows = [list(ep.cs.explicit).index(j) for j in joints]
    A = np.vstack([np.kron(ep.cs.C_explicit[r], Psi) for r in rows])  # in λ_i
    target = np.concatenate((path(t / ep.duration) - ep.q0[joints]).T)
    Az = A @ problem.null[a:b]
    rhs = target - A @ problem.coefficients(np.zeros_like(z))[a:b]
    hold = HOLD * np.linalg.norm(Az, 2)
    fit = np.linalg.lstsq(
        np.vstack([Az, hold * np.eye(z.size)]), np.concatenate([rhs, hold * z]), rcond=None
    )[0]
    return onto_goals(problem._evaluate, fit, RESTORED, RESTORE_ITERATIONS)
