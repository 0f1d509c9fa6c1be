"""The physical lower bound on energy: each leg sequence as a direct-collocation OCP (CasADi).

Usage: python benchmarks/casadi_baseline.py [--nodes N] [--starts K] [--without-conditions]
       [SCENARIO ...]          (needs the optional extra: pip install -e '.[bench]')

For a scenario's leg sequence, minimise ∫ Σ u² dt over *free* controls (no Fourier basis) with
the same dynamics `q' = G(q) u` (only the stratum's active inputs on each leg, the others
identically zero), the same leg durations, the same boundary configurations (every leg starts
where the previous one ended and reaches its prescribed goal coordinates) and the same control
boundary conditions as stratplan (DESIGN §3): at a switch, inputs active on the next leg start
at the previous leg's end value (and derivative, for C1), or at 0 if the previous leg did not
use them; `lr-*` also ends the inputs the next leg does not use at 0 (and derivative 0); soft
start / full stop ask u = u' = 0 at the very start / end.

Discretisation: per leg, the states (q, u) are collocated with Legendre-Radau polynomials of
degree 3 on N intervals; the control is u's increment over each interval, so u is continuous
and piecewise linear (the energy quadrature is exact) and its one-sided derivatives exist at
every switch. The mesh is graded towards the ends of each leg (Chebyshev points).

Why graded: point conditions on the controls cost no energy in the continuous limit (a control
can be brought to any value in a vanishing time at vanishing energy), so the bound's infimum is
the same with and without them; on a mesh the conditions cost a boundary layer about one
interval wide, O(h) in energy: 0.5-1 % at N = 40 on a uniform mesh, < 0.1 % graded.

Local minima are many (energies from one start vary by 2-5x), so IPOPT (exact Hessian, MUMPS)
solves from `starts` deterministic guesses on a coarse mesh, without the control conditions,
and refines the best few with them; the best
local optimum is the bound, an upper estimate of the true global infimum. Each bound is checked
by re-integrating its controls with scipy's `solve_ivp` (DOP853) on stratplan's own numpy
vector fields, legs chained.
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

try:
    import casadi as ca
except ImportError:  # optional extra `bench`
    ca = None

from stratcli.continuity import mode_order
from stratcli.scenario import Task, load_scenario

ROOT = Path(__file__).resolve().parents[1]
PAPER_SCENARIOS = (
    "sim1_l_c1",
    "sim1_lr_c1",
    "sim2",
    "sim2_soft",
    "sim4_task_a",
    "sim4_task_b",
    "sim4_task_c",
    "sim4_task_d",
)
DEGREE = 3  # Legendre-Radau collocation degree
NODES = 40  # intervals per leg (graded mesh)
COARSE_NODES = 12  # intervals per leg for the multi-start
STARTS = 24  # deterministic initial guesses, solved on the coarse mesh
REFINE = 3  # best distinct coarse optima solved again on the full mesh
IPOPT = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.tol": 1e-10,
    "ipopt.max_iter": 3000,
}


def casadi_available() -> bool:
    return ca is not None


def _casadi_functions() -> dict:
    names = ("sin", "cos", "tan", "exp", "log", "sqrt", "tanh", "sinh", "cosh")
    names += ("asin", "acos", "atan", "atan2")
    out = {name: getattr(ca, name) for name in names}
    out["Abs"] = ca.fabs
    return out


def _fields(system, stratum) -> ca.Function:
    """`G(q)` of a stratum's active inputs as a CasADi function (sympy → casadi via lambdify)."""
    G = system.fields_on(stratum)
    func = sp.lambdify(system.symbols, G.tolist(), modules=[_casadi_functions(), "math"])
    q = ca.SX.sym("q", system.n)
    rows = func(*[q[i] for i in range(system.n)])
    return ca.Function(f"G_{stratum.name}", [q], [ca.vertcat(*[ca.horzcat(*r) for r in rows])])


