"""The honest peer: CasADi/IPOPT on exactly stratplan's energy problem, against stratplan.

Usage: python benchmarks/bench_peer.py [--seeded N] [--first-seed S] [--repeats R]
       [--search loops|starts|legwise] [SCENARIO ...]
       (needs the optional extra: pip install -e '.[bench]')

For each paper scenario, the problem the energy objective solves (`stratcli.planners.energy`),
written as one CasADi NLP and handed to IPOPT (exact Hessian of the Lagrangian by automatic
differentiation, MUMPS):

* variables: the same stacked Fourier coefficients λ of all legs (layout `(m_active, 2H+1)` per
  leg, H = the scenario's basis, 3 by default);
* linear equalities: the same continuity rows (`continuity.sequence_constraints`: lr-C1
  switches, soft start, full stop), not eliminated;
* nonlinear equalities: every leg reaches its via (the prescribed coordinates of its goal) from
  the previous leg's via, with the joints in closed form (`q_E(t) = q_E(0) + C L Ψ(t)`) and θ by
  the same composite Gauss–Legendre rule (`endpoint.gauss_legendre`; the node count of each leg
  is fixed for the NLP: the one stratplan's evaluator picks at stratplan's optimum, plus one
  panel of 32);
* objective: the energy λᵀMλ with stratplan's Gram matrices.

IPOPT starts (a) from stratplan's own starting plans (the Newton plans its multi-start begins
from, captured from a real run) and (b) from `--seeded` seeded coefficient vectors (random
Gaussian ones, and the Newton plan plus a Gaussian perturbation, alternately; 0.1 to 8 times
the Newton plan's RMS coefficient). Every IPOPT solution is re-checked with stratplan's own
end-point evaluator (adaptive quadrature): a solution counts only if it reaches every via
within 1e-8 and meets the continuity rows within 1e-9. Times are CPU seconds
(`time.process_time`): stratplan's whole energy objective (the Newton plans that make its
starts included; median of --repeats runs after a warm-up run) and IPOPT's solves (NLP
construction excluded and reported apart, as model compilation is for stratplan; the Newton
plans stratplan hands it are not charged to it).
"""

from __future__ import annotations

import os

# as the stratplan command does (stratcli/__main__.py): no BLAS threads for small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import platform
import statistics
import sys
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
import sympy as sp

try:
    import casadi as ca
except ImportError:  # optional extra `bench`
    ca = None

from casadi_baseline import machine, scenario_paths

import stratcli.objectives as objectives
from stratcli.continuity import sequence_constraints
from stratcli.endpoint import PANEL, gauss_legendre, make_endpoint, node_count
from stratcli.scenario import Task, load_scenario
from stratcli.settings import SEARCHES

SEEDED = 24
SCALES = (0.1, 0.5, 1.0, 2.0, 4.0, 8.0)
GOAL_CHECK = 1e-8  # a peer solution must reach every via this closely (stratplan's evaluator)
CONTINUITY_CHECK = 1e-9
IPOPT = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.tol": 1e-10,
    "ipopt.constr_viol_tol": 1e-10,
    "ipopt.max_iter": 3000,
    "ipopt.hessian_approximation": "exact",
    "ipopt.linear_solver": "mumps",
}


@dataclass
class Captured:
    """What `plan_with_objective` hands the energy search: the legs' nominal starts (the
    previous leg's via), targets and the stacked starting coefficients."""

    nominal: list
    targets: list
    seeds: list


def stratplan_run(task: Task, repeats: int, search: str | None = None):
    """stratplan's energy objective: (plan, median CPU s, captured starts); `search` replaces
    the scenario's (`PlannerSettings.search`) if given."""
    settings = replace(task.settings, objective="energy")
    if search is not None:
        settings = replace(settings, search=search)
    captured: list[Captured] = []
    original = objectives.optimise_energy

    def spy(system, starts, legs, settings, targets, seeds, *args, **kwargs):
        captured.append(Captured([np.array(s) for s in starts], targets, seeds))
        return original(system, starts, legs, settings, targets, seeds, *args, **kwargs)

    objectives.optimise_energy = spy
    try:
        plan = objectives.plan_sequence(task.system, task.start, task.legs, settings)
    finally:
        objectives.optimise_energy = original
    times = []
    for _ in range(repeats):
        clock = time.process_time()
        plan = objectives.plan_sequence(task.system, task.start, task.legs, settings)
        times.append(time.process_time() - clock)
    return plan, statistics.median(times), captured[0]


