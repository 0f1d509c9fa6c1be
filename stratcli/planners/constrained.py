"""Planning within joint limits, self-collision and obstacles, along the whole of every leg.

Both objectives search the stacked problem of the energy objective (`stacked.StackedProblem`: all
legs' coefficients, continuity eliminated, every iterate restored onto the goals by Newton
steps of least energy norm) with the node margins g(z) ≥ 0 of `node_margins` (joint limits
exact, clearances as signed distances, at 128 nodes a leg, less a cushion). URDF robots'
legs (joint limits only: their joints are closed-form, the attitude on SO(3) is a goal) are
searched alike, the goals' curvature estimated (`sqp.Descent.goal_curvature`).

Each start is a `margin_search.MarginSearch`: its phases 1 (onto the margins) and 2 (least
energy inside them) are described there. Then, **between the nodes**, a dense check (`DENSE`
samples a leg) adds nodes where a margin dips below a quarter of the cushion, and the search
goes on (`REFINEMENTS` times), the last time without lowering the energy again: lowering leaves
the contacts on the limits at the nodes, and on a random task they slid to new dips between the
nodes pass after pass (the start was dropped after 6.6 s, the next one got inside at 1346.20;
its plan of the last pass, moved inside by phase 1 only, is 999.10). Such a plan is kept beside
the other starts' (`Searched.kept`), which often end lower: auto mode's (S1, S3) under ±2.5 rad
keeps 247.96 from its first start that way, and the next start ends at 146.90.

A search that cannot make every margin positive says which limit on which leg it stalled on
(`MarginSearch.stalled`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..endpoint import QuadratureEndpoint
from ..magnus import MagnusEndpoint
from ..node_margins import CUSHION, NodeMargins
from .margin_search import REACH, MarginSearch
from .stacked import StackedProblem

__all__ = ["NotSearchable", "Searched", "constrained_search"]


class NotSearchable(Exception):
    """The legs' joints are not closed-form (ODE-path legs), or a URDF robot's legs have
    limits on more than its joints: the search does not apply (the limits are verified)."""


REFINEMENTS = 6  # passes that add nodes where a dense check finds a margin below zero
LAST_PASS = (  # the note of a plan whose last pass kept it inside without lowering it
    "each of the constrained search's first {} passes dipped below a limit between its "
    "nodes; the next and last kept its plan moved inside them, without lowering its energy"
)
DENSE = 1000  # samples a leg of that check


def _searchable(problem: StackedProblem, constraints) -> bool:
    """Whether the search applies: quadrature legs (joints in closed form, θ by quadrature),
    or legs whose joints are closed-form and the only limits (URDF robots, `MagnusEndpoint`:
    joint limits are affine in the coefficients; the goals' curvature is estimated)."""
    if all(isinstance(ep, QuadratureEndpoint) for ep in problem.endpoints):
        return True
    limited = np.flatnonzero(np.isfinite(constraints.lower) | np.isfinite(constraints.upper))
    return not constraints.geometric and all(
        isinstance(ep, MagnusEndpoint) and np.isin(limited, ep.E).all() for ep in problem.endpoints
    )


class Searched(NamedTuple):
    """What `constrained_search` found."""

    coefficients: list | None  # per leg; None where no start got inside, or none was needed
    notes: list[str]
    stalled: str  # the stall message of the last start tried ("" where one got inside)
    energy: float  # the plan's, or NaN
    iterations: int  # of the search that found it, over all legs together, or 0
    kept: bool = False  # its last pass's plan, kept inside without lowering (`LAST_PASS`)


def constrained_search(
    system, starts, legs, settings, targets, seeds, constraints, lower_energy: bool, first=True
) -> Searched:
    """Coefficients within the limits at every node, from the first of `seeds` (stacked
    coefficients reaching the goals) that leads to a feasible plan (`Searched`); no
    coefficients and no stall when the first seed is inside the limits already and `first`
    (the plan as planned: then it is the constrained minimum as well). With `lower_energy`
    (the energy objective) the feasible plan's energy is then lowered inside the limits
    (`_Search.lower`).
    """
    problem = StackedProblem(system, starts, legs, settings, targets)
    if not _searchable(problem, constraints):
        raise NotSearchable
    margins = NodeMargins(problem, system, constraints, reach=REACH + CUSHION)
    stalled = ""
    z = problem.project(seeds[0][1])
    g = margins(z, jacobian=False)[0]
    if first and (g.size == 0 or g.min() >= 0) and margins.refined(z, DENSE) is None:
        return Searched(
            None, ["inside the limits already: no constrained search needed"], "", np.nan, 0
        )
    for kind, lam in seeds:
        with np.errstate(all="ignore"):
            search = MarginSearch(problem, margins, problem.project(lam), settings.tolerance)
            found, kept = np.nan, False
            for refinement in range(REFINEMENTS + 1):
                if not search.reach_feasible():
                    break
                if np.isnan(found):
                    found = search.energy
                if lower_energy and refinement < REFINEMENTS:  # (the last: inside is enough)
                    search.lower(lead_in=refinement == 0)
                    if not search.inside() and not search.reach_feasible():
                        break  # (the SQP's last iterate outside: back inside by its phase 1)
                finer = search.margins.refined(search.z, DENSE)
                if finer is None:
                    kept = lower_energy and refinement == REFINEMENTS
                    break
                search.margins = finer  # and again, with nodes where it dipped in between
            else:
                search.stalled = (
                    "the constrained search kept dipping below a margin between its nodes"
                )
            if search.stalled:
                stalled = search.stalled
                continue
        nodes = sum(len(leg.t) for leg in search.margins.legs)
        notes = [search_note(kind, nodes, search.iterations, found, search.energy, lower_energy)]
        if kept:
            notes.append(LAST_PASS.format(REFINEMENTS))
        coefficients = problem.split(problem.coefficients(search.z))
        return Searched(coefficients, notes, "", search.energy, search.iterations, kept)
    return Searched(None, [], stalled, np.nan, 0)


def search_note(kind: str, nodes: int, iterations: int, found: float, final: float, lowered: bool):
    """The plan's note on its constrained search: from which plan, at how many nodes, the
    energy of the first plan within the limits and the final one: lowered inside them (the
    energy objective: `lowered`), or higher where nodes added between dips cost more than the
    SQP won, or (the Newton objective) moved by the search again from those nodes."""
    moved = abs(final - found) > 1e-9 * max(abs(found), 1.0)
    energy = f"energy {found:.6g} when {'first ' if lowered or moved else ''}within the limits"
    if lowered and final <= found:
        energy += f", lowered to {final:.6g} inside them"
    elif lowered or moved:
        energy += (
            f", {'raised' if final > found else 'moved'} to {final:.6g} by the nodes added "
            "where a plan dipped below a limit between them"
        )
    return (
        f"constrained search from the {kind} plan ({iterations} iterations in all, the limits "
        f"checked at {nodes} nodes): {energy} (at the speed planned, before any time scaling)"
    )