def _radau(degree: int):
    """Collocation points τ (with τ0 = 0), derivative matrix C and quadrature weights B."""
    tau = np.append(0.0, ca.collocation_points(degree, "radau"))
    C = np.zeros((degree + 1, degree + 1))
    B = np.zeros(degree + 1)
    for j in range(degree + 1):
        p = np.poly1d([1.0])
        for r in range(degree + 1):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        dp = np.polyder(p)
        for r in range(degree + 1):
            C[j, r] = dp(tau[r])
        B[j] = np.polyint(p)(1.0)
    return tau, C, B


class _Leg:
    def __init__(self, task: Task, index: int):
        system = task.system
        spec = task.legs[index]
        self.stratum = system.stratum(spec.stratum)
        self.active = self.stratum.active
        self.m = len(self.active)
        self.duration = float(spec.duration)
        self.goal = np.asarray(spec.goal, dtype=float)
        free = self.stratum.free(system.n)
        self.targets = [i for i in free if not np.isnan(self.goal[i])]
        self.G = _fields(system, self.stratum)
        self.G_numpy = system.compiled(self.stratum).G  # stratplan's own, for the re-check


def mesh(nodes: int, kind: str = "graded") -> np.ndarray:
    """Interval lengths as fractions of a leg: uniform, or graded towards both ends (Chebyshev
    points, smallest interval ≈ 2.5/N²) to resolve the boundary layers of the control
    conditions."""
    if kind == "uniform":
        return np.full(nodes, 1.0 / nodes)
    if kind != "graded":
        raise ValueError(f"unknown mesh {kind!r}")
    return np.diff(0.5 * (1.0 - np.cos(np.pi * np.arange(nodes + 1) / nodes)))