def _casadi_functions() -> dict:
    names = ("sin", "cos", "tan", "exp", "log", "sqrt", "tanh", "sinh", "cosh")
    out = {name: getattr(ca, name) for name in names}
    out["Abs"] = ca.fabs
    return out


class PeerProblem:
    """stratplan's energy problem of one task as a CasADi NLP (see the module docstring)."""

    def __init__(self, task: Task, captured: Captured, optimum: list[np.ndarray]):
        clock = time.process_time()
        system, settings = task.system, task.settings
        basis = settings.basis
        self.task, self.captured = task, captured
        self.legs = task.legs
        strata = [system.stratum(leg.stratum) for leg in self.legs]
        actives = [s.active for s in strata]
        durations = [float(leg.duration) for leg in self.legs]
        self.basis, self.actives, self.durations = basis, actives, durations
        sizes = [len(a) * basis.size for a in actives]
        self.offsets = np.cumsum([0, *sizes])
        P = int(self.offsets[-1])
        cons = sequence_constraints(
            basis,
            durations,
            actives,
            system.inputs,
            settings.continuity,
            soft_start=settings.soft_start,
            full_stop=settings.full_stop,
        )
        self.C_cont, self.c_cont = cons.C, cons.c
        self.M = scipy.linalg.block_diag(
            *[
                np.kron(np.eye(len(a)), basis.gram(T))
                for a, T in zip(actives, durations, strict=True)
            ]
        )
        self.compiled = [system.compiled(s) for s in strata]
        lam = ca.SX.sym("lam", P)
        g = [ca.mtimes(ca.DM(cons.C), lam) - ca.DM(cons.c)] if cons.C.shape[0] else []
        self.nodes = []
        for i, (stratum, cs) in enumerate(zip(strata, self.compiled, strict=True)):
            m, s = len(actives[i]), basis.size
            part = lam[int(self.offsets[i]) : int(self.offsets[i + 1])]
            L = ca.horzcat(*[part[a * s : (a + 1) * s] for a in range(m)]).T  # (m, s)
            q0 = np.asarray(captured.nominal[i], dtype=float)
            targets = np.asarray(captured.targets[i], dtype=int)
            # the node count stratplan's evaluator uses at stratplan's optimum, one panel more
            K = node_count(optimum[i].reshape(m, s), durations[i], basis) + PANEL
            self.nodes.append(K)
            t, w = gauss_legendre(K, durations[i])
            Phi, Psi = basis.values(t), basis.integrals(t)
            E, Q = list(cs.explicit), list(cs.quadrature)
            Cx = ca.DM(cs.C_explicit)
            end = [None] * system.n
            qE_end = ca.DM(q0[E]) + ca.mtimes(
                Cx, ca.mtimes(L, ca.DM(basis.integrals(durations[i])))
            )
            for r, e in enumerate(E):
                end[e] = qE_end[r]
            if Q:
                G = system.fields_on(stratum)
                rows = sp.lambdify(
                    system.symbols,
                    G.extract(Q, list(range(m))).tolist(),
                    modules=[_casadi_functions(), "math"],
                )
                U = ca.mtimes(ca.DM(Phi), L.T)  # (K, m)
                QE = ca.repmat(ca.DM(q0[E]).T, K, 1) + ca.mtimes(ca.DM(Psi), ca.mtimes(L.T, Cx.T))
                totals = [ca.SX(0.0) for _ in Q]
                for k in range(K):
                    q = [None] * system.n
                    for r, e in enumerate(E):
                        q[e] = QE[k, r]
                    for e in Q:
                        q[e] = float(q0[e])  # the quadrature rows depend on the joints only
                    values = rows(*q)
                    for r in range(len(Q)):
                        totals[r] += w[k] * sum(values[r][a] * U[k, a] for a in range(m))
                for r, e in enumerate(Q):
                    end[e] = q0[e] + totals[r]
            goal = np.asarray(self.legs[i].goal, dtype=float)
            g += [end[e] - goal[e] for e in targets]
        f = ca.mtimes([lam.T, ca.DM(self.M), lam])
        nlp = {"x": lam, "f": f, "g": ca.vertcat(*g)}
        self.functions = ca.Function("peer_fg", [lam], [f, ca.vertcat(*g)])
        self.solver = ca.nlpsol("peer", "ipopt", nlp, IPOPT)
        self.n_constraints = int(ca.vertcat(*g).shape[0])
        self.size = P
        self.build_seconds = time.process_time() - clock

    def solve(self, x0: np.ndarray) -> dict:
        clock = time.process_time()
        sol = self.solver(x0=x0, lbg=0.0, ubg=0.0)
        seconds = time.process_time() - clock
        stats = self.solver.stats()
        x = np.asarray(sol["x"]).ravel()
        return {
            "x": x,
            "energy": float(sol["f"]),
            "status": stats["return_status"],
            "iterations": int(stats["iter_count"]),
            "seconds": seconds,
            **self.check(x),
        }

    def check(self, lam: np.ndarray) -> dict:
        """Re-check with stratplan's evaluator (adaptive Gauss–Legendre): goal error (max over
        legs and targets), continuity residual, energy λᵀMλ; `valid` if within the checks."""
        errors = []
        for i, (leg, cs) in enumerate(zip(self.legs, self.compiled, strict=True)):
            ep = make_endpoint(cs, self.captured.nominal[i], self.basis, self.durations[i])
            part = lam[self.offsets[i] : self.offsets[i + 1]]
            with np.errstate(all="ignore"):
                end, _ = ep(part, jacobian=False)
            t = np.asarray(self.captured.targets[i], dtype=int)
            errors.append(float(np.abs(end[t] - np.asarray(leg.goal)[t]).max(initial=0.0)))
        goal_error = max(errors) if all(np.isfinite(errors)) else np.inf
        continuity = float(np.abs(self.C_cont @ lam - self.c_cont).max(initial=0.0))
        energy = float(lam @ self.M @ lam)
        valid = bool(goal_error <= GOAL_CHECK and continuity <= CONTINUITY_CHECK)
        return {
            "goal_error": goal_error,
            "continuity": continuity,
            "checked_energy": energy,
            "valid": valid,
        }


