"""Spatial free-floating manipulators from URDF, built on Pinocchio.

The configuration is `(R, q)`: base attitude `R ∈ SO(3)` and the angles `q` of the revolute
joints (Pinocchio's order, which is the URDF's depth-first order). A plan's coordinates are
`(q_1..q_k, rx, ry, rz)`, the attitude as its rotation vector `log(R)` (rad, world frame);
the planners never integrate it in those coordinates: the end-point map integrates `R` on the
group (`stratcli.magnus`) and only reports `log(R(T))`.

Zero total momentum fixes the base twist `ν = S(q) q̇` (6×k, base frame, `[v; ω]`) with
`S = −A_b⁻¹ A_j` from the centroidal map `A_g = [A_b A_j]` (Pinocchio, base at the identity:
`S` does not depend on `R`). Its derivative along the joints contracted with the joint rates,
`∂(S u)/∂q`, comes from Pinocchio's analytic centroidal-momentum derivatives
(`∂h/∂q` at the zero-momentum velocity), one call per point.

Pinocchio (`pip install 'stratplan[spatial]'`) is imported only here, on first use.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .. import so3
from ..errors import InputError, ModelError, Problem
from .manipulator import locked_strata
from .system import Stratum, System
from .urdf import UrdfSummary, lock_indices, native_stderr, read_urdf, urdfdom_errors

__all__ = ["INSTALL", "SpatialRobot", "SpatialStratum", "SpatialSystem", "load_pinocchio"]

INSTALL = "pip install 'stratplan[spatial]' (in a source checkout: pip install -e '.[spatial]')"
ATTITUDE = ("rx", "ry", "rz")


def load_pinocchio():
    """The `pinocchio` module, or an `InputError` with the exact install command."""
    try:
        import pinocchio
    except ImportError:
        raise InputError(
            [
                Problem(
                    "model.kind",
                    f"URDF models need Pinocchio, which is not installed; install it with: "
                    f"{INSTALL}",
                )
            ]
        ) from None
    return pinocchio


class SpatialRobot:
    """A free-flying base carrying revolute joints, from a URDF (Pinocchio model inside).

    Pickles as its URDF text (Pinocchio's model is rebuilt where it is unpickled).
    """

    def __init__(self, text: str, summary: UrdfSummary, path: str = "", base: str | None = None):
        self.text, self.summary, self.path = text, summary, path
        self.base = base or summary.root
        if self.base != summary.root:
            raise InputError(
                [
                    Problem(
                        "model.base",
                        f"must be the URDF's root link {summary.root!r} (re-rooting a URDF at "
                        f"another link is not supported yet), got {self.base!r}",
                    )
                ]
            )
        self._build()

    def _build(self) -> None:
        pin = load_pinocchio()
        self._pin = pin
        try:  # urdfdom's reasons, printed on stderr with C++ source lines, go in the message
            with native_stderr() as said:
                self.model = pin.buildModelFromXML(self.text, pin.JointModelFreeFlyer())
        except (RuntimeError, ValueError) as exc:
            why = urdfdom_errors(said) or str(exc)
            raise InputError([Problem("model.path", f"Pinocchio cannot load it: {why}")]) from None
        if said and sys.stderr is not None:  # what it said of a model it loaded: passed on
            print("\n".join(said), file=sys.stderr)  # (file=None would print on stdout)
        self.data = self.model.createData()
        model = self.model
        names = list(model.names)[2:]
        for j, name in enumerate(names, start=2):
            if model.joints[j].nq != 1 or model.joints[j].nv != 1:
                raise InputError(
                    [Problem("model.path", f"joint {name!r} is not a 1-DoF revolute joint")]
                )
        self.joint_names = tuple(names)
        self.iq = np.array([model.joints[j].idx_q for j in range(2, model.njoints)])
        self.iv = np.array([model.joints[j].idx_v for j in range(2, model.njoints)])
        self.lower = np.asarray(model.lowerPositionLimit)[self.iq].copy()
        self.upper = np.asarray(model.upperPositionLimit)[self.iq].copy()
        # the URDF's <limit velocity>, rad/s (not used: `[constraints] max_rate` is; shown by
        # `stratplan models` so that it can be copied there)
        self.velocity = np.asarray(model.velocityLimit)[self.iv].copy()
        self.mass = float(sum(inertia.mass for inertia in model.inertias))
        if not self.mass > 0:
            raise InputError([Problem("model.path", "the robot has no mass")])
        # joints whose moved links carry no mass or inertia: they turn nothing (a hint when
        # a stratum of them is not controllable, `api.check`)
        self.inert_joints = tuple(
            model.names[j]
            for j in range(2, model.njoints)
            if all(
                model.inertias[i].mass == 0.0 and not np.any(model.inertias[i].inertia)
                for i in model.subtrees[j]
            )
        )
        self._neutral = np.asarray(pin.neutral(model), dtype=float)
        self.link_names = tuple(f.name for f in model.frames if f.type == pin.FrameType.BODY)

    def __getstate__(self) -> dict:
        return {"text": self.text, "summary": self.summary, "path": self.path, "base": self.base}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._build()

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def configuration(self, q: np.ndarray, R: np.ndarray | None = None, p=None) -> np.ndarray:
        """Pinocchio's `q` (position, quaternion x y z w, joints) for joints `q` and pose."""
        x = self._neutral.copy()
        x[self.iq] = q
        if R is not None:
            w, qx, qy, qz = so3.quaternion_from_matrix(R)
            x[3:7] = (qx, qy, qz, w)
        if p is not None:
            x[:3] = p
        return x

    def _centroidal_maps(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pinocchio configurations X (K, nq) for joint angles q (K, k) and the centroidal
        momentum maps there (K, 6, nv)."""
        model, data = self.model, self.data
        q = np.atleast_2d(np.asarray(q, dtype=float))
        X = np.repeat(self._neutral[None], q.shape[0], axis=0)
        X[:, self.iq] = q
        Ag = np.empty((q.shape[0], 6, model.nv))
        centroidal_map = self._pin.computeCentroidalMap
        for i, x in enumerate(X):  # the per-point cost is this loop's own: keep it bare
            Ag[i] = centroidal_map(model, data, x)
        return X, Ag

    def connection(
        self, q: np.ndarray, u: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """`S(q)` (K, 6, k) at joint angles q (K, k), and with rates `u` (K, k) also
        `D = ∂(S_ω u)/∂q` (K, 3, k), the angular rows' derivative along the joints."""
        pin, model, data = self._pin, self.model, self.data
        X, Ag = self._centroidal_maps(q)
        K = X.shape[0]
        Ab = Ag[:, :, :6]
        S = -np.linalg.solve(Ab, Ag[:, :, self.iv])
        if u is None:
            return S, None
        u = np.atleast_2d(np.asarray(u, dtype=float))
        V = np.zeros((K, model.nv))
        V[:, :6] = (S @ u[:, :, None])[:, :, 0]
        V[:, self.iv] = u
        zero = np.zeros(model.nv)
        dh = np.empty((K, 6, model.nv))
        derivatives = pin.computeCentroidalDynamicsDerivatives
        for i in range(K):
            dh[i] = derivatives(model, data, X[i], V[i], zero)[0]
        dh = dh[:, :, self.iv]
        D = -np.linalg.solve(Ab, dh)[:, 3:]
        return S, D

    def angular(
        self, q: np.ndarray, u: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """`S_ω(q)` (K, 3, k) and with `u` also `D` (K, 3, k): what planning needs.

        The angular momentum about the CoM does not see the base's linear velocity (a uniform
        translation), so the angular rows of the centroidal map alone fix `ω`:
        `S_ω = −A_ωω⁻¹ A_ωq`, a 3×3 solve (in closed form here) instead of the 6×6 one.
        """
        S, state = self.angular_map(q)
        return S, (None if u is None else self.angular_derivative(state, S, u))

    def angular_map(self, q: np.ndarray) -> tuple[np.ndarray, tuple]:
        """`S_ω(q)` (K, 3, k) and what `angular_derivative` needs at the same points."""
        X, Ag = self._centroidal_maps(q)
        inverse = _inverse3(Ag[:, 3:, 3:6])
        return -inverse @ Ag[:, 3:, self.iv], (X, inverse)

    def angular_derivative(self, state: tuple, S: np.ndarray, u: np.ndarray) -> np.ndarray:
        """`D = ∂(S_ω u)/∂q` (K, 3, k) at the points of `angular_map` (its `S` and state),
        for joint rates `u` (K, k): added only when a Jacobian is wanted."""
        pin, model, data = self._pin, self.model, self.data
        X, inverse = state
        K = X.shape[0]
        u = np.atleast_2d(np.asarray(u, dtype=float))
        V = np.zeros((K, model.nv))
        V[:, 3:6] = (S @ u[:, :, None])[:, :, 0]  # the base's linear velocity changes no
        V[:, self.iv] = u  # angular momentum about the CoM: left at zero
        zero = np.zeros(model.nv)
        dh = np.empty((K, 6, model.nv))
        derivatives = pin.computeCentroidalDynamicsDerivatives
        for i, (x, v) in enumerate(zip(X, V, strict=True)):
            dh[i] = derivatives(model, data, x, v, zero)[0]
        return -inverse @ dh[:, 3:, self.iv]

    def com_in_base(self, q: np.ndarray) -> np.ndarray:
        """The system CoM in the base frame (K, 3) at joint angles q (K, k)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return np.array(
            [self._pin.centerOfMass(self.model, self.data, self.configuration(qi)) for qi in q]
        )

    def base_position(self, q: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Base origin in the world frame with the system CoM at the origin: `−R c(q)`."""
        c = self.com_in_base(q)
        return -(np.asarray(R) @ c[..., None])[..., 0]

    def momentum(self, q: np.ndarray, R: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """Total momentum (6,) about the CoM, world axes, of the motion with joint rates
        `rates` and the base twist the connection gives (an audit: it should be ~0)."""
        S, _ = self.connection(q[None])
        v = np.concatenate([S[0] @ rates, rates])
        x = self.configuration(q, R)
        return np.asarray(self._pin.computeCentroidalMap(self.model, self.data, x) @ v)

    def link_poses(self, q: np.ndarray, R: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """World pose (position, rotation) of every body link at joints q and attitude R."""
        pin = self._pin
        x = self.configuration(q, R, self.base_position(q[None], R)[0])
        pin.framesForwardKinematics(self.model, self.data, x)
        out = {}
        for i, frame in enumerate(self.model.frames):
            if frame.type == pin.FrameType.BODY:
                placement = self.data.oMf[i]
                out[frame.name] = (placement.translation.copy(), placement.rotation.copy())
        return out

    def base_box(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The base body as the uniform box of its mass and inertia (a URDF carries no shape
        the planner reads): centre and axes in the base frame, and the edge lengths (m).

        A uniform box of mass m and edges a, b, c has I = m(b² + c²)/12 about its a axis
        (and so on), so a² = 6(I_b + I_c − I_a)/m over the principal moments.
        """
        inertia = self.model.inertias[1]  # the free-flyer's body: the base and what is fixed to it
        moments, axes = np.linalg.eigh(np.asarray(inertia.inertia, dtype=float))
        mass = max(float(inertia.mass), 1e-12)
        edges = np.sqrt(np.maximum(6.0 * (moments.sum() - 2.0 * moments) / mass, 0.0))
        return np.asarray(inertia.lever, dtype=float).copy(), axes, edges


def _inverse3(A: np.ndarray) -> np.ndarray:
    """Inverses of 3×3 matrices (K, 3, 3) by cross products (adjugate over determinant)."""
    a0, a1, a2 = A[:, :, 0], A[:, :, 1], A[:, :, 2]
    rows = np.stack([so3.cross(a1, a2), so3.cross(a2, a0), so3.cross(a0, a1)], axis=1)
    det = np.einsum("ki,ki->k", a0, rows[:, 0])
    return rows / det[:, None, None]


@dataclass
class SpatialStratum:
    """The interface of `CompiledStratum` for a spatial stratum; its end-point map is
    `MagnusEndpoint` (the joints in closed form, the attitude on the group)."""

    system: SpatialSystem
    stratum: Stratum

    def __post_init__(self) -> None:
        k = self.system.spatial.n_joints
        self.k = k
        self.act = np.array(self.stratum.active, dtype=int)
        self.explicit = tuple(range(k))
        self.quadrature = ()
        self.C_explicit = np.eye(k)[:, self.act]
        self.supports_quadrature = True  # the quadrature structure, with a group update

    def residual(self, end, J, aim, targets):
        """End minus goal with the attitude on the group (`magnus.residual_on_group`)."""
        from ..magnus import residual_on_group

        return residual_on_group(end, J, aim, targets, self.k)

    def endpoint(self, q0, basis, duration):
        from ..magnus import MagnusEndpoint

        return MagnusEndpoint(self, q0, basis, duration)

    def G(self, y: np.ndarray) -> np.ndarray:
        """`y' = G(y) u` in the plan's coordinates (joints, rotation vector), (..., n, m):
        the attitude row is `J_r⁻¹(φ) S_ω(q)`, valid while |φ| < π (re-integration only)."""
        y = np.asarray(y, dtype=float)
        lead, k, m = y.shape[:-1], self.k, self.act.size
        flat = y.reshape(-1, k + 3)
        S, _ = self.system.spatial.angular(flat[:, :k])
        out = np.zeros((flat.shape[0], k + 3, m))
        out[:, self.act, np.arange(m)] = 1.0
        out[:, k:, :] = so3.right_jacobian_inverse(flat[:, k:]) @ S[:, :, self.act]
        return out.reshape(*lead, k + 3, m)

    def dG(self, y: np.ndarray) -> np.ndarray:
        """`∂G/∂y` (..., n, m, n) by central differences (the general ODE path only)."""
        y = np.asarray(y, dtype=float)
        n, h = y.shape[-1], 1e-6
        cols = [(self.G(y + h * e) - self.G(y - h * e)) / (2 * h) for e in np.eye(n)]
        return np.stack(cols, axis=-1)


class _NoFields(ModelError, AttributeError):
    """A URDF model's `fields`: a `ModelError` that is an AttributeError as well, so that
    `hasattr(system, "fields")` answers False instead of raising."""


class SpatialSystem(System):
    """A `System` on SO(3)×Rᵏ from a URDF; coordinates `(joints..., rx, ry, rz)`."""

    def __init__(
        self,
        robot: SpatialRobot,
        lock_sets: list[tuple[int, ...]] | None = None,
        name: str = "urdf",
    ):
        k = robot.n_joints
        if set(robot.joint_names) & set(ATTITUDE):
            raise InputError(
                [Problem("model.path", f"joint names {ATTITUDE} are reserved for the attitude")]
            )
        states = (*robot.joint_names, *ATTITUDE)
        inputs = tuple(f"u_{j}" for j in robot.joint_names)
        strata = locked_strata(k, lock_sets)
        limits = ", ".join(
            f"{name} [{lo:.3g}, {hi:.3g}]"
            for name, lo, hi in zip(robot.joint_names, robot.lower, robot.upper, strict=True)
        )
        v = robot.velocity  # (a URDF without them: Pinocchio's placeholder, no limit)
        speeds = (
            f"; the URDF's velocity limits, not used unless copied to [constraints]: max_rate "
            f"= [{', '.join(f'{x:g}' for x in v)}] (rad/s)"
            if np.all(np.isfinite(v) & (v > 0) & (v < 1e6))
            else ""
        )
        description = (
            f"URDF robot {robot.summary.name!r}, {robot.mass:.4g} kg: {k} revolute joints "
            f"(limits, rad: {limits}) on a free-flying base {robot.base!r}; attitude rx, ry, rz "
            f"= rotation vector log(R), rad, world frame{speeds}"
        )
        super().__init__(name, states, inputs, None, strata, description=description)
        self.spatial = robot

    @property
    def fields(self):
        raise _NoFields(
            [Problem("model", "a URDF model has no symbolic vector fields (numeric only)")]
        )

    @fields.setter
    def fields(self, value) -> None:
        pass

    def _value(self) -> tuple:
        """What it compares by: `System`'s fields, with the URDF's text in place of the
        symbolic fields it has not (the dataclass's `==` read `fields`, which raises here:
        a URDF model was unequal to nothing, itself included: it raised)."""
        return (
            self.name, self.states, self.inputs, dict(self.strata), dict(self.parameters),
            self.description, self.spec, self.spatial.text,
        )  # fmt: skip

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._value() == other._value()

    __hash__ = None  # (as `System`'s: its strata are a mapping)

    def __repr__(self) -> str:  # the dataclass's would read `fields`, which raises here
        return (
            f"SpatialSystem({self.spatial.summary.name!r}: coordinates "
            f"{', '.join(self.states)}; strata {', '.join(self.strata)})"
        )

    @cached_property
    def attitude(self) -> slice:
        """Where the rotation vector sits in a configuration."""
        return slice(self.n - 3, self.n)

    def compiled(self, stratum):
        s = self.stratum(stratum) if isinstance(stratum, str) else stratum
        if s.name not in self._compiled:
            self._compiled[s.name] = SpatialStratum(self, s)
        return self._compiled[s.name]


def load_spatial(path: str | Path, base: str | None = None, strata=None) -> SpatialSystem:
    """A `SpatialSystem` from a URDF file; `strata` are lock sets of joint names."""
    text, summary = read_urdf(Path(path))
    robot = SpatialRobot(text, summary, str(path), base)
    lock_sets = None if strata is None else lock_indices(strata, robot.joint_names, summary)
    return SpatialSystem(robot, lock_sets)