class _Collocation:
    """The whole sequence as one NLP; variables laid out leg by leg.

    Per leg: states x = (q, u) (all n coordinates, the stratum's active inputs), collocated
    on every interval; per interval one control variable, the increment `du` of u over it
    (u' = du/h is constant on the interval, so u is continuous and piecewise linear and its
    one-sided derivatives u'(0+) and u'(T-) exist at every switch).
    """

    def __init__(self, task: Task, nodes: int, kind: str = "graded", conditions: bool = True):
        self.task = task
        self.nodes = nodes
        self.kind = kind
        self.degree = DEGREE
        self.n = task.system.n
        self.legs = [_Leg(task, i) for i in range(len(task.legs))]
        tau, C, B = _radau(DEGREE)
        self.tau = tau
        settings = task.settings
        order = mode_order(settings.continuity) if conditions else -1
        lr = conditions and settings.continuity.startswith("lr")
        soft = conditions and settings.soft_start
        stop = conditions and settings.full_stop
        w_all, g_all, self.layout = [], [], []
        J = 0
        offset = 0

        def var(name, size):
            nonlocal offset
            v = ca.SX.sym(name, size)
            w_all.append(v)
            offset += size
            return v, offset - size

        m_all = task.system.m
        previous = None  # q, then u and u' of all m inputs at the previous leg's end
        for i, leg in enumerate(self.legs):
            nx = self.n + leg.m
            steps = leg.duration * mesh(nodes, kind)
            X0, x0_at = var(f"X{i}_0", nx)
            entry = {"x0": x0_at, "colloc": [], "du": [], "h": steps}
            q0, u0 = X0[: self.n], X0[self.n :]
            dus, Xk = [], X0
            for k in range(nodes):
                dU, du_at = var(f"dU{i}_{k}", leg.m)
                Xc, xc_at = var(f"Xc{i}_{k}", nx * DEGREE)
                entry["du"].append(du_at)
                entry["colloc"].append(xc_at)
                dus.append(dU)
                h = steps[k]
                points = [Xk] + [Xc[j * nx : (j + 1) * nx] for j in range(DEGREE)]
                for j in range(1, DEGREE + 1):
                    xp = sum(C[r, j] * points[r] for r in range(DEGREE + 1))
                    q, u = points[j][: self.n], points[j][self.n :]
                    g_all.append(h * (leg.G(q) @ u) - xp[: self.n])
                    g_all.append(dU - xp[self.n :])  # u' = dU/h
                    J = J + B[j] * h * ca.sumsqr(u)
                Xk = points[DEGREE]
            q1, u1 = Xk[: self.n], Xk[self.n :]
            # leg start: configuration and control conditions
            g_all.append(q0 - (np.asarray(task.start, dtype=float) if i == 0 else previous[0]))
            for a, k in enumerate(leg.active):
                if i == 0:
                    if soft:
                        g_all += [u0[a], dus[0][a]]
                elif order >= 0:
                    g_all.append(u0[a] - previous[1][k])
                    if order >= 1:
                        g_all.append(dus[0][a] - steps[0] * previous[2][k])
            # leg end: goal and control conditions
            if leg.targets:
                g_all.append(q1[leg.targets] - leg.goal[leg.targets])
            last = i + 1 == len(self.legs)
            for a, k in enumerate(leg.active):
                if last and stop:
                    g_all += [u1[a], dus[-1][a]]
                elif not last and lr and k not in self.legs[i + 1].active:
                    g_all.append(u1[a])
                    if order >= 1:
                        g_all.append(dus[-1][a])
            u_end, du_end = [0.0] * m_all, [0.0] * m_all
            for a, k in enumerate(leg.active):
                u_end[k], du_end[k] = u1[a], dus[-1][a] / steps[-1]
            previous = (q1, u_end, du_end)
            self.layout.append(entry)
        self.size = offset
        g = ca.vertcat(*g_all)
        self.n_constraints = g.shape[0]
        nlp = {"x": ca.vertcat(*w_all), "f": J, "g": g}
        self.solver = ca.nlpsol("bound", "ipopt", nlp, IPOPT)

    # -- layout ---------------------------------------------------------------------------
    def unpack(self, x: np.ndarray) -> list[dict]:
        """Per leg: mesh times (N+1,), states at them (N+1, nx), collocation states (N, d, nx)."""
        out = []
        for leg, entry in zip(self.legs, self.layout, strict=True):
            nx = self.n + leg.m
            colloc = np.array([x[a : a + nx * DEGREE] for a in entry["colloc"]])
            colloc = colloc.reshape(self.nodes, DEGREE, nx)
            X = np.vstack([x[entry["x0"] : entry["x0"] + nx], colloc[:, -1, :]])
            times = np.concatenate([[0.0], np.cumsum(entry["h"])])
            out.append({"t": times, "X": X, "colloc": colloc})
        return out

    def pack(self, states) -> np.ndarray:
        """Variables from per-leg state functions states(i, t) -> (q, u) of shape (nx,)."""
        x = np.zeros(self.size)
        for i, (leg, entry) in enumerate(zip(self.legs, self.layout, strict=True)):
            nx = self.n + leg.m
            t = 0.0
            x[entry["x0"] : entry["x0"] + nx] = states(i, 0.0)
            for k, h in enumerate(entry["h"]):
                colloc = np.array([states(i, t + h * s) for s in self.tau[1:]])
                x[entry["colloc"][k] : entry["colloc"][k] + nx * DEGREE] = colloc.ravel()
                u0 = states(i, t)[self.n :]
                x[entry["du"][k] : entry["du"][k] + leg.m] = colloc[-1, self.n :] - u0
                t += h
        return x

    def guess(self, kind: str, seed: int = 0) -> np.ndarray:
        """Deterministic initial guesses: configurations interpolated linearly between the
        boundary configurations; controls zero ("zero"), the least-squares constant velocity
        ("ramp"), or that plus a seeded smooth perturbation ("perturbed")."""
        rng = np.random.default_rng(seed)
        configs = [np.asarray(self.task.start, dtype=float)]
        for leg in self.legs:
            configs.append(np.where(np.isnan(leg.goal), configs[-1], leg.goal))
        profiles = []
        for i, leg in enumerate(self.legs):
            a, b = configs[i], configs[i + 1]
            u = np.zeros(leg.m)
            if kind != "zero":
                G = np.asarray(leg.G(0.5 * (a + b)))
                u = np.linalg.lstsq(G, (b - a) / leg.duration, rcond=None)[0]
            scale = (0.5, 2.0, 4.0)[seed % 3] * max(1.0, float(np.abs(u).max(initial=0.0)))
            amp = rng.normal(size=(leg.m, 3)) * scale
            if kind != "perturbed":
                amp[:] = 0.0
            profiles.append((a, b, u, amp))

        def states(i, t):
            a, b, u, amp = profiles[i]
            lam = t / self.legs[i].duration
            s = np.pi * lam * np.arange(1, 4)
            return np.concatenate([(1 - lam) * a + lam * b, u + amp @ np.sin(s)])

        return self.pack(states)

    def interpolate(self, legs: list[dict]) -> np.ndarray:
        """A guess on this mesh from a solution on another mesh (same legs)."""
        source = []
        for part in legs:
            t, h = part["t"], np.diff(part["t"])
            times = np.concatenate([[0.0], (t[:-1, None] + h[:, None] * self.tau[1:]).ravel()])
            values = np.vstack([part["X"][0], part["colloc"].reshape(-1, part["X"].shape[1])])
            source.append((times, values))

        def states(i, t):
            times, values = source[i]
            return np.array([np.interp(t, times, values[:, c]) for c in range(values.shape[1])])

        return self.pack(states)

    def solve(self, x0: np.ndarray) -> dict:
        clock = time.perf_counter()
        sol = self.solver(x0=x0, lbg=0.0, ubg=0.0)
        seconds = time.perf_counter() - clock
        stats = self.solver.stats()
        return {
            "x": np.asarray(sol["x"]).ravel(),
            "energy": float(sol["f"]),
            "status": stats["return_status"],
            "success": bool(stats["success"]),
            "iterations": int(stats["iter_count"]),
            "seconds": seconds,
            "violation": float(np.abs(np.asarray(sol["g"])).max(initial=0.0)),
        }

    def check(self, x: np.ndarray) -> dict:
        """Re-integrate the controls (exactly piecewise linear) with solve_ivp, interval by
        interval, legs chained from the task's start; goal error per leg (Euclidean norm over
        the prescribed coordinates, as stratplan measures it) and the exact energy."""
        q = np.asarray(self.task.start, dtype=float)
        errors, energy = [], 0.0
        for leg, part in zip(self.legs, self.unpack(x), strict=True):
            t, U = part["t"], part["X"][:, self.n :]
            h = np.diff(t)
            energy += float(np.sum(h[:, None] * (U[:-1] ** 2 + U[:-1] * U[1:] + U[1:] ** 2)) / 3)
            G = leg.G_numpy
            for k in range(self.nodes):
                slope = (U[k + 1] - U[k]) / h[k]

                def rhs(s, y, G=G, u=U[k], slope=slope):
                    return G(y) @ (u + slope * s)

                q = solve_ivp(rhs, (0.0, h[k]), q, method="DOP853", rtol=1e-12, atol=1e-13).y[:, -1]
            tg = leg.targets
            errors.append(float(np.linalg.norm(q[tg] - leg.goal[tg])) if tg else 0.0)
        return {"goal_errors": errors, "goal_error": max(errors), "energy_exact": energy}