def seeded_starts(captured: Captured, count: int, first: int = 0) -> list[tuple[str, np.ndarray]]:
    """Seeded coefficient vectors: odd seeds Gaussian, even seeds the Newton plan plus a
    Gaussian perturbation; scaled by 0.1 to 8 times the Newton plan's RMS coefficient."""
    newton = np.asarray(captured.seeds[0][1], dtype=float)
    rms = float(np.sqrt(np.mean(newton**2)))
    out = []
    for k in range(first, first + count):
        rng = np.random.default_rng(k)
        noise = SCALES[k % len(SCALES)] * rms * rng.normal(size=newton.size)
        out.append((f"seed {k}", noise if k % 2 else newton + 0.3 * noise))
    return out


def best_valid(runs: list[dict]) -> dict | None:
    valid = [r for r in runs if r["valid"]]
    return min(valid, key=lambda r: r["checked_energy"]) if valid else None


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help="names or paths (default: the paper's)")
    parser.add_argument("--seeded", type=int, default=SEEDED, help="seeded random IPOPT starts")
    parser.add_argument("--first-seed", type=int, default=0, help="of the seeded starts")
    parser.add_argument("--repeats", type=int, default=5, help="stratplan runs timed")
    parser.add_argument(
        "--search",
        choices=SEARCHES,
        default=None,
        help="stratplan's energy search (default: the scenario's)",
    )
    args = parser.parse_args(argv)
    if ca is None:
        sys.exit("casadi is not installed: pip install -e '.[bench]'")
    print(f"$ python benchmarks/bench_peer.py {' '.join(argv or sys.argv[1:])}".rstrip())
    print(
        f"{machine()}, Python {platform.python_version()}, CasADi {ca.__version__} (IPOPT, exact "
        f"Hessian, MUMPS); CPU seconds; stratplan: median of {args.repeats} runs\n"
    )
    summary = []
    for path in scenario_paths(args.scenarios):
        task = load_scenario(path)
        plan, sp_seconds, captured = stratplan_run(task, args.repeats, args.search)
        peer = PeerProblem(task, captured, [leg.coefficients for leg in plan.legs])
        own = []
        for k, (kind, lam) in enumerate(captured.seeds):
            run = peer.solve(np.asarray(lam, dtype=float))
            run["start"] = f"stratplan {k} ({kind})"
            own.append(run)
        seeded = []
        for label, lam in seeded_starts(captured, args.seeded, args.first_seed):
            run = peer.solve(lam)
            run["start"] = label
            seeded.append(run)
        name = task.scenario.name
        # the same problem: at stratplan's optimum the NLP's energy is stratplan's and its
        # constraints hold
        f_opt, g_opt = peer.functions(
            np.concatenate([leg.coefficients.ravel() for leg in plan.legs])
        )
        print(
            f"### {name}: {peer.size} coefficients, {peer.n_constraints} equality constraints, "
            f"quadrature nodes per leg {peer.nodes}, NLP construction {peer.build_seconds:.2f} s; "
            f"at stratplan's optimum the NLP's energy is {float(f_opt):.6f} and its largest "
            f"constraint residual {float(np.abs(np.asarray(g_opt)).max()):.0e}"
        )
        print()
        print(
            "| solver | starts | valid | best energy | CPU s "
            "| energy ÷ stratplan | CPU ÷ stratplan |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|")
        e0 = plan.total_energy
        print(
            f"| stratplan (energy objective) | {len(captured.seeds)} | "
            f"{'1' if plan.ok else '0'} | {e0:.2f} | {sp_seconds:.3f} | 1 | 1 |"
        )
        rows = {}
        for label, runs in (
            ("IPOPT from stratplan's starts", own),
            (f"IPOPT from {args.seeded} seeded starts", seeded),
            ("IPOPT, all starts", own + seeded),
        ):
            best = best_valid(runs)
            seconds = sum(r["seconds"] for r in runs)
            energy = best["checked_energy"] if best else float("nan")
            rows[label] = (energy, seconds, best)
            print(
                f"| {label} | {len(runs)} | {sum(r['valid'] for r in runs)} | "
                f"{energy:.2f} | {seconds:.3f} | {energy / e0:.4f} | {seconds / sp_seconds:.1f} |"
            )
        best = rows["IPOPT, all starts"][2]
        if best is not None:
            print(
                f"\nIPOPT's best: start {best['start']}, {best['iterations']} iterations, "
                f"{best['seconds']:.3f} s, goal error {best['goal_error']:.1e} "
                f"(stratplan's evaluator), NLP energy {best['energy']:.4f}"
            )
        minima = sorted({round(r["checked_energy"], 2) for r in own + seeded if r["valid"]})
        print(f"distinct valid minima: {', '.join(f'{e:.2f}' for e in minima[:12])}")
        failures = [r for r in own + seeded if not r["valid"]]
        if failures:
            print(
                "failed the re-check (IPOPT status, NLP energy, goal error): "
                + "; ".join(
                    f"{r['status']} {r['energy']:.2f} {r['goal_error']:.0e}" for r in failures
                )
            )
        print(flush=True)
        summary.append((name, e0, sp_seconds, rows))
    print("### Summary (CPU seconds; energy ÷: IPOPT's best valid energy over stratplan's)\n")
    print(
        "| scenario | stratplan energy | stratplan s | IPOPT from stratplan's starts | s "
        f"| CPU ÷ stratplan | energy ÷ | IPOPT from {args.seeded} seeded starts | s "
        "| energy ÷ |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, e0, seconds, rows in summary:
        own = rows["IPOPT from stratplan's starts"]
        seed = next(v for k, v in rows.items() if "seeded" in k)
        print(
            f"| {name} | {e0:.2f} | {seconds:.3f} | {own[0]:.2f} | {own[1]:.2f} "
            f"| {own[1] / seconds:.1f} | {own[0] / e0:.4f} | {seed[0]:.2f} | {seed[1]:.2f} "
            f"| {seed[0] / e0:.4f} |"
        )


if __name__ == "__main__":
    main()