def _plan_guess(problem: _Collocation, plan) -> np.ndarray:
    """A guess from a stratplan plan (`PlanResult`): its Fourier controls on each leg and the
    configurations they produce (integrated from the leg's start)."""
    tracks = []
    for leg, result in zip(problem.legs, plan.legs, strict=True):

        def u_of(t, result=result, leg=leg):
            return result.controls(np.array([t]))[0][list(leg.active)]

        def rhs(t, y, G=leg.G_numpy, u_of=u_of):
            return G(y) @ u_of(t)

        sol = solve_ivp(
            rhs, (0.0, leg.duration), result.start, rtol=1e-9, atol=1e-11, dense_output=True
        )
        tracks.append((sol.sol, u_of))

    def states(i, t):
        q_of, u_of = tracks[i]
        return np.concatenate([q_of(t), u_of(t)])

    return problem.pack(states)


def solve_bound(
    task: Task,
    nodes_per_leg: int = NODES,
    starts: int = STARTS,
    *,
    coarse_nodes: int | None = COARSE_NODES,
    refine: int = REFINE,
    initial: dict | None = None,
    plans: tuple = (),
    check: bool = True,
    mesh_kind: str = "graded",
    conditions: bool = True,
) -> dict:
    """Minimum ∫|u|² over free controls for the task's leg sequence.

    Multi-start: `starts` deterministic guesses (zero controls, the least-squares constant
    velocity, seeded perturbations of it) are solved on a coarse mesh of `coarse_nodes`
    intervals per leg *without* the control conditions (same basins, found more often), the
    `refine` best distinct local optima are interpolated onto the mesh of `nodes_per_leg`
    intervals and solved again with all conditions; the best is the bound. `initial` (a previous
    result, e.g. on a coarser mesh) is interpolated and solved as one more start. `plans`
    ((label, stratplan PlanResult) pairs) are solved as extra starts *seeded by stratplan*:
    their time is reported apart (`seeded_seconds`), not in `seconds`.
    `conditions=False` drops the control boundary conditions (switches, soft start, full stop).

    Returns energy, status, success, best_start, seconds (IPOPT wall time of the unseeded
    starts: coarse and fine solves), best_seconds (the winning start's own solves),
    seeded_seconds, cold_energy (best without stratplan's help), build_seconds (symbolic NLP
    construction and IPOPT set-up), runs (one dict per solve), nodes_per_leg, variables,
    constraints, legs (the solution), violation, and with `check` the re-integration: goal_error
    (max over legs), goal_errors, energy_exact.
    """
    if ca is None:
        raise ImportError("casadi is not installed: pip install -e '.[bench]'")
    clock = time.perf_counter()
    fine = _Collocation(task, nodes_per_leg, mesh_kind, conditions)
    two_level = starts > 0 and coarse_nodes is not None and coarse_nodes < nodes_per_leg
    # The multi-start runs without the control conditions: they cost no energy in the limit,
    # so the basins are the same, and the relaxed problem finds the low ones more often.
    coarse = _Collocation(task, coarse_nodes, mesh_kind, False) if two_level else fine
    build = time.perf_counter() - clock

    kinds = ["zero", "ramp"] + [f"perturbed-{s}" for s in range(max(starts - 2, 0))]
    runs: list[dict] = []
    candidates = []
    for kind in kinds[:starts]:
        name, _, seed = kind.partition("-")
        run = coarse.solve(coarse.guess(name, int(seed or 0)))
        run.update(kind=kind, nodes=coarse.nodes, chain=run["seconds"])
        runs.append(run)
        candidates.append(run)
    finals = []
    if two_level:
        distinct: list[dict] = []
        for run in sorted(candidates, key=lambda r: _key(r)):
            if len(distinct) == refine:
                break
            if all(abs(run["energy"] - d["energy"]) > 1e-4 * abs(d["energy"]) for d in distinct):
                distinct.append(run)
        for run in distinct:
            out = fine.solve(fine.interpolate(coarse.unpack(run["x"])))
            out.update(kind=run["kind"], nodes=fine.nodes, chain=run["seconds"] + out["seconds"])
            runs.append(out)
            finals.append(out)
    else:
        finals = list(candidates)
    if initial is not None:
        out = fine.solve(fine.interpolate(initial["legs"]))
        out.update(kind="interpolated", nodes=fine.nodes, chain=out["seconds"])
        runs.append(out)
        finals.append(out)
    cold_seconds = sum(r["seconds"] for r in runs)
    seeded = []
    for label, plan in plans:
        out = fine.solve(_plan_guess(fine, plan))
        out.update(kind=f"stratplan {label}", nodes=fine.nodes, chain=out["seconds"])
        runs.append(out)
        seeded.append(out)
    if not finals and not seeded:
        raise ValueError("no start: give starts > 0, initial or plans")
    best = min(finals + seeded, key=_key)
    cold = min(finals, key=_key) if finals else None
    result = {
        "energy": best["energy"],
        "status": best["status"],
        "success": best["success"],
        "best_start": best["kind"],
        "seconds": cold_seconds,
        "best_seconds": best["chain"],
        "seeded_seconds": sum(r["seconds"] for r in seeded),
        "cold_energy": cold["energy"] if cold and cold["success"] else float("nan"),
        "build_seconds": build,
        "runs": [{k: v for k, v in r.items() if k != "x"} for r in runs],
        "nodes_per_leg": nodes_per_leg,
        "mesh": mesh_kind,
        "variables": fine.size,
        "constraints": fine.n_constraints,
        "legs": fine.unpack(best["x"]),
        "violation": best["violation"],
    }
    if check:
        result.update(fine.check(best["x"]))
    return result


def _key(run: dict) -> tuple:
    """Successful solves first, then by energy."""
    energy = run["energy"] if np.isfinite(run["energy"]) else np.inf
    return (not run["success"], energy)


def scenario_paths(names: list[str] | None = None) -> list[Path]:
    names = names or list(PAPER_SCENARIOS)
    return [Path(n) if n.endswith(".toml") else ROOT / "scenarios" / f"{n}.toml" for n in names]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", help="names or paths (default: the paper's)")
    parser.add_argument("--nodes", type=int, default=NODES, help="intervals per leg")
    parser.add_argument("--starts", type=int, default=STARTS, help="deterministic IPOPT starts")
    parser.add_argument("--coarse-nodes", type=int, default=COARSE_NODES)
    parser.add_argument("--mesh", choices=("graded", "uniform"), default="graded")
    parser.add_argument("--no-refine", action="store_true", help="skip the check with 2N")
    parser.add_argument(
        "--without-conditions",
        action="store_true",
        help="also solve without the control boundary conditions (their continuous limit)",
    )
    args = parser.parse_args(argv)
    if ca is None:
        sys.exit("casadi is not installed: pip install -e '.[bench]'")
    N = args.nodes
    print(f"$ python benchmarks/casadi_baseline.py {' '.join(argv or sys.argv[1:])}".rstrip())
    print(
        f"{machine()}, Python {platform.python_version()}, CasADi {ca.__version__}; Radau "
        f"degree {DEGREE}, {args.mesh} mesh of N = {N} intervals per leg; {args.starts} starts "
        f"on N = {args.coarse_nodes}, best {REFINE} refined\n"
    )
    head = [
        "scenario",
        "conditions",
        f"bound N={N}",
        f"bound N={2 * N}",
        "change",
        f"goal error N={N}",
        f"goal error N={2 * N}",
        "energy re-check",
    ]
    if args.without_conditions:
        head.append(f"without control conditions N={N}")
    head += ["best start", "IPOPT s (all starts)", "IPOPT s (best start)", "build s", "status"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for path in scenario_paths(args.scenarios):
        task = load_scenario(path)
        s = task.settings
        mode = s.continuity + (" +soft" if s.soft_start else "") + (" +stop" if s.full_stop else "")
        options = {"coarse_nodes": args.coarse_nodes, "mesh_kind": args.mesh}
        r = solve_bound(task, N, args.starts, **options)
        fine = None
        if not args.no_refine:
            fine = solve_bound(task, 2 * N, 0, initial=r, mesh_kind=args.mesh)
        cells = [
            task.scenario.name,
            mode,
            f"{r['energy']:.3f}",
            f"{fine['energy']:.3f}" if fine else "–",
            f"{100 * (fine['energy'] / r['energy'] - 1):+.2f} %" if fine else "–",
            f"{r['goal_error']:.1e}",
            f"{fine['goal_error']:.1e}" if fine else "–",
            f"{abs(r['energy_exact'] / r['energy'] - 1):.0e}",
        ]
        if args.without_conditions:
            free = solve_bound(task, N, args.starts, conditions=False, check=False, **options)
            cells.append(f"{free['energy']:.3f}")
        cells += [
            r["best_start"],
            f"{r['seconds']:.2f}",
            f"{r['best_seconds']:.2f}",
            f"{r['build_seconds']:.2f}",
            r["status"],
        ]
        print("| " + " | ".join(cells) + " |", flush=True)


def machine() -> str:
    """CPU model (lscpu), else platform.processor()."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=5).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return platform.processor() or platform.machine()


if __name__ == "__main__":
    main()
